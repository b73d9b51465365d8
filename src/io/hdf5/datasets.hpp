#pragma once
// Finding the volume in an HDF5 file: every dataset the file links to, which of them a volume
// reader can open (numeric, rank 3 to 5), and the one to open when the caller names none.
#include <hdf5.h>

#include <string>
#include <vector>

namespace strata::io::detail::hdf5 {

/// @brief A dataset of the file, as listed to a user who must pick one.
struct DatasetEntry {
  std::string path;   // "/entry/data/data"
  std::string shape;  // "(2, 64, 512, 512)", C order as h5py prints it
  std::string type;   // "u16", "string", ...
  bool is_volume = false;  // numeric of rank 3, 4 or 5
};

/// @brief Every dataset reachable from the root group through hard links, in name order; at
/// most `limit` of them (a hostile file may link millions). Call with the library lock held.
std::vector<DatasetEntry> list_datasets(hid_t file, std::size_t limit);

/// @brief "/a (64, 64, 64) u8, /b (3,) f64": entries for a message, the volumes first.
std::string datasets_text(const std::vector<DatasetEntry>& entries);

/// @brief The path of the dataset to open when the caller named none: the file's only volume
/// dataset. Throws FormatError(file, "dataset", ...) listing every dataset with its shape and type
/// when there is none or several. Call with the library lock held.
std::string only_volume_dataset(hid_t file, const std::string& file_name);

}  // namespace strata::io::detail::hdf5
