#pragma once
/// @file
/// @brief The cache of reconstructed bricks (paper 1, §3: reconstruction happens only on cache misses):
/// B^3 floats per (brick, rank K), least recently used first out, never above its byte budget.
/// Values are shared, so a frame keeps drawing a brick the cache has just evicted; only the
/// cache's own share counts against the budget. Thread-safe.
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <unordered_map>
#include <vector>

#include "strata/lod/lru_cache.hpp"
#include "strata/store/container.hpp"

namespace strata::lod {

/// @brief The B^3 reconstructed floats of one brick at one rank, shared with the frames that draw it.
using BrickSamples = std::shared_ptr<const std::vector<float>>;

/// @brief A brick at one reconstruction rank: the cache's key.
struct RankedKey {
  store::BrickKey brick;
  int rank = 0;
  bool operator==(const RankedKey&) const = default;
};

struct RankedKeyHash {
  std::size_t operator()(const RankedKey& k) const {
    return store::BrickKeyHash{}(k.brick) * 31u + std::size_t(k.rank);
  }
};

/// @brief What a cache reports in frame statistics.
struct CacheCounters {
  std::uint64_t evictions = 0;
};

/// @brief The cache itself (see the file comment).
class BrickCache {
 public:
  explicit BrickCache(std::uint64_t budget_bytes);

  /// @brief The samples at exactly rank K (marked recently used), or nullptr.
  BrickSamples find(const store::BrickKey& key, int rank);
  /// @brief The samples at rank K if cached, else at the cached rank nearest to K; `found_rank` gets
  /// the rank. For stand-ins while the wanted rank is being reconstructed.
  BrickSamples find_any_rank(const store::BrickKey& key, int rank, int* found_rank = nullptr);
  bool contains(const store::BrickKey& key, int rank) const;
  /// @brief False when the brick alone exceeds the budget (then it is not kept).
  bool insert(const store::BrickKey& key, int rank, BrickSamples samples);

  std::uint64_t bytes() const;
  std::uint64_t budget() const { return lru_.budget(); }
  std::size_t size() const;
  CacheCounters counters() const;

 private:
  void forget_rank(const RankedKey& key);
  mutable std::mutex mutex_;
  LruCache<RankedKey, BrickSamples, RankedKeyHash> lru_;
  // Ranks cached per brick, so stand-in lookups need not probe every rank.
  std::unordered_map<store::BrickKey, std::vector<int>, store::BrickKeyHash> ranks_;
};

}  // namespace strata::lod
