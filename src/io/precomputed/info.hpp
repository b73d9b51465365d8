#pragma once
// The `info` JSON file at the root of a Neuroglancer precomputed volume: what the reader needs of
// it (validated, so nothing later computes from an unchecked size) and its JSON form for the writer.
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "strata/core/dtype.hpp"
#include "strata/core/extent.hpp"

namespace strata::io::detail::precomputed {

enum class ChunkEncoding { raw, jpeg, compressed_segmentation };

// A scale's "sharding" member (sharded.md): how chunk ids map to shard files.
struct ShardingSpec {
  int preshift_bits = 0;
  bool murmurhash = false;  // hash murmurhash3_x86_128; identity otherwise
  int minishard_bits = 0;
  int shard_bits = 0;
  bool gzip_minishard_index = false;
  bool gzip_data = false;
};

// One element of "scales": a resolution level.
struct Scale {
  std::string key;                            // the folder of its chunks, relative to the volume's folder
  Extent size;                                // voxels
  Extent voxel_offset;                        // index of the first voxel in the scale's voxel space
  Extent chunk;                               // chunk_sizes[0]
  std::array<double, 3> resolution{1, 1, 1};  // nm per voxel
  ChunkEncoding encoding = ChunkEncoding::raw;
  Extent block{8, 8, 8};  // compressed_segmentation_block_size
  std::optional<ShardingSpec> sharding;
  int jpeg_quality = 0;  // what the writer encodes jpeg chunks at (not in the info file)
};

struct VolumeDescription {
  DType dtype = DType::u8;
  bool segmentation = false;  // "type": "segmentation" (else "image")
  std::int64_t channels = 1;
  std::vector<Scale> scales;
};

// The largest `info` file read: real ones are a few kB, a pyramid of 20 scales is under 10 kB.
inline constexpr std::uint64_t kMaxInfoBytes = 1 << 20;
// The deepest JSON nesting read (an info file nests 3 deep); deeper input is refused before
// parsing, so a hostile file cannot exhaust the parser's stack.
inline constexpr int kMaxJsonDepth = 32;
// The largest decoded chunk (all its channels): chunk_sizes beyond it are refused as damaged.
// Real chunks are 64^3 (2 MiB of uint64) to 512^3 (128 MiB of uint8).
inline constexpr std::uint64_t kMaxChunkBytes = std::uint64_t(256) << 20;

// Reads and checks `<folder>/info`; throws FormatError naming the file and the field.
VolumeDescription read_info(const std::filesystem::path& folder);
// Whether `<folder>/info` looks like a precomputed volume's (for folder detection; never throws).
bool looks_like_precomputed(const std::filesystem::path& folder);
// The JSON form of `description` (what the writer stores as `info`).
nlohmann::json info_json(const VolumeDescription& description);

// The "data_type" name of a sample type ("uint8", ...), or nullptr when the format has none.
const char* data_type_name(DType dtype);

}  // namespace strata::io::detail::precomputed
