#pragma once
/// @file
/// @brief Open-addressing hash map (linear probing, backward-shift deletion, power-of-two capacity)
/// used by the mixture module for its hot tables: pair scores, node dedupe, label values.
/// std::unordered_map allocates one node per entry; at millions of pairs that costs both
/// memory (the paper's §3.7 remark) and time. Keys need an `empty` sentinel that never occurs.
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "strata/core/hash.hpp"

namespace strata::mixture::detail {

/// @brief The default hash of FlatMap: splitmix64 of the key.
struct U64Hash {
  std::uint64_t operator()(std::uint64_t k) const { return splitmix64(k); }
};

/// @brief Key and Value must be cheap to copy. `empty` is the sentinel key marking free slots.
template <class Key, class Value, class Hash = U64Hash>
class FlatMap {
 public:
  struct Slot {
    Key key;
    Value value;
  };

  explicit FlatMap(Key empty, std::size_t expected = 0) : empty_(empty) { reserve(expected); }

  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  std::size_t capacity() const { return slots_.size(); }

  /// @brief Capacity for n entries at a load factor of at most 3/4 (linear probing still finds a key
  /// in a few probes there; the maps of a large factorisation hold tens of millions of entries,
  /// so a lower bound would cost gigabytes).
  void reserve(std::size_t n) {
    std::size_t cap = 16;
    while (3 * cap < 4 * n) cap <<= 1;
    if (cap > slots_.size()) rehash(cap);
  }

  Value* find(const Key& k) {
    if (slots_.empty()) return nullptr;
    for (std::size_t i = home(k);; i = (i + 1) & mask_) {
      Slot& s = slots_[i];
      if (s.key == k) return &s.value;
      if (s.key == empty_) return nullptr;
    }
  }
  const Value* find(const Key& k) const { return const_cast<FlatMap*>(this)->find(k); }

  /// @brief Returns the value slot for k, inserting `init` when absent; .second tells whether it was
  /// inserted. The pointer is valid until the next insertion.
  std::pair<Value*, bool> insert(const Key& k, const Value& init) {
    if (4 * (size_ + 1) > 3 * slots_.size()) rehash(slots_.empty() ? 16 : slots_.size() * 2);
    for (std::size_t i = home(k);; i = (i + 1) & mask_) {
      Slot& s = slots_[i];
      if (s.key == k) return {&s.value, false};
      if (s.key == empty_) {
        s.key = k;
        s.value = init;
        ++size_;
        return {&s.value, true};
      }
    }
  }

  bool erase(const Key& k) {
    if (slots_.empty()) return false;
    std::size_t i = home(k);
    for (;; i = (i + 1) & mask_) {
      if (slots_[i].key == k) break;
      if (slots_[i].key == empty_) return false;
    }
    // Backward-shift: move later members of the probe run into the hole when allowed.
    for (std::size_t j = (i + 1) & mask_;; j = (j + 1) & mask_) {
      Slot& s = slots_[j];
      if (s.key == empty_) break;
      const std::size_t h = home(s.key);
      // s may move to i iff its home is not cyclically inside (i, j].
      const bool stays = (i <= j) ? (h > i && h <= j) : (h > i || h <= j);
      if (!stays) {
        slots_[i] = s;
        i = j;
      }
    }
    slots_[i].key = empty_;
    --size_;
    return true;
  }

  void clear() {
    for (auto& s : slots_) s.key = empty_;
    size_ = 0;
  }

  template <class F>
  void for_each(F&& f) const {
    for (const auto& s : slots_)
      if (!(s.key == empty_)) f(s.key, s.value);
  }

 private:
  std::size_t home(const Key& k) const { return std::size_t(Hash{}(k)) & mask_; }

  void rehash(std::size_t cap) {
    std::vector<Slot> old;
    old.swap(slots_);
    slots_.assign(cap, Slot{empty_, Value{}});
    mask_ = cap - 1;
    for (const auto& s : old) {
      if (s.key == empty_) continue;
      std::size_t i = home(s.key);
      while (!(slots_[i].key == empty_)) i = (i + 1) & mask_;
      slots_[i] = s;
    }
  }

  Key empty_;
  std::vector<Slot> slots_;
  std::size_t mask_ = 0;
  std::size_t size_ = 0;
};

}  // namespace strata::mixture::detail
