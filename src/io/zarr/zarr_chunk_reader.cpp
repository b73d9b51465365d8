// Encoded chunks from a store: whole values, or inner chunks of v3 shards.
//
// A shard (zarr-specs v3 sharding-indexed codec), the value of one chunk-grid cell's key:
// | part          | bytes                       | here                                             |
// | ------------- | --------------------------- | ------------------------------------------------ |
// | inner chunks  | anywhere, any order         | each read alone by the range its entry gives     |
// | index         | 16 per inner chunk (C order | at the end (index_location "end") or the start;  |
// |               | of the shard's inner grid), | entry: u64 offset, u64 nbytes in index_codecs'   |
// |               | + 4 with crc32c             | byte order; both 2^64-1: an empty inner chunk    |
// | index crc32c  | 4, little-endian            | of the index's 16 n bytes, checked               |
//
// Refused (FormatError naming the shard and "shard index"): a shard shorter than its index, a crc
// mismatch, entries outside the shard or larger than an inner chunk can be encoded. A missing
// shard, like a missing chunk file, is the fill value.
#include "io/zarr/zarr_chunk_reader.hpp"

#include <bit>

#include <fmt/format.h>

#include "io/io_detail.hpp"
#include "strata/core/bytes.hpp"
#include "strata/core/checked.hpp"
#include "strata/core/error.hpp"

namespace strata::io::detail {

namespace {

// A chunk larger than its decoded size plus this is not a chunk of the array (blosc and the
// deflate codecs add at most a few hundred bytes to incompressible data).
constexpr std::uint64_t kEncodedSlack = 1u << 20;
constexpr std::uint64_t kEmpty = ~std::uint64_t(0);
constexpr std::uint64_t kIndexEntryBytes = 16;

}  // namespace

std::optional<EncodedChunk> ZarrChunkReader::read(std::span<const std::int64_t> index) const {
  return array_.sharding ? read_inner(index) : read_whole(index);
}

std::optional<EncodedChunk> ZarrChunkReader::read_whole(std::span<const std::int64_t> index) const {
  const std::string key = array_.chunk_key(index);
  const std::optional<std::uint64_t> size = array_.store->size(key);
  if (!size) return std::nullopt;
  EncodedChunk chunk{{}, array_.store->name(key)};
  if (*size > array_.chunk_bytes() + kEncodedSlack)
    throw FormatError(chunk.name, "chunk",
                      fmt::format("{} bytes, more than a chunk of {} bytes can take", *size, array_.chunk_bytes()));
  chunk.bytes = array_.store->read(key, 0, *size, "chunk");
  return chunk;
}

std::optional<EncodedChunk> ZarrChunkReader::read_inner(std::span<const std::int64_t> index) const {
  const ZarrSharding& s = *array_.sharding;
  std::vector<std::int64_t> shard(index.size());
  std::uint64_t entry = 0;  // the inner chunk's place in the shard, C order
  for (std::size_t i = 0; i < index.size(); ++i) {
    shard[i] = index[i] / s.per_shard[i];
    entry = entry * std::uint64_t(s.per_shard[i]) + std::uint64_t(index[i] % s.per_shard[i]);
  }
  const std::string key = array_.chunk_key(shard);
  const std::shared_ptr<const ShardIndex> shard_index = this->shard_index(key);
  if (shard_index->empty()) return std::nullopt;
  const std::uint64_t offset = (*shard_index)[2 * entry], nbytes = (*shard_index)[2 * entry + 1];
  if (offset == kEmpty && nbytes == kEmpty) return std::nullopt;
  EncodedChunk chunk{array_.store->read(key, offset, nbytes, "shard index"),
                     fmt::format("{} (inner chunk {})", array_.store->name(key), entry)};
  return chunk;
}

std::shared_ptr<const ZarrChunkReader::ShardIndex> ZarrChunkReader::shard_index(const std::string& key) const {
  {
    std::lock_guard lock(mutex_);
    if (auto cached = indexes_.find(key)) return cached;
  }
  const std::optional<std::uint64_t> size = array_.store->size(key);
  auto index = std::make_shared<const ShardIndex>(size ? load_shard_index(key, *size) : ShardIndex{});
  std::lock_guard lock(mutex_);
  indexes_.insert(key, index, std::max<std::size_t>(1, index->size() * sizeof(std::uint64_t)));
  return index;
}

ZarrChunkReader::ShardIndex ZarrChunkReader::load_shard_index(const std::string& key, std::uint64_t shard_bytes) const {
  const ZarrSharding& s = *array_.sharding;
  const std::string file = array_.store->name(key), field = "shard index";
  const std::uint64_t index_bytes = s.index_bytes();
  if (shard_bytes < index_bytes)
    throw FormatError(file, field,
                      fmt::format("the shard has {} bytes, fewer than its index of {} inner chunks takes ({})", shard_bytes,
                                  s.index_entries(), index_bytes));
  const std::vector<std::byte> raw = array_.store->read(key, s.index_at_start ? 0 : shard_bytes - index_bytes, index_bytes, field);
  const std::uint64_t entry_bytes = s.index_entries() * kIndexEntryBytes;
  if (s.index_crc32c &&
      load_field<std::uint32_t>(std::span<const std::byte>(raw), entry_bytes) != crc32c(std::span(raw).first(entry_bytes)))
    throw FormatError(file, field, "crc32c checksum mismatch (a damaged shard)");
  ShardIndex index(2 * s.index_entries());
  const std::endian order = s.index_big_endian ? std::endian::big : std::endian::little;
  for (std::size_t i = 0; i < index.size(); ++i) index[i] = load_field<std::uint64_t>(std::span<const std::byte>(raw), 8 * i, order);
  const std::uint64_t largest = array_.chunk_bytes() + kEncodedSlack;
  for (std::size_t k = 0; k < index.size(); k += 2) {
    const std::uint64_t offset = index[k], nbytes = index[k + 1];
    if (offset == kEmpty && nbytes == kEmpty) continue;
    const auto end = checked_add(offset, nbytes);
    if (!end || *end > shard_bytes || nbytes > largest)
      throw FormatError(file, field,
                        fmt::format("inner chunk {}: bytes {}..+{} {}", k / 2, offset, nbytes,
                                    nbytes > largest ? fmt::format("are more than an inner chunk of {} bytes can take",
                                                                   array_.chunk_bytes())
                                                     : fmt::format("lie outside the shard of {} bytes", shard_bytes)));
  }
  return index;
}

}  // namespace strata::io::detail
