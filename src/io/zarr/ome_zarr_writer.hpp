#pragma once
// The OME-Zarr writer of the zarr format entry: level 0 streamed slab by slab (the public
// write_ome_zarr_pyramid, strata/io/ome_zarr.hpp, writes every level).
#include <filesystem>
#include <memory>

#include "strata/io/volume_io.hpp"

namespace strata::io::detail {

// Writes `info` as a one-level OME-Zarr 0.4 image at the folder `path` (through `<path>.tmp`).
std::unique_ptr<VolumeWriter> make_ome_zarr_writer(const std::filesystem::path& path, const VolumeInfo& info,
                                                   const WriteOptions& options);

}  // namespace strata::io::detail
