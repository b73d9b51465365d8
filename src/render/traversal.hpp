#pragma once
// What the scalar ray caster (ray_traversal.cpp) and the label ray caster (label_raycaster.cpp)
// share: the image cut into tiles and the parallel loop over them, the slab test that clips a
// ray to the volume's box, the exit of a ray from a box (where a brick, a brick cell or an empty
// cube ends) and the rounding of a composited channel to a byte. Each caster supplies what
// differs: its ray space, how it turns a distance along an axis into a ray parameter, and its
// sampling, classification, empty-space structure and compositing.
//
// The casters' images depend on the exact floating-point operations, so nothing here computes
// a ray parameter by a rule of its own: the caster's ParamRule does (the scalar caster multiplies
// by the reciprocal direction, the label caster divides by the direction), and the shared code
// performs the operations each caster performed before, in the same order.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <utility>

namespace strata::render::detail {

// ---- Tiles ----------------------------------------------------------------------------------

// An image of width x height pixels cut into tiles of tile x tile pixels, numbered row by row;
// the last column and row of tiles are cut to the image.
struct TileGrid {
  int width = 0, height = 0, tile = 1;  // tile >= 1 (the casters' options checks)

  struct Rect {
    int x0, y0, x1, y1;  // pixels [x0, x1) x [y0, y1)
  };

  int columns() const { return (width + tile - 1) / tile; }
  int rows() const { return (height + tile - 1) / tile; }
  std::int64_t count() const { return std::int64_t(columns()) * rows(); }
  Rect at(std::int64_t t) const {
    const int x0 = int(t % columns()) * tile, y0 = int(t / columns()) * tile;
    return {x0, y0, std::min(x0 + tile, width), std::min(y0 + tile, height)};
  }
};

// Calls worker(px, py) once for every pixel of `grid`: tiles are handed to `threads` OpenMP
// threads one at a time (a dynamic schedule, since a tile's cost depends on what its rays meet),
// pixels row by row inside a tile. Each thread casts with its own worker, made by make(), and
// hands it to merge() once when the tiles run out, one thread at a time, so per-thread counters
// and flags need no atomics.
template <class Make, class Merge>
void for_each_pixel(const TileGrid& grid, int threads, Make&& make, Merge&& merge) {
  const std::int64_t tiles = grid.count();
#pragma omp parallel num_threads(threads)
  {
    auto worker = make();
#pragma omp for schedule(dynamic, 1)
    for (std::int64_t t = 0; t < tiles; ++t) {
      const TileGrid::Rect r = grid.at(t);
      for (int py = r.y0; py < r.y1; ++py)
        for (int px = r.x0; px < r.x1; ++px) worker(px, py);
    }
#pragma omp critical
    merge(worker);
  }
}

// ---- Boxes ----------------------------------------------------------------------------------

// Ray parameters of the scalar caster: a distance along axis a times 1 / dir[a] (`inv`, one
// division per axis and ray).
struct TimesInverse {
  const std::array<double, 3>& inv;
  double operator()(int a, double distance) const { return distance * inv[std::size_t(a)]; }
};

// Ray parameters of the label caster: a distance along axis a divided by dir[a].
template <class Point>
struct DividedByDirection {
  const Point& dir;
  double operator()(int a, double distance) const { return distance / dir[a]; }
};

// [t_enter, t_exit] of the ray origin + t dir (t >= 0) inside the box [0, hi]: the slab test.
// The ray misses the box when t_enter >= t_exit, which includes a ray parallel to an axis
// outside the box's slab ({1, 0}). Point: anything indexed by axis 0..2 (std::array, Vec3).
template <class Point, class ParamRule>
std::pair<double, double> clip_to_box(const Point& origin, const Point& dir, const Point& hi, ParamRule param) {
  double t0 = 0, t1 = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    if (dir[a] == 0) {
      if (origin[a] < 0 || origin[a] > hi[a]) return {1, 0};
      continue;
    }
    double ta = param(a, 0 - origin[a]), tb = param(a, hi[a] - origin[a]);
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  return {t0, t1};
}

// The parameter where a ray that is inside the box [lo, hi] leaves it (+inf when dir is 0):
// where a skipped brick cell or empty cube ends, or a brick's own interval.
template <class Point, class Corner, class ParamRule>
double box_exit(const Point& origin, const Point& dir, const Corner& lo, const Corner& hi, ParamRule param) {
  double t = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    if (dir[a] > 0) t = std::min(t, param(a, hi[a] - origin[a]));
    else if (dir[a] < 0) t = std::min(t, param(a, lo[a] - origin[a]));
  }
  return t;
}

// ---- Pixels ---------------------------------------------------------------------------------

// A pixel's sample-lattice offset in [0, 1), as a fraction of a step: interleaved gradient
// noise (Jimenez 2014), whose neighbouring values differ by large, evenly spread amounts, so
// the step's error shows as fine noise rather than rings. Pass k adds k times the golden-ratio
// fraction: the offsets of passes 0..n-1 lie evenly spread in [0, 1) for every pixel.
inline double lattice_offset(int px, int py, std::uint32_t pass) {
  const double g = 52.9829189 * (0.06711056 * px + 0.00583715 * py - std::floor(0.06711056 * px + 0.00583715 * py));
  const double u = g + 0.6180339887498949 * double(pass);
  return u - std::floor(u);
}

// A colour channel in [0, 1] (clamped) as the nearest of 256 levels.
inline std::uint8_t unit_to_byte(float v) { return std::uint8_t(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f)); }

}  // namespace strata::render::detail
