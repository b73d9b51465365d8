#pragma once
// A chunk's encoded bytes to samples and back, for the three encodings of the format.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "io/precomputed/info.hpp"

namespace strata::io::detail::precomputed {

// The largest encoded (gzip removed) chunk of `extent` voxels accepted: what the worst
// compressed_segmentation (1-voxel blocks: a header and a table entry per voxel) can take.
std::uint64_t max_encoded_chunk_bytes(const Extent& extent, const VolumeDescription& description);

// Channel `channel` of the chunk of `extent` voxels (its part inside the volume), x fastest;
// FormatError(file, ...) when the bytes do not hold such a chunk.
std::vector<std::byte> decode_chunk(const std::vector<std::byte>& encoded, const Extent& extent, const Scale& scale,
                                    const VolumeDescription& description, std::int64_t channel,
                                    const std::string& file);

// The one-channel encoding (raw, jpeg at the scale's jpeg_quality for u8, or
// compressed_segmentation) of `extent` voxels of `dtype`.
std::vector<std::byte> encode_chunk(const std::byte* samples, const Extent& extent, const Scale& scale, DType dtype);

}  // namespace strata::io::detail::precomputed
