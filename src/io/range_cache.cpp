#include "range_cache.hpp"

namespace strata::io::detail {

namespace {

// Coalesced fetches overlap single ones now and then; looking this many ranges back from the
// offset finds the one holding a request in practice, without a full interval tree.
constexpr int kRangesLookedAt = 4;

}  // namespace

std::optional<SharedBytes> RangeCache::find(std::uint64_t offset, std::uint64_t size) {
  std::lock_guard lock(mutex_);
  auto it = ranges_.upper_bound(offset);
  for (int i = 0; i < kRangesLookedAt && it != ranges_.begin(); ++i) {
    --it;
    const std::uint64_t start = it->first, length = it->second.bytes.size();
    if (offset - start <= length && size <= length - (offset - start)) {
      uses_.splice(uses_.begin(), uses_, it->second.use);
      return it->second.bytes.subrange(offset - start, size);
    }
  }
  return std::nullopt;
}

void RangeCache::insert(std::uint64_t offset, SharedBytes bytes) {
  if (bytes.size() > max_bytes_ || max_entries_ == 0) return;
  std::lock_guard lock(mutex_);
  auto it = ranges_.find(offset);
  if (it != ranges_.end()) {
    if (it->second.bytes.size() >= bytes.size()) return;  // another thread fetched as much
    bytes_ -= it->second.bytes.size();
    uses_.erase(it->second.use);
    ranges_.erase(it);
  }
  bytes_ += bytes.size();
  uses_.push_front(offset);
  ranges_.emplace(offset, Entry{std::move(bytes), uses_.begin()});
  evict();
}

void RangeCache::evict() {
  while (!uses_.empty() && (bytes_ > max_bytes_ || ranges_.size() > max_entries_)) {
    const auto it = ranges_.find(uses_.back());
    bytes_ -= it->second.bytes.size();
    ranges_.erase(it);
    uses_.pop_back();
  }
}

}  // namespace strata::io::detail
