#include "gen/slice_generator.hpp"

#include <algorithm>
#include <cmath>

#include "strata/core/error.hpp"
#include "strata/core/threads.hpp"

namespace strata::gen::detail {

namespace {
// Tasks of about this many voxels: large enough to amortise per-task setup (noise lattices,
// object lookups), small enough to balance across threads even for a single slice.
constexpr std::int64_t kTaskVoxels = 1 << 16;
}  // namespace

Volume SliceGenerator::slab(std::int64_t z0, std::int64_t z1) const {
  return slab_in_blocks(z0, z1, kTaskVoxels / std::max<std::int64_t>(info_.dims.x, 1));
}

Volume SliceGenerator::slab_in_blocks(std::int64_t z0, std::int64_t z1, std::int64_t rows_per_task) const {
  const Extent& dims = info_.dims;
  if (z0 < 0 || z1 < z0 || z1 > dims.z) {
    throw Error("generator slab [" + std::to_string(z0) + ", " + std::to_string(z1) +
                ") is outside slices [0, " + std::to_string(dims.z) + ")");
  }
  Volume out(Extent{dims.x, dims.y, z1 - z0}, info_.dtype, info_.spacing);
  rows_per_task = std::clamp<std::int64_t>(rows_per_task, 1, dims.y);
  const std::int64_t blocks = (dims.y + rows_per_task - 1) / rows_per_task;
  const std::int64_t tasks = (z1 - z0) * blocks;
  const std::size_t row_bytes = std::size_t(dims.x) * dtype_size(info_.dtype);
  std::byte* base = out.bytes();
#pragma omp parallel for schedule(dynamic) num_threads(strata::thread_count())
  for (std::int64_t task = 0; task < tasks; ++task) {
    const std::int64_t z = z0 + task / blocks;
    const std::int64_t y0 = (task % blocks) * rows_per_task, y1 = std::min(dims.y, y0 + rows_per_task);
    fill_rows(z, y0, y1, base + std::size_t((z - z0) * dims.y + y0) * row_bytes);
  }
  return out;
}

double mean_extent(const Extent& dims) {
  return std::cbrt(double(dims.x) * double(dims.y) * double(dims.z));
}

double zbin_index_bytes(std::int64_t depth) { return (double(depth) / 8 + 2) * sizeof(std::size_t); }

}  // namespace strata::gen::detail
