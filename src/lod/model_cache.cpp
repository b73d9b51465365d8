#include "strata/lod/model_cache.hpp"

namespace strata::lod {

std::uint64_t model_bytes(const quant::DequantizedModel& model) {
  std::uint64_t floats = model.core.size();
  for (const auto& f : model.factors) floats += f.size();
  floats += model.correction_value.size() + model.samples.size();
  return floats * sizeof(float) + model.correction_index.size() * sizeof(std::uint32_t);
}

ModelCache::ModelCache(std::uint64_t budget_bytes) : lru_(budget_bytes) {}

BrickModel ModelCache::find(const store::BrickKey& key) {
  std::lock_guard lock(mutex_);
  const BrickModel* m = lru_.find(key);
  return m ? *m : nullptr;
}

bool ModelCache::insert(const store::BrickKey& key, BrickModel model) {
  const std::uint64_t bytes = model ? model_bytes(*model) : 0;
  std::lock_guard lock(mutex_);
  return lru_.insert(key, std::move(model), bytes);
}

std::uint64_t ModelCache::bytes() const {
  std::lock_guard lock(mutex_);
  return lru_.bytes();
}

std::size_t ModelCache::size() const {
  std::lock_guard lock(mutex_);
  return lru_.size();
}

}  // namespace strata::lod
