// Sharded chunk storage (Neuroglancer's sharded.md).
//
// hashed = hash(chunk_id >> preshift_bits); minishard = bits [0, minishard_bits) of it, shard =
// bits [minishard_bits, minishard_bits + shard_bits). A shard file:
// | bytes                      | what                                                           |
// | -------------------------- | -------------------------------------------------------------- |
// | 16 * 2^minishard_bits      | shard index: per minishard, uint64le [start, end) of its       |
// |                            | minishard index, relative to the end of the shard index        |
// | ...                        | minishard indices (raw or gzip) and chunk data (raw or gzip)   |
// A decoded minishard index is 3 x n uint64le: chunk ids (delta-coded), data offsets (each
// relative to the end of the previous chunk's data, the first to the end of the shard index) and
// data sizes.
#include "io/precomputed/sharding.hpp"

#include <bit>
#include <cstring>

#include <fmt/format.h>

#include "strata/core/bytes.hpp"
#include "strata/core/error.hpp"

namespace strata::io::detail::precomputed {

namespace {

std::uint32_t fmix32(std::uint32_t h) {
  h ^= h >> 16;
  h *= 0x85ebca6bu;
  h ^= h >> 13;
  h *= 0xc2b2ae35u;
  h ^= h >> 16;
  return h;
}

// The word of up to 4 bytes at `p`, little-endian (the tail of the input is shorter).
std::uint32_t load_partial(const std::byte* p, std::size_t n) {
  std::uint32_t k = 0;
  for (std::size_t i = 0; i < n; ++i) k |= std::uint32_t(std::to_integer<std::uint8_t>(p[i])) << (8 * i);
  return k;
}

int bits_for(std::int64_t grid) { return grid <= 1 ? 0 : std::bit_width(std::uint64_t(grid - 1)); }

}  // namespace

std::array<std::uint32_t, 4> murmurhash3_x86_128(std::span<const std::byte> bytes, std::uint32_t seed) {
  constexpr std::array<std::uint32_t, 4> c{0x239b961bu, 0xab0e9789u, 0x38b34ae5u, 0xa1e38b93u};
  constexpr std::array<int, 4> k_rotation{15, 16, 17, 18}, h_rotation{19, 17, 15, 13};
  constexpr std::array<std::uint32_t, 4> h_add{0x561ccd1bu, 0x0bcaa747u, 0x96cd1c35u, 0x32ac3b17u};
  std::array<std::uint32_t, 4> h{seed, seed, seed, seed};
  // Lane i mixes its word with constants c[i], c[i + 1].
  const auto mix_k = [&](std::uint32_t k, int i) {
    k *= c[i];
    k = std::rotl(k, k_rotation[i]);
    return k * c[(i + 1) % 4];
  };
  const std::size_t blocks = bytes.size() / 16;
  for (std::size_t b = 0; b < blocks; ++b)
    for (int i = 0; i < 4; ++i) {
      h[i] ^= mix_k(load_partial(bytes.data() + 16 * b + 4 * i, 4), i);
      h[i] = std::rotl(h[i], h_rotation[i]) + h[(i + 1) % 4];
      h[i] = h[i] * 5 + h_add[i];
    }
  const std::size_t tail = bytes.size() % 16;
  for (int i = 0; i < 4; ++i) {
    const std::size_t at = 4 * std::size_t(i);
    if (tail > at) h[i] ^= mix_k(load_partial(bytes.data() + 16 * blocks + at, std::min<std::size_t>(4, tail - at)), i);
  }
  for (auto& x : h) x ^= std::uint32_t(bytes.size());
  const auto spread = [&] {
    h[0] += h[1] + h[2] + h[3];
    for (int i = 1; i < 4; ++i) h[i] += h[0];
  };
  spread();
  for (auto& x : h) x = fmix32(x);
  spread();
  return h;
}

std::uint64_t compressed_morton_code(const Extent& position, const Extent& grid) {
  const int bits[3] = {bits_for(grid.x), bits_for(grid.y), bits_for(grid.z)};
  const std::uint64_t coordinate[3] = {std::uint64_t(position.x), std::uint64_t(position.y), std::uint64_t(position.z)};
  std::uint64_t code = 0;
  int out = 0;
  for (int i = 0; i < std::max({bits[0], bits[1], bits[2]}); ++i)
    for (int axis = 0; axis < 3; ++axis)
      if (i < bits[axis]) code |= ((coordinate[axis] >> i) & 1u) << out++;
  return code;
}

ShardSlot shard_slot(const ShardingSpec& spec, std::uint64_t chunk_id) {
  const std::uint64_t shifted = spec.preshift_bits >= 64 ? 0 : chunk_id >> spec.preshift_bits;
  std::uint64_t hashed = shifted;
  if (spec.murmurhash) {
    std::array<std::byte, 8> key{};
    std::memcpy(key.data(), &shifted, 8);  // little-endian host (bytes.hpp)
    const auto h = murmurhash3_x86_128(key, 0);
    hashed = std::uint64_t(h[0]) | (std::uint64_t(h[1]) << 32);
  }
  const auto low_bits = [](std::uint64_t v, int n) { return n >= 64 ? v : v & ((std::uint64_t(1) << n) - 1); };
  const std::uint64_t minishard = low_bits(hashed, spec.minishard_bits);
  const std::uint64_t shard = spec.minishard_bits >= 64 ? 0 : low_bits(hashed >> spec.minishard_bits, spec.shard_bits);
  return {fmt::format("{:0{}x}.shard", shard, (spec.shard_bits + 3) / 4), minishard};
}

std::uint64_t shard_index_bytes(const ShardingSpec& spec) { return std::uint64_t(16) << spec.minishard_bits; }

ByteRange minishard_index_range(std::span<const std::byte> entry, const ShardingSpec& spec, std::uint64_t file_size,
                                const std::string& file) {
  const std::uint64_t base = shard_index_bytes(spec);
  const auto begin = load_field<std::uint64_t>(entry, 0), end = load_field<std::uint64_t>(entry, 8);
  if (begin > end || end > file_size || file_size - end < base)
    throw FormatError(file, "shard index",
                      fmt::format("minishard index [{}, {}) lies outside the {} bytes after the index", begin, end,
                                  file_size < base ? 0 : file_size - base));
  return {base + begin, base + end};
}

std::optional<ByteRange> find_chunk(std::span<const std::byte> minishard_index, std::uint64_t chunk_id,
                                    const ShardingSpec& spec, std::uint64_t file_size, const std::string& file) {
  if (minishard_index.size() % 24 != 0)
    throw FormatError(file, "minishard index", fmt::format("{} bytes is not a multiple of 24", minishard_index.size()));
  const std::size_t n = minishard_index.size() / 24;
  const auto value = [&](std::size_t row, std::size_t i) {
    return load_field<std::uint64_t>(minishard_index, 8 * (row * n + i));
  };
  // Sums wrap modulo 2^64 like the writer's deltas; the final range is checked against the file.
  std::uint64_t id = 0, end = shard_index_bytes(spec);
  for (std::size_t i = 0; i < n; ++i) {
    id += value(0, i);
    const std::uint64_t begin = end + value(1, i), size = value(2, i);
    end = begin + size;
    if (id != chunk_id) continue;
    if (begin < shard_index_bytes(spec) || begin > file_size || size > file_size - begin)
      throw FormatError(file, "minishard index",
                        fmt::format("chunk {} at [{}, {}+{}) lies outside the file of {} bytes", chunk_id, begin, begin,
                                    size, file_size));
    return ByteRange{begin, begin + size};
  }
  return std::nullopt;
}

}  // namespace strata::io::detail::precomputed
