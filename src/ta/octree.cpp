#include "strata/ta/octree.hpp"

#include <cmath>

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

Volume half_resolution(const Volume& v) {
  const Extent d = v.dims(), h = half_extent(d);
  Volume out(h, DType::f32, v.spacing());
  const auto in = v.view<float>();
  auto o = out.view<float>();
  for (std::int64_t z = 0; z < h.z; ++z)
    for (std::int64_t y = 0; y < h.y; ++y)
      for (std::int64_t x = 0; x < h.x; ++x) {
        double sum = 0;
        int finite = 0;
        float first = 0;
        for (int c = 0; c < 8; ++c) {
          const float s = in(std::min(2 * x + (c & 1), d.x - 1), std::min(2 * y + (c >> 1 & 1), d.y - 1),
                             std::min(2 * z + (c >> 2), d.z - 1));
          if (c == 0) first = s;
          if (std::isfinite(s)) {
            sum += double(s);
            ++finite;
          }
        }
        o(x, y, z) = finite > 0 ? float(sum / finite) : first;
      }
  return out;
}

}  // namespace strata::ta
