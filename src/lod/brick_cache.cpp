#include "strata/lod/brick_cache.hpp"

#include <algorithm>
#include <cstdlib>

namespace strata::lod {

BrickCache::BrickCache(std::uint64_t budget_bytes) : lru_(budget_bytes) {}

BrickSamples BrickCache::find(const store::BrickKey& key, int rank) {
  std::lock_guard lock(mutex_);
  const BrickSamples* v = lru_.find({key, rank});
  return v ? *v : nullptr;
}

BrickSamples BrickCache::find_any_rank(const store::BrickKey& key, int rank, int* found_rank) {
  std::lock_guard lock(mutex_);
  auto it = ranks_.find(key);
  if (it == ranks_.end() || it->second.empty()) return nullptr;
  const int best = *std::min_element(it->second.begin(), it->second.end(),
                                     [rank](int a, int b) { return std::abs(a - rank) < std::abs(b - rank); });
  if (found_rank) *found_rank = best;
  return *lru_.find({key, best});
}

bool BrickCache::contains(const store::BrickKey& key, int rank) const {
  std::lock_guard lock(mutex_);
  return lru_.contains({key, rank});
}

bool BrickCache::insert(const store::BrickKey& key, int rank, BrickSamples samples) {
  const std::uint64_t bytes = samples ? samples->size() * sizeof(float) : 0;
  std::lock_guard lock(mutex_);
  const bool replaced = lru_.contains({key, rank});
  std::vector<RankedKey> evicted;
  const bool stored = lru_.insert({key, rank}, std::move(samples), bytes, &evicted);
  for (const RankedKey& e : evicted) forget_rank(e);
  if (stored && !replaced) ranks_[key].push_back(rank);
  if (!stored && replaced) forget_rank({key, rank});
  return stored;
}

void BrickCache::forget_rank(const RankedKey& key) {
  auto it = ranks_.find(key.brick);
  if (it == ranks_.end()) return;
  std::erase(it->second, key.rank);
  if (it->second.empty()) ranks_.erase(it);
}

std::uint64_t BrickCache::bytes() const {
  std::lock_guard lock(mutex_);
  return lru_.bytes();
}

std::size_t BrickCache::size() const {
  std::lock_guard lock(mutex_);
  return lru_.size();
}

CacheCounters BrickCache::counters() const {
  std::lock_guard lock(mutex_);
  return {lru_.evictions()};
}

}  // namespace strata::lod
