// Frames without the lod module: every brick of one level of a .strata file, or level 0 of an
// in-memory volume cut into bricks.
#include <algorithm>
#include <exception>

#include "strata/core/error.hpp"
#include "strata/core/threads.hpp"
#include "strata/lod/histogram_bins.hpp"
#include "strata/render/raycaster.hpp"
#include "strata/ta/ta_volume.hpp"

namespace strata::render {

lod::FrameBricks level_bricks(const ta::TaVolume& volume, int level, int rank, std::uint64_t visible_mask) {
  volume.check_level(level);
  const ta::OctreeGeometry& g = volume.geometry();
  const Extent grid = g.level(level).bricks;
  const std::size_t width = std::size_t(g.layout().brick);
  const std::int64_t count = grid.voxel_count();
  std::vector<lod::ResidentBrick> slots(static_cast<std::size_t>(count));
  std::vector<std::uint8_t> keep(static_cast<std::size_t>(count), 0);
  std::exception_ptr failure;
#pragma omp parallel num_threads(thread_count())
  {
    tensor::BrickReconstructor reconstructor;
    ta::DecodeScratch scratch;
#pragma omp for schedule(dynamic)
    for (std::int64_t i = 0; i < count; ++i) {
      try {
        const store::BrickKey key{std::uint8_t(level), std::int32_t(i % grid.x), std::int32_t((i / grid.x) % grid.y),
                                  std::int32_t(i / (grid.x * grid.y))};
        const store::BrickEntry* entry = &volume.entry(key);
        if (!lod::brick_visible(*entry, visible_mask, volume.value_min(), volume.value_max())) continue;
        lod::ResidentBrick& b = slots[std::size_t(i)];
        b.key = key;
        b.rank = std::clamp(rank, 1, volume.rank());
        keep[std::size_t(i)] = 1;
        if (entry->kind == store::PayloadKind::constant) {
          b.constant_value = entry->min;
          continue;
        }
        auto samples = std::make_shared<std::vector<float>>(width * width * width);
        volume.decode_brick(key, b.rank, *samples, reconstructor, scratch);
        b.samples = std::move(samples);
      } catch (...) {
#pragma omp critical
        if (!failure) failure = std::current_exception();
      }
    }
  }
  if (failure) std::rethrow_exception(failure);
  lod::FrameBricks frame;
  for (std::size_t i = 0; i < slots.size(); ++i)
    if (keep[i]) frame.bricks.push_back(std::move(slots[i]));
  frame.stats.selected = frame.stats.resident = frame.bricks.size();
  return frame;
}

lod::FrameBricks bricks_from_volume(const Volume& volume, const ta::OctreeGeometry& geometry) {
  if (!(volume.dims() == geometry.level(0).dims))
    throw Error("render: volume " + volume.dims().to_string() + " does not match the octree's level 0 " +
                geometry.level(0).dims.to_string());
  const Volume f = volume.dtype() == DType::f32 ? Volume() : volume.converted(DType::f32);
  const auto src = (volume.dtype() == DType::f32 ? volume : f).view<float>();
  const Extent grid = geometry.level(0).bricks, dims = volume.dims();
  const int width = geometry.layout().brick;
  lod::FrameBricks frame;
  frame.bricks.resize(std::size_t(grid.voxel_count()));
#pragma omp parallel for schedule(dynamic) num_threads(thread_count())
  for (std::int64_t i = 0; i < grid.voxel_count(); ++i) {
    const std::int64_t bx = i % grid.x, by = (i / grid.x) % grid.y, bz = i / (grid.x * grid.y);
    const Box box = geometry.brick_sample_box(0, bx, by, bz);
    auto samples = std::make_shared<std::vector<float>>(std::size_t(width) * width * width);
    float* out = samples->data();
    // Samples outside the volume repeat the edge voxel, as the compressor stores them.
    for (std::int64_t z = box.lo.z; z < box.hi.z; ++z)
      for (std::int64_t y = box.lo.y; y < box.hi.y; ++y)
        for (std::int64_t x = box.lo.x; x < box.hi.x; ++x)
          *out++ = src(std::clamp<std::int64_t>(x, 0, dims.x - 1), std::clamp<std::int64_t>(y, 0, dims.y - 1),
                       std::clamp<std::int64_t>(z, 0, dims.z - 1));
    lod::ResidentBrick& b = frame.bricks[std::size_t(i)];
    b.key = {0, std::int32_t(bx), std::int32_t(by), std::int32_t(bz)};
    b.rank = width;
    b.samples = std::move(samples);
  }
  frame.stats.selected = frame.stats.resident = frame.bricks.size();
  return frame;
}

}  // namespace strata::render
