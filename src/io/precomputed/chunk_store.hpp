#pragma once
// Where a scale's encoded chunks are read from: one file per chunk (unsharded) or shard files.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "io/lru_cache.hpp"
#include "io/precomputed/info.hpp"
#include "strata/io/files.hpp"

namespace strata::io::detail::precomputed {

using Bytes = std::vector<std::byte>;

// The encoded bytes of a scale's chunks, gzip already removed. Thread safe.
class ChunkStore {
 public:
  // `max_encoded_bytes` bounds what one chunk may decode to before it is refused as damaged.
  ChunkStore(std::filesystem::path folder, Scale scale, std::uint64_t max_encoded_bytes);
  // Chunk `position` of the grid (0 <= position < grid), or nothing when it is absent (zeros).
  std::optional<Bytes> read(const Extent& position) const;
  // The file that holds chunk `position` (for messages).
  std::string file_of(const Extent& position) const;

 private:
  std::optional<Bytes> read_unsharded(const Extent& position) const;
  std::optional<Bytes> read_sharded(const Extent& position) const;
  std::shared_ptr<const MappedFile> shard(const std::string& name) const;
  std::shared_ptr<const Bytes> minishard_index(const std::string& shard_name, const MappedFile& file,
                                               std::uint64_t minishard) const;
  Bytes decoded(const std::byte* data, std::uint64_t size, bool gzip, const std::string& file,
                const std::string& field) const;

  std::filesystem::path folder_;  // <volume>/<key>
  Scale scale_;
  Extent grid_;
  std::uint64_t max_encoded_bytes_;
  mutable std::mutex mutex_;
  mutable LruCache<std::string, MappedFile> shards_{16};
  mutable LruCache<std::pair<std::string, std::uint64_t>, Bytes> minishards_{256};
};

}  // namespace strata::io::detail::precomputed
