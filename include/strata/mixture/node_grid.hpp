#pragma once
/// @file
/// @brief Per-level node ids of an encoded label volume, behind one interface so queries, rendering
/// and decoding work the same on an in-memory factorization and on a stored .strata file.
#include <cstdint>
#include <span>
#include <vector>

#include "strata/core/extent.hpp"
#include "strata/mixture/factorize.hpp"

namespace strata::mixture {

/// @brief The node id of every voxel of every level, however it is stored.
class NodeGrid {
 public:
  virtual ~NodeGrid() = default;
  virtual int level_count() const = 0;
  virtual Extent level_dims(int level) const = 0;
  virtual std::uint32_t node_at(int level, std::int64_t x, std::int64_t y, std::int64_t z) const = 0;
  /// @brief Node ids of `box` (inside the level), x-fastest, into `out` (box.voxel_count() entries).
  virtual void decode_box(int level, const Box& box, std::span<std::uint32_t> out) const;
};

/// @brief The node ids a factorization produced, held in memory (tests, encode-then-query).
class FactorizationGrid final : public NodeGrid {
 public:
  explicit FactorizationGrid(const Factorization& f) : f_(f) {}
  int level_count() const override { return int(f_.levels.size()); }
  Extent level_dims(int level) const override { return f_.levels.at(std::size_t(level)).dims; }
  std::uint32_t node_at(int level, std::int64_t x, std::int64_t y, std::int64_t z) const override {
    const MipLevel& l = f_.levels[std::size_t(level)];
    return l.ids[l.index(x, y, z)];
  }
  void decode_box(int level, const Box& box, std::span<std::uint32_t> out) const override;

 private:
  const Factorization& f_;
};

}  // namespace strata::mixture
