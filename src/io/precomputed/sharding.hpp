#pragma once
// Neuroglancer's sharded chunk storage (sharded.md): chunk ids (compressed Morton codes of the
// chunk grid) hashed to a shard file and a minishard inside it, whose index lists the chunks.
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>

#include "io/precomputed/info.hpp"

namespace strata::io::detail::precomputed {

// MurmurHash3_x86_128 of `bytes` with `seed`: the four 32-bit words h1..h4.
std::array<std::uint32_t, 4> murmurhash3_x86_128(std::span<const std::byte> bytes, std::uint32_t seed);

// The compressed Morton code of chunk `position` in a grid of `grid` chunks: the bits of x, y
// and z interleaved, each axis giving only the ceil(log2(grid)) bits it needs.
std::uint64_t compressed_morton_code(const Extent& position, const Extent& grid);

// Where a chunk lives: the shard file's name and the minishard in it.
struct ShardSlot {
  std::string file_name;  // "<shard>.shard": lower-case hex padded to ceil(shard_bits / 4) digits
  std::uint64_t minishard = 0;
};
ShardSlot shard_slot(const ShardingSpec& spec, std::uint64_t chunk_id);

// A byte range [begin, end) of a shard file.
struct ByteRange {
  std::uint64_t begin = 0, end = 0;
  bool empty() const { return begin == end; }
};

// The bytes of the shard index at its start: 16 per minishard.
std::uint64_t shard_index_bytes(const ShardingSpec& spec);
// Minishard `minishard`'s index in a shard file of `file_size` bytes, from the 16-byte shard-index
// entry `entry`; FormatError(file, "shard index", ...) when it lies outside the file.
ByteRange minishard_index_range(std::span<const std::byte> entry, const ShardingSpec& spec, std::uint64_t file_size,
                                const std::string& file);
// Where chunk `chunk_id`'s data lies according to a decoded minishard index, or nothing when the
// minishard does not list it; FormatError(file, "minishard index", ...) when the index is
// malformed or points outside a file of `file_size` bytes.
std::optional<ByteRange> find_chunk(std::span<const std::byte> minishard_index, std::uint64_t chunk_id,
                                    const ShardingSpec& spec, std::uint64_t file_size, const std::string& file);

}  // namespace strata::io::detail::precomputed
