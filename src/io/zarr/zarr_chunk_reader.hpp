#pragma once
// The encoded bytes of a Zarr array's chunks as its store holds them: a whole value per chunk,
// or for sharded arrays (v3 sharding_indexed) a range of the shard, found through the shard's
// index (decoded once, kept in a bounded cache). Thread safe.
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "io/lru_cache.hpp"
#include "io/zarr/zarr_array.hpp"

namespace strata::io::detail {

// Decoded shard indexes a reader keeps (an index holds 16 bytes per inner chunk: 64 MiB is 4M
// inner chunks, hundreds of shards as they are written).
inline constexpr std::size_t kZarrShardIndexCacheBytes = 64u << 20;

struct EncodedChunk {
  std::vector<std::byte> bytes;
  std::string name;  // what messages call it: the chunk's file, or the shard's and the inner chunk
};

class ZarrChunkReader {
 public:
  explicit ZarrChunkReader(const ZarrArray& array) : array_(array) {}
  // Chunk `index` (of `array.chunks`, the inner chunks when sharded), or nothing when it is not
  // stored (a missing file or shard, an empty index entry: the fill value). FormatError naming
  // the file and field for chunks larger than they can be and damaged shard indexes.
  std::optional<EncodedChunk> read(std::span<const std::int64_t> index) const;

 private:
  using ShardIndex = std::vector<std::uint64_t>;  // offset, nbytes per inner chunk; empty: no shard
  std::optional<EncodedChunk> read_whole(std::span<const std::int64_t> index) const;
  std::optional<EncodedChunk> read_inner(std::span<const std::int64_t> index) const;
  std::shared_ptr<const ShardIndex> shard_index(const std::string& key) const;
  ShardIndex load_shard_index(const std::string& key, std::uint64_t shard_bytes) const;

  const ZarrArray& array_;  // owned by the source that owns this reader
  mutable std::mutex mutex_;
  mutable LruCache<std::string, ShardIndex> indexes_{kZarrShardIndexCacheBytes};
};

}  // namespace strata::io::detail
