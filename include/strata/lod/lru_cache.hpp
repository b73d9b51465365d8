#pragma once
/// @file
/// @brief A least-recently-used map with a byte budget: the storage policy shared by the brick caches.
/// Not thread-safe; the caches that use it hold a lock around every call.
#include <cstdint>
#include <list>
#include <unordered_map>
#include <utility>
#include <vector>

namespace strata::lod {

/// @brief Values of any type, each charged `bytes` against the budget when inserted.
template <class Key, class Value, class Hash = std::hash<Key>>
class LruCache {
 public:
  explicit LruCache(std::uint64_t budget_bytes) : budget_(budget_bytes) {}

  /// @brief The value, marked as most recently used; nullptr when absent.
  const Value* find(const Key& key) {
    auto it = index_.find(key);
    if (it == index_.end()) return nullptr;
    order_.splice(order_.begin(), order_, it->second);
    return &it->second->value;
  }
  bool contains(const Key& key) const { return index_.contains(key); }

  /// @brief Stores (or replaces) `key`, evicting least recently used entries until the total fits the
  /// budget; their keys are appended to `evicted`. An item larger than the whole budget is not
  /// stored (returns false) so the budget is never exceeded.
  bool insert(const Key& key, Value value, std::uint64_t bytes, std::vector<Key>* evicted = nullptr) {
    erase(key);
    if (bytes > budget_) return false;
    while (bytes_ + bytes > budget_) {
      const Entry& victim = order_.back();
      if (evicted) evicted->push_back(victim.key);
      bytes_ -= victim.bytes;
      index_.erase(victim.key);
      order_.pop_back();
      ++evictions_;
    }
    order_.push_front({key, std::move(value), bytes});
    index_.emplace(key, order_.begin());
    bytes_ += bytes;
    return true;
  }

  bool erase(const Key& key) {
    auto it = index_.find(key);
    if (it == index_.end()) return false;
    bytes_ -= it->second->bytes;
    order_.erase(it->second);
    index_.erase(it);
    return true;
  }

  std::uint64_t bytes() const { return bytes_; }
  std::uint64_t budget() const { return budget_; }
  std::size_t size() const { return index_.size(); }
  std::uint64_t evictions() const { return evictions_; }

 private:
  struct Entry {
    Key key;
    Value value;
    std::uint64_t bytes;
  };
  std::uint64_t budget_;
  std::uint64_t bytes_ = 0, evictions_ = 0;
  std::list<Entry> order_;  // most recent first
  std::unordered_map<Key, typename std::list<Entry>::iterator, Hash> index_;
};

}  // namespace strata::lod
