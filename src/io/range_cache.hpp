#pragma once
// The bounded cache of byte ranges a remote source has fetched (src/io/http_source.cpp): least
// recently used ranges go first when it holds more than its byte or entry limit. Thread-safe.
#include <cstdint>
#include <list>
#include <map>
#include <mutex>
#include <optional>

#include "strata/io/byte_source.hpp"

namespace strata::io::detail {

class RangeCache {
 public:
  RangeCache(std::uint64_t max_bytes, std::uint64_t max_entries) : max_bytes_(max_bytes), max_entries_(max_entries) {}
  /// @brief Bytes [offset, offset + size) when a cached range holds them all (that range
  /// becomes the most recently used), else nothing.
  std::optional<SharedBytes> find(std::uint64_t offset, std::uint64_t size);
  /// @brief Keeps `bytes`, fetched from `offset`, evicting the least recently used ranges beyond
  /// the limits. A range larger than the byte limit is not kept.
  void insert(std::uint64_t offset, SharedBytes bytes);

 private:
  struct Entry {
    SharedBytes bytes;
    std::list<std::uint64_t>::iterator use;
  };
  void evict();
  std::mutex mutex_;
  std::uint64_t max_bytes_, max_entries_, bytes_ = 0;
  std::map<std::uint64_t, Entry> ranges_;  // by offset
  std::list<std::uint64_t> uses_;          // offsets, most recently used first
};

}  // namespace strata::io::detail
