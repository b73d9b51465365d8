#include "render/frame_index.hpp"

#include <algorithm>
#include <limits>
#include <cmath>
#include <string>

#include "strata/core/error.hpp"
#include "strata/core/threads.hpp"
#include "strata/lod/brick_bounds.hpp"
#include "strata/store/container.hpp"

namespace strata::render::detail {

namespace {

void check_brick(const lod::ResidentBrick& b, const ta::OctreeGeometry& g) {
  if (b.key.level >= g.level_count()) throw Error("render: " + store::brick_name(b.key) + " is beyond the octree's levels");
  const Extent& grid = g.level(b.key.level).bricks;
  if (b.key.x < 0 || b.key.y < 0 || b.key.z < 0 || b.key.x >= grid.x || b.key.y >= grid.y || b.key.z >= grid.z)
    throw Error("render: " + store::brick_name(b.key) + " is outside the level's brick grid " + grid.to_string());
  const std::size_t width = std::size_t(g.layout().brick);
  if (!b.is_constant() && b.samples->size() != width * width * width)
    throw Error("render: " + store::brick_name(b.key) + " has " + std::to_string(b.samples->size()) + " samples, expected " +
                std::to_string(width * width * width));
}

// The brick's [min, max]: from the file's index when it has the key, else from its samples.
void fill_ranges(const FrameInput& frame, FrameIndex& index) {
  const auto& bricks = frame.bricks->bricks;
  const std::int64_t n = std::int64_t(bricks.size());
#pragma omp parallel for schedule(dynamic, 16) num_threads(thread_count())
  for (std::int64_t i = 0; i < n; ++i) {
    const lod::ResidentBrick& b = bricks[std::size_t(i)];
    Block& blk = index.blocks[std::size_t(i)];
    if (b.is_constant()) {
      blk.value_lo = blk.value_hi = b.constant_value;
      continue;
    }
    const store::BrickEntry* entry = frame.index ? frame.index->find(b.key) : nullptr;
    if (entry) {
      blk.value_lo = entry->min;
      blk.value_hi = entry->max;
    } else {
      std::tie(blk.value_lo, blk.value_hi) = finite_range(b.samples->data(), b.samples->size());
    }
  }
}

// Assigns each cell the finest brick covering it; a brick that loses a cell to a finer one is
// walked cell by cell instead of as one box.
void fill_cells(const FrameInput& frame, FrameIndex& index) {
  const auto& bricks = frame.bricks->bricks;
  const auto& c = index.cells;
  index.cell_block.assign(std::size_t(c[0] * c[1] * c[2]), -1);
  std::vector<std::int64_t> covered(bricks.size(), 0);
  for (std::size_t i = 0; i < bricks.size(); ++i) {
    const store::BrickKey& k = bricks[i].key;
    const std::int64_t s = std::int64_t(1) << k.level;
    const std::array<std::int64_t, 3> lo{k.x * s, k.y * s, k.z * s};
    const std::array<std::int64_t, 3> hi{std::min(lo[0] + s, c[0]), std::min(lo[1] + s, c[1]), std::min(lo[2] + s, c[2])};
    for (std::int64_t z = lo[2]; z < hi[2]; ++z)
      for (std::int64_t y = lo[1]; y < hi[1]; ++y)
        for (std::int64_t x = lo[0]; x < hi[0]; ++x) {
          std::int32_t& cell = index.cell_block[std::size_t((z * c[1] + y) * c[0] + x)];
          ++covered[i];
          if (cell < 0 || bricks[std::size_t(cell)].key.level > k.level) cell = std::int32_t(i);
        }
  }
  std::vector<std::int64_t> owned(bricks.size(), 0);
  for (std::int32_t cell : index.cell_block)
    if (cell >= 0) ++owned[std::size_t(cell)];
  for (std::size_t i = 0; i < bricks.size(); ++i) index.blocks[i].exclusive = owned[i] == covered[i];
}

Block brick_block(const lod::ResidentBrick& b, const ta::OctreeGeometry& g, const Spacing& sp) {
  const ta::BrickLayout& layout = g.layout();
  const double s = std::ldexp(1.0, b.key.level);
  const std::array<double, 3> spacing{sp.x, sp.y, sp.z};
  const std::array<std::int64_t, 3> key{b.key.x, b.key.y, b.key.z};
  const lod::WorldBox box = lod::brick_world_box(g, sp, b.key);  // core voxels, clipped to the volume
  Block blk;
  blk.data = b.is_constant() ? nullptr : b.samples->data();
  blk.constant = b.constant_value;
  blk.n = {layout.brick, layout.brick, layout.brick};
  blk.level = b.key.level;
  for (int a = 0; a < 3; ++a) {
    const double core_lo = double(key[std::size_t(a)] * layout.core());  // level-l voxels
    const double voxel = s * spacing[std::size_t(a)];                      // world size of a level-l voxel
    blk.lo[std::size_t(a)] = box.lo[a];
    blk.hi[std::size_t(a)] = box.hi[a];
    // Level-l position q = world / voxel; local index = q - 0.5 - core_lo + overlap.
    blk.scale[std::size_t(a)] = 1.0 / voxel;
    blk.offset[std::size_t(a)] = -0.5 - core_lo + layout.overlap;
    blk.gradient_scale[std::size_t(a)] = float(0.5 / voxel);
  }
  return blk;
}

std::array<double, 3> world_extent(const Extent& dims, const Spacing& sp) {
  return {double(dims.x) * sp.x, double(dims.y) * sp.y, double(dims.z) * sp.z};
}

void check_spacing(const Spacing& sp) {
  if (!(sp.x > 0 && sp.y > 0 && sp.z > 0)) throw Error("render: voxel spacing must be positive");
}

}  // namespace

std::pair<float, float> finite_range(const float* v, std::size_t n) {
  float lo = std::numeric_limits<float>::infinity(), hi = -lo;
  for (std::size_t i = 0; i < n; ++i) {
    const bool finite = std::abs(v[i]) <= std::numeric_limits<float>::max();
    lo = finite && v[i] < lo ? v[i] : lo;
    hi = finite && v[i] > hi ? v[i] : hi;
  }
  return {lo, hi};
}

void cull_blocks(FrameIndex& index, const TransferFunction& tf, double value_min, double value_max) {
  const ValueMapping m = tf.mapping(value_min, value_max);
  // A block without finite samples (NaN or infinite only: empty space) is culled.
  for (Block& b : index.blocks)
    b.culled = !(b.value_lo <= b.value_hi) || !tf.visible(m.normalise(b.value_lo), m.normalise(b.value_hi));
}

FrameIndex build_frame_index(const FrameInput& frame, const TransferFunction& tf) {
  if (!frame.bricks || !frame.geometry) throw Error("render: frame needs bricks and an octree geometry");
  check_spacing(frame.spacing);
  const ta::OctreeGeometry& g = *frame.geometry;
  FrameIndex index;
  index.volume_hi = world_extent(g.level(0).dims, frame.spacing);
  index.min_spacing = std::min({frame.spacing.x, frame.spacing.y, frame.spacing.z});
  const Extent cells = g.level(0).bricks;
  index.cells = {cells.x, cells.y, cells.z};
  const double core = g.layout().core();
  index.cell_size = {core * frame.spacing.x, core * frame.spacing.y, core * frame.spacing.z};
  index.blocks.reserve(frame.bricks->bricks.size());
  for (const lod::ResidentBrick& b : frame.bricks->bricks) {
    check_brick(b, g);
    index.blocks.push_back(brick_block(b, g, frame.spacing));
    index.max_level = std::max(index.max_level, int(b.key.level));
  }
  fill_ranges(frame, index);
  cull_blocks(index, tf, frame.value_min, frame.value_max);
  fill_cells(frame, index);
  return index;
}

FrameIndex build_volume_index(const Volume& volume) {
  check_spacing(volume.spacing());
  if (volume.voxel_count() <= 0) throw Error("render: the volume is empty");
  if (volume.dims().x > 0x7fffffff || volume.dims().y > 0x7fffffff || volume.dims().z > 0x7fffffff)
    throw Error("render: volume extent too large for single-block rendering");
  FrameIndex index;
  const Spacing& sp = volume.spacing();
  index.volume_hi = world_extent(volume.dims(), sp);
  index.min_spacing = std::min({sp.x, sp.y, sp.z});
  index.cell_size = index.volume_hi;
  index.cell_block = {0};
  Block blk;
  if (volume.dtype() == DType::f32) {
    blk.data = volume.samples<float>().data();
  } else {
    index.owned = volume.converted(DType::f32);
    blk.data = index.owned.samples<float>().data();
  }
  blk.n = {int(volume.dims().x), int(volume.dims().y), int(volume.dims().z)};
  const std::array<double, 3> spacing{sp.x, sp.y, sp.z};
  for (int a = 0; a < 3; ++a) {
    blk.hi[std::size_t(a)] = index.volume_hi[std::size_t(a)];
    blk.scale[std::size_t(a)] = 1.0 / spacing[std::size_t(a)];
    blk.offset[std::size_t(a)] = -0.5;
    blk.gradient_scale[std::size_t(a)] = float(0.5 / spacing[std::size_t(a)]);
  }
  std::tie(blk.value_lo, blk.value_hi) = finite_range(blk.data, std::size_t(volume.voxel_count()));
  index.blocks.push_back(blk);
  return index;
}

}  // namespace strata::render::detail
