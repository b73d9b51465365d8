#pragma once
/// @file
/// @brief The cache of dequantized Tucker models at full stored rank, keyed by brick. It is what makes
/// the rank slider cheap (paper 1, §3): a new K re-runs only the reconstruction (TTM) from the
/// cached core and factors, never the file read, checksum and dequantization. A model is a few
/// times smaller than its reconstructed brick (R^3 + 3 B R floats against B^3). Thread-safe.
#include <cstdint>
#include <memory>
#include <mutex>

#include "strata/lod/lru_cache.hpp"
#include "strata/quant/brick.hpp"
#include "strata/store/container.hpp"

namespace strata::lod {

/// @brief One brick's dequantized model at its full stored rank, shared with the loaders using it.
using BrickModel = std::shared_ptr<const quant::DequantizedModel>;

/// @brief Bytes of a model's floats (what the cache budget counts).
std::uint64_t model_bytes(const quant::DequantizedModel& model);

/// @brief The cache itself (see the file comment).
class ModelCache {
 public:
  explicit ModelCache(std::uint64_t budget_bytes);

  BrickModel find(const store::BrickKey& key);  // marked recently used; nullptr when absent
  bool insert(const store::BrickKey& key, BrickModel model);  // false when larger than the budget

  std::uint64_t bytes() const;
  std::uint64_t budget() const { return lru_.budget(); }
  std::size_t size() const;

 private:
  mutable std::mutex mutex_;
  LruCache<store::BrickKey, BrickModel, store::BrickKeyHash> lru_;
};

}  // namespace strata::lod
