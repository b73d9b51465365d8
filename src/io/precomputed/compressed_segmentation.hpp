#pragma once
// Neuroglancer's compressed_segmentation chunk encoding of uint32 and uint64 label volumes: each
// block of a fixed size (8^3 usually) stores a lookup table of its distinct ids and, per voxel, an
// index into it of 0, 1, 2, 4, 8, 16 or 32 bits.
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "strata/core/dtype.hpp"
#include "strata/core/extent.hpp"

namespace strata::io::detail::precomputed {

// Decodes channel `channel` of a chunk of `channels` channels and `chunk` voxels, encoded with
// `block`-sized blocks, into `out` (chunk.voxel_count() samples of `dtype`, u32 or u64, x
// fastest). Every offset, table index and bit width is checked against the data: malformed
// input throws FormatError(file, "compressed_segmentation", ...).
void decode_compressed_segmentation(std::span<const std::byte> data, const Extent& chunk, const Extent& block,
                                    std::int64_t channels, std::int64_t channel, DType dtype, std::byte* out,
                                    const std::string& file);

// The one-channel encoding of `chunk` voxels of `dtype` (u32 or u64, x fastest) at `samples`.
std::vector<std::byte> encode_compressed_segmentation(const std::byte* samples, const Extent& chunk,
                                                      const Extent& block, DType dtype);

}  // namespace strata::io::detail::precomputed
