// "superpixels": the over-segmentation a 2D pipeline makes of serial-section EM before
// agglomeration. Every z-slice (section) is cut into about N superpixels, each section has its
// own ids (a superpixel never continues into the next section), and there is no background.
// Consecutive sections often show the same structures, so sections come in runs (1, 2, 3 ...
// slices, each slice starting a new run with probability 1/2) that share one partition under
// different ids: the dyadic, exactly repeating mixtures real superpixel stacks produce in the
// histogram mipmap (e.g. fibsem_medulla_250_sp).
//
// A partition is the nearest-site (Voronoi) diagram of one jittered site per cell of a
// gx x gy grid (gx gy ~ N): the site of a voxel's own cell is within sqrt(2) cells, every site
// three or more cells away is at least two cells away, so the 5 x 5 cells around the voxel hold
// its nearest site. Ids of section z: z * gx * gy + cell + 1.
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "gen/noise.hpp"
#include "gen/slice_generator.hpp"
#include "strata/core/error.hpp"

namespace strata::gen::detail {

namespace {

class SuperpixelGenerator final : public SliceGenerator {
 public:
  explicit SuperpixelGenerator(const Params& p);

 protected:
  void fill_rows(std::int64_t z, std::int64_t y0, std::int64_t y1, std::byte* rows) const override;

 private:
  // The first slice of the run holding slice z (its partition's seed).
  std::int64_t run_start(std::int64_t z) const;
  // Site of grid cell (i, j) in partition `run`, voxel coordinates.
  void site(std::int64_t run, std::int64_t i, std::int64_t j, double& sx, double& sy) const;

  std::uint64_t seed_;
  std::int64_t gx_ = 1, gy_ = 1;
  double cell_x_ = 1.0, cell_y_ = 1.0;
};

SuperpixelGenerator::SuperpixelGenerator(const Params& p)
    : SliceGenerator(VolumeInfo{p.dims, DType::u32, {}}), seed_(p.seed) {
  const double area = double(p.dims.x) * double(p.dims.y);
  const double side = std::sqrt(area / double(p.count));
  gx_ = std::clamp<std::int64_t>(std::llround(double(p.dims.x) / side), 1, p.dims.x);
  gy_ = std::clamp<std::int64_t>(std::llround(double(p.dims.y) / side), 1, p.dims.y);
  cell_x_ = double(p.dims.x) / double(gx_);
  cell_y_ = double(p.dims.y) / double(gy_);
  const double ids = double(gx_) * double(gy_) * double(p.dims.z);
  if (ids > double(std::numeric_limits<std::uint32_t>::max()))
    throw Error("generate superpixels: " + std::to_string(gx_ * gy_) + " superpixels per section times " +
                std::to_string(p.dims.z) + " sections exceed the u32 label range");
}

std::int64_t SuperpixelGenerator::run_start(std::int64_t z) const {
  const std::uint64_t s = derive_seed(seed_, 21);
  while (z > 0 && (hash_combine(s, z) >> 63) == 0) --z;
  return z;
}

void SuperpixelGenerator::site(std::int64_t run, std::int64_t i, std::int64_t j, double& sx, double& sy) const {
  const std::uint64_t h = hash3(derive_seed(seed_, 22), i, j, run);
  const double u = double(h >> 40) * 0x1.0p-24, v = double((h >> 16) & 0xffffff) * 0x1.0p-24;
  sx = (double(i) + u) * cell_x_;
  sy = (double(j) + v) * cell_y_;
}

void SuperpixelGenerator::fill_rows(std::int64_t z, std::int64_t y0, std::int64_t y1, std::byte* rows) const {
  const std::int64_t nx = info().dims.x;
  const std::int64_t run = run_start(z);
  const std::uint64_t first_id = std::uint64_t(z) * std::uint64_t(gx_ * gy_) + 1;
  auto* out = reinterpret_cast<std::uint32_t*>(rows);
  for (std::int64_t y = y0; y < y1; ++y) {
    const double fy = double(y) + 0.5;
    const std::int64_t cj = std::min(gy_ - 1, std::int64_t(fy / cell_y_));
    for (std::int64_t x = 0; x < nx; ++x) {
      const double fx = double(x) + 0.5;
      const std::int64_t ci = std::min(gx_ - 1, std::int64_t(fx / cell_x_));
      double best = std::numeric_limits<double>::infinity();
      std::int64_t best_cell = 0;
      for (std::int64_t j = std::max<std::int64_t>(0, cj - 2); j <= std::min(gy_ - 1, cj + 2); ++j)
        for (std::int64_t i = std::max<std::int64_t>(0, ci - 2); i <= std::min(gx_ - 1, ci + 2); ++i) {
          double sx, sy;
          site(run, i, j, sx, sy);
          const double d2 = (sx - fx) * (sx - fx) + (sy - fy) * (sy - fy);
          if (d2 < best) best = d2, best_cell = j * gx_ + i;  // ties: the first cell in scan order
        }
      out[(y - y0) * nx + x] = std::uint32_t(first_id + std::uint64_t(best_cell));
    }
  }
}

}  // namespace

std::unique_ptr<Generator> make_superpixels(const Params& params) {
  return std::make_unique<SuperpixelGenerator>(params);
}

}  // namespace strata::gen::detail
