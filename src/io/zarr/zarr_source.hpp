#pragma once
// A VolumeSource over one Zarr array: read_box decodes only the chunks the box touches and keeps
// the most recently used ones (a bounded number of bytes) so consecutive z slabs through the
// same chunk row decode each chunk once. Thread safe.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <vector>

#include "io/zarr/zarr_array.hpp"
#include "strata/io/volume_io.hpp"

namespace strata::io::detail {

// Decoded chunks a source keeps: enough for a chunk row of a 2048 x 2048 slice of 64^3 u16
// chunks, small beside the memory limits volumes are compressed under.
inline constexpr std::uint64_t kZarrCacheBytes = 256u << 20;
// And at most this many, however small they are (each entry costs a few hundred bytes itself).
inline constexpr std::uint64_t kZarrCacheChunks = 1u << 16;

// Where in the array the source reads: the array's last `spatial` axes (2 or 3) are z, y, x (y,
// x for 2), the leading ones are fixed at `leading_index` (one volume of a t/c series).
struct ZarrView {
  int spatial = 3;
  std::vector<std::int64_t> leading_index;
};

// `info` carries dims, dtype, spacing, volumes and geometry as the caller worked them out;
// `path` is what errors and path() name.
std::unique_ptr<VolumeSource> make_zarr_source(ZarrArray array, ZarrView view, VolumeInfo info,
                                               std::filesystem::path path);

}  // namespace strata::io::detail
