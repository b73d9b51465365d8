#pragma once
// The OME-Zarr writer of the zarr format entry: level 0 streamed slab by slab (the public
// write_ome_zarr_pyramid, strata/io/ome_zarr.hpp, writes every level).
#include <filesystem>
#include <memory>

#include <nlohmann/json.hpp>

#include "strata/io/volume_io.hpp"

namespace strata::io::detail {

// Writes `info` as a one-level OME-Zarr 0.4 image at the folder `path` (through `<path>.tmp`).
std::unique_ptr<VolumeWriter> make_ome_zarr_writer(const std::filesystem::path& path, const VolumeInfo& info,
                                                   const WriteOptions& options);

// The `.zattrs` of an OME-Zarr 0.4 image named `name` whose datasets "0", "1", ... are `levels`.
nlohmann::json multiscales_attributes(const std::string& name, const std::vector<VolumeInfo>& levels);
// The chunk shape (x, y, z) of a level's array: 64^3 clipped to its dims.
Extent ome_zarr_chunk_shape(const VolumeInfo& level);
// The `.zarray` of a level's array (blosc-zstd, or no compressor).
nlohmann::json ome_zarr_array_metadata(const VolumeInfo& level, bool compress);
// The stored bytes of a chunk of shape `chunk` whose part inside the array is `part`: zero-padded
// to the whole chunk, blosc-zstd compressed when `compress`.
std::vector<std::byte> ome_zarr_stored_chunk(const Volume& part, const Extent& chunk, bool compress);

}  // namespace strata::io::detail
