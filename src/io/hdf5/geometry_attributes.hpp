#pragma once
// A volume's voxel size and placement as attributes of its HDF5 dataset. HDF5 itself has no
// notion of either; these are the conventions the files our users have follow.
//
// Attributes read (on the dataset; all optional) and written:
// | attribute         | type                  | meaning                                             |
// | ----------------- | --------------------- | --------------------------------------------------- |
// | spacing           | 3 numbers, x y z      | voxel size in `unit` (Strata; wins over the next)    |
// | element_size_um   | 3 numbers, z y x      | voxel size in micrometres (ilastik, Fiji's plugin)   |
// | origin            | 3 numbers, x y z      | centre of voxel (0, 0, 0) in `unit`                  |
// | direction         | 9 numbers, row-major  | column c: unit vector of index axis c (x, y, z)      |
// | unit              | string                | "mm", "um", "nm", "angstrom", ... of the above       |
// | space             | string                | "RAS" or "LPS" when the world axes are anatomical    |
// element_size_um is written only when `unit` converts to micrometres.
#include <hdf5.h>

#include <string>

#include "strata/core/volume.hpp"

namespace strata::io::detail::hdf5 {

/// @brief Fills info.spacing and info.geometry from the attributes of `dataset` (left at their
/// defaults when absent). Throws FormatError(file, "attribute <name>", ...) for an attribute of
/// the wrong type or count, a spacing that is not positive and finite, a direction whose columns
/// are not unit vectors, or a space other than RAS / LPS. Call with the library lock held.
void read_geometry_attributes(hid_t dataset, const std::string& file, VolumeInfo& info);

/// @brief Writes info's spacing and geometry as the attributes above. Throws Error naming `file`
/// when the library refuses. Call with the library lock held.
void write_geometry_attributes(hid_t dataset, const std::string& file, const VolumeInfo& info);

}  // namespace strata::io::detail::hdf5
