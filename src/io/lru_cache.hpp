#pragma once
// A least-recently-used map bounded by a count of units, shared by the chunked readers
// (precomputed shards and minishard indexes, Zarr shard indexes).
#include <cstddef>
#include <list>
#include <map>
#include <memory>

namespace strata::io::detail {

// A least-recently-used map holding at most `capacity` units (bytes, or entries when each
// counts 1). Not thread safe: its owner locks.
template <class Key, class Value>
class LruCache {
 public:
  explicit LruCache(std::size_t capacity) : capacity_(capacity) {}
  std::shared_ptr<const Value> find(const Key& key) {
    const auto it = index_.find(key);
    if (it == index_.end()) return nullptr;
    order_.splice(order_.begin(), order_, it->second);
    return it->second->value;
  }
  void insert(const Key& key, std::shared_ptr<const Value> value, std::size_t units) {
    if (index_.contains(key) || units > capacity_) return;
    order_.push_front({key, std::move(value), units});
    index_[key] = order_.begin();
    used_ += units;
    while (used_ > capacity_) {
      used_ -= order_.back().units;
      index_.erase(order_.back().key);
      order_.pop_back();
    }
  }

 private:
  struct Entry {
    Key key;
    std::shared_ptr<const Value> value;
    std::size_t units;
  };
  std::size_t capacity_, used_ = 0;
  std::list<Entry> order_;
  std::map<Key, typename std::list<Entry>::iterator> index_;
};

}  // namespace strata::io::detail
