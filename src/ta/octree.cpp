#include "strata/ta/octree.hpp"

#include <algorithm>
#include <string>

#include "strata/core/error.hpp"

namespace strata::ta {

void BrickLayout::validate() const {
  if (brick < 2 || brick > 256)
    throw ParameterError("BrickLayout::brick", "must be in 2..256, got " + std::to_string(brick));
  if (overlap < 0 || core() < 1)
    throw ParameterError("BrickLayout::overlap", "must be >= 0 and leave a core in the brick width " + std::to_string(brick) +
                                                     " (2*overlap < width), got " + std::to_string(overlap));
}

Extent half_extent(const Extent& d) { return {(d.x + 1) / 2, (d.y + 1) / 2, (d.z + 1) / 2}; }

namespace {
std::int64_t ceil_div(std::int64_t a, std::int64_t b) { return (a + b - 1) / b; }
}  // namespace

OctreeGeometry::OctreeGeometry(const Extent& volume_dims, const BrickLayout& layout) : layout_(layout) {
  layout_.validate();
  if (volume_dims.x < 1 || volume_dims.y < 1 || volume_dims.z < 1)
    throw Error("octree: every extent must be at least 1, got " + volume_dims.to_string());
  const std::int64_t core = layout_.core();
  Extent dims = volume_dims;
  while (true) {
    levels_.push_back({dims, {ceil_div(dims.x, core), ceil_div(dims.y, core), ceil_div(dims.z, core)}});
    if (dims.x <= core && dims.y <= core && dims.z <= core) break;
    dims = half_extent(dims);
  }
  std::int64_t first = 0;
  for (const LevelGeometry& l : levels_) {
    first_brick_.push_back(first);
    first += l.bricks.voxel_count();
  }
}

std::int64_t OctreeGeometry::total_bricks() const {
  return first_brick_.back() + levels_.back().bricks.voxel_count();
}

std::int64_t OctreeGeometry::brick_ordinal(int l, std::int64_t bx, std::int64_t by, std::int64_t bz, bool within_level) const {
  const Extent& grid = level(l).bricks;
  return (within_level ? 0 : first_brick_[std::size_t(l)]) + bx + grid.x * (by + grid.y * bz);
}

Box OctreeGeometry::brick_sample_box(int level, std::int64_t bx, std::int64_t by, std::int64_t bz) const {
  const std::int64_t core = layout_.core(), o = layout_.overlap, b = layout_.brick;
  Extent lo{bx * core - o, by * core - o, bz * core - o};
  (void)level;
  return {lo, {lo.x + b, lo.y + b, lo.z + b}};
}

Box OctreeGeometry::brick_core_box(int level, std::int64_t bx, std::int64_t by, std::int64_t bz) const {
  const std::int64_t core = layout_.core();
  Box box{{bx * core, by * core, bz * core}, {(bx + 1) * core, (by + 1) * core, (bz + 1) * core}};
  return box.intersect(Box::whole(this->level(level).dims));
}

}  // namespace strata::ta
