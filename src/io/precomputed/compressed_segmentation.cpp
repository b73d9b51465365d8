// The compressed_segmentation encoding (Neuroglancer's sliceview/compressed_segmentation README).
//
// A chunk of C channels starts with C uint32le words: the offset, in 32-bit words from the start
// of the chunk, of each channel's data. A channel's data, all offsets in 32-bit words from its
// start:
// | words                     | what                                                              |
// | ------------------------- | ----------------------------------------------------------------- |
// | 2 per block (x fastest)   | header: bits 0-23 lookup table offset, bits 24-31 encoded bits,   |
// |                           | then the encoded values offset                                    |
// | ceil(bits * B / 32)       | per block: voxel indices into the table, packed little-endian,    |
// |                           | voxel (x, y, z) of the block at bit bits * (x + bx * (y + by * z)) |
// | 1 (u32) or 2 (u64) each   | per block: the lookup table of distinct ids, little-endian        |
// Blocks past the chunk's upper edge are padded to the full block size.
#include "io/precomputed/compressed_segmentation.hpp"

#include <algorithm>
#include <bit>

#include <fmt/format.h>

#include "strata/core/bytes.hpp"
#include "strata/core/error.hpp"

namespace strata::io::detail::precomputed {

namespace {

constexpr std::string_view kField = "compressed_segmentation";

std::int64_t blocks_along(std::int64_t size, std::int64_t block) { return (size + block - 1) / block; }

std::uint64_t block_count(const Extent& chunk, const Extent& block) {
  return std::uint64_t(blocks_along(chunk.x, block.x)) * std::uint64_t(blocks_along(chunk.y, block.y)) *
         std::uint64_t(blocks_along(chunk.z, block.z));
}

// Calls visit(header word, voxels of the block inside the chunk) for every block, x fastest: the
// order of the block headers.
template <class Visit>
void for_each_block(const Extent& chunk, const Extent& block, Visit&& visit) {
  std::uint64_t header = 0;
  for (std::int64_t z = 0; z < chunk.z; z += block.z)
    for (std::int64_t y = 0; y < chunk.y; y += block.y)
      for (std::int64_t x = 0; x < chunk.x; x += block.x, header += 2)
        visit(header,
              Box{{x, y, z},
                  {std::min(x + block.x, chunk.x), std::min(y + block.y, chunk.y), std::min(z + block.z, chunk.z)}});
}

// The channel data as 32-bit words, with checked access.
class Words {
 public:
  Words(std::span<const std::byte> data, const std::string& file) : data_(data), file_(file) {
    if (data.size() % 4 != 0) fail(fmt::format("{} bytes is not a whole number of 32-bit words", data.size()));
  }
  std::uint64_t size() const { return data_.size() / 4; }
  std::uint32_t operator[](std::uint64_t i) const {
    if (i >= size()) fail(fmt::format("word {} is past the end of the chunk ({} words)", i, size()));
    return load_field<std::uint32_t>(data_, std::size_t(i) * 4, std::endian::little);
  }
  Words from(std::uint64_t word) const {
    if (word >= size()) fail(fmt::format("channel offset {} is past the end of the chunk ({} words)", word, size()));
    return Words(data_.subspan(std::size_t(word) * 4), file_);
  }
  [[noreturn]] void fail(const std::string& problem) const { throw FormatError(file_, std::string(kField), problem); }

 private:
  std::span<const std::byte> data_;
  const std::string& file_;
};

template <class T>
void decode_block(const Words& words, std::uint64_t header, const Extent& block, const Box& voxels, const Extent& chunk,
                  T* out) {
  constexpr std::uint64_t kWordsPerValue = sizeof(T) / 4;
  const std::uint32_t w0 = words[header], values = words[header + 1];
  const std::uint32_t table = w0 & 0xFFFFFFu, bits = w0 >> 24;
  if (bits > 32 || (bits != 0 && !std::has_single_bit(bits)))
    words.fail(fmt::format("{} encoded bits (expected 0, 1, 2, 4, 8, 16 or 32)", bits));
  if (table >= words.size()) words.fail(fmt::format("lookup table offset {} is past the end of the data", table));
  const std::uint64_t table_entries = (words.size() - table) / kWordsPerValue;
  const std::uint64_t block_voxels = std::uint64_t(block.x) * std::uint64_t(block.y) * std::uint64_t(block.z);
  if (bits != 0 && std::uint64_t(values) + (bits * block_voxels + 31) / 32 > words.size())
    words.fail(fmt::format("encoded values at offset {} run past the end of the data", values));
  const std::uint32_t mask = bits == 32 ? 0xFFFFFFFFu : (1u << bits) - 1;
  for (std::int64_t z = voxels.lo.z; z < voxels.hi.z; ++z)
    for (std::int64_t y = voxels.lo.y; y < voxels.hi.y; ++y)
      for (std::int64_t x = voxels.lo.x; x < voxels.hi.x; ++x) {
        std::uint64_t index = 0;
        if (bits != 0) {
          const std::uint64_t in_block =
              std::uint64_t((x - voxels.lo.x) + block.x * ((y - voxels.lo.y) + block.y * (z - voxels.lo.z)));
          const std::uint64_t bit = bits * in_block;
          index = (words[values + bit / 32] >> (bit % 32)) & mask;
        }
        if (index >= table_entries)
          words.fail(fmt::format("table index {} is past the end of the lookup table at {}", index, table));
        const std::uint64_t at = table + index * kWordsPerValue;
        std::uint64_t id = words[at];
        if constexpr (kWordsPerValue == 2) id |= std::uint64_t(words[at + 1]) << 32;
        out[std::size_t((z * chunk.y + y) * chunk.x + x)] = T(id);
      }
}

template <class T>
void decode_channel(const Words& words, const Extent& chunk, const Extent& block, T* out) {
  const std::uint64_t blocks = block_count(chunk, block);
  if (2 * blocks > words.size())
    words.fail(fmt::format("{} block headers do not fit in {} words", blocks, words.size()));
  for_each_block(chunk, block, [&](std::uint64_t header, const Box& voxels) {
    decode_block(words, header, block, voxels, chunk, out);
  });
}

// Appends the encoding of one block: its packed indices, then its table.
template <class T>
void encode_block(const T* samples, const Extent& chunk, const Extent& block, const Box& voxels,
                  std::vector<std::uint32_t>& words, std::uint64_t header) {
  std::vector<T> table;
  for (std::int64_t z = voxels.lo.z; z < voxels.hi.z; ++z)
    for (std::int64_t y = voxels.lo.y; y < voxels.hi.y; ++y)
      for (std::int64_t x = voxels.lo.x; x < voxels.hi.x; ++x)
        table.push_back(samples[std::size_t((z * chunk.y + y) * chunk.x + x)]);
  std::sort(table.begin(), table.end());
  table.erase(std::unique(table.begin(), table.end()), table.end());
  std::uint32_t bits = 0;
  while ((std::uint64_t(1) << bits) < table.size()) bits = bits == 0 ? 1 : 2 * bits;
  const std::uint64_t block_voxels = std::uint64_t(block.x) * std::uint64_t(block.y) * std::uint64_t(block.z);
  const std::uint64_t values = words.size();
  words.resize(words.size() + (bits * block_voxels + 31) / 32, 0);
  if (bits != 0)
    for (std::int64_t z = voxels.lo.z; z < voxels.hi.z; ++z)
      for (std::int64_t y = voxels.lo.y; y < voxels.hi.y; ++y)
        for (std::int64_t x = voxels.lo.x; x < voxels.hi.x; ++x) {
          const T id = samples[std::size_t((z * chunk.y + y) * chunk.x + x)];
          const auto index = std::uint32_t(std::lower_bound(table.begin(), table.end(), id) - table.begin());
          const std::uint64_t bit =
              bits * std::uint64_t((x - voxels.lo.x) + block.x * ((y - voxels.lo.y) + block.y * (z - voxels.lo.z)));
          words[values + bit / 32] |= index << (bit % 32);
        }
  const std::uint64_t table_offset = words.size();
  for (T id : table) {
    words.push_back(std::uint32_t(std::uint64_t(id)));
    if constexpr (sizeof(T) == 8) words.push_back(std::uint32_t(std::uint64_t(id) >> 32));
  }
  if (table_offset > 0xFFFFFFu || values > 0xFFFFFFFFu)
    throw Error("compressed_segmentation: a chunk's encoding exceeds the format's 24-bit table offsets");
  words[header] = std::uint32_t(table_offset) | (bits << 24);
  words[header + 1] = std::uint32_t(values);
}

template <class T>
std::vector<std::uint32_t> encode_channel(const T* samples, const Extent& chunk, const Extent& block) {
  std::vector<std::uint32_t> words(std::size_t(2 * block_count(chunk, block)), 0);
  for_each_block(chunk, block, [&](std::uint64_t header, const Box& voxels) {
    encode_block(samples, chunk, block, voxels, words, header);
  });
  return words;
}

}  // namespace

void decode_compressed_segmentation(std::span<const std::byte> data, const Extent& chunk, const Extent& block,
                                    std::int64_t channels, std::int64_t channel, DType dtype, std::byte* out,
                                    const std::string& file) {
  const Words all(data, file);
  if (std::uint64_t(channels) > all.size())
    all.fail(fmt::format("{} bytes cannot hold the offsets of {} channels", data.size(), channels));
  const Words words = all.from(all[std::uint64_t(channel)]);
  if (dtype == DType::u32) decode_channel(words, chunk, block, reinterpret_cast<std::uint32_t*>(out));
  else decode_channel(words, chunk, block, reinterpret_cast<std::uint64_t*>(out));
}

std::vector<std::byte> encode_compressed_segmentation(const std::byte* samples, const Extent& chunk,
                                                      const Extent& block, DType dtype) {
  const std::vector<std::uint32_t> words =
      dtype == DType::u32 ? encode_channel(reinterpret_cast<const std::uint32_t*>(samples), chunk, block)
                          : encode_channel(reinterpret_cast<const std::uint64_t*>(samples), chunk, block);
  std::vector<std::byte> out(4 * (words.size() + 1));
  store_field(out, 0, std::uint32_t(1));  // the one channel starts after its offset word
  for (std::size_t i = 0; i < words.size(); ++i) store_field(out, 4 * (i + 1), words[i]);
  return out;
}

}  // namespace strata::io::detail::precomputed
