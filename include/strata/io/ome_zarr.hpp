#pragma once
/// @file
/// @brief OME-Zarr output beyond the single-level VolumeWriter: every resolution level of a
/// volume as one multiscale image, the way `strata decompress -o x.ome.zarr` writes a `.strata`
/// file's pyramid.
#include <filesystem>
#include <vector>

#include "strata/io/volume_io.hpp"

namespace strata::io {

/// @brief Writes `levels` (the finest first, each a coarser resolution of the same volume) as an
/// OME-Zarr 0.4 image at the folder `path`: a Zarr v2 group whose arrays "0", "1", ... hold the
/// levels in 64^3 chunks (blosc-zstd, or uncompressed when options.compress is false), and whose
/// `.zattrs` multiscales give each level its scale (the level's spacing) and translation (its
/// geometry's origin) along axes z, y, x of level 0's unit. Each level is read from its source
/// one chunk row (64 slices) at a time. The image is written to `<path>.tmp` and renamed to
/// `path` at the end (replacing what was there); on any error nothing is left behind.
/// Throws ParameterError("levels") when `levels` is empty or the levels differ in sample type.
void write_ome_zarr_pyramid(const std::filesystem::path& path, const std::vector<VolumeSource*>& levels,
                            const WriteOptions& options = {});

}  // namespace strata::io
