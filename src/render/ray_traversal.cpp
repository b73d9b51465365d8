#include "render/ray_traversal.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "render/traversal.hpp"
#include "strata/core/isa.hpp"
#include "strata/core/threads.hpp"

namespace strata::render::detail {

namespace {

// floor / ceil to an integer without a libm call (the portable build has no roundsd); equal to
// std::int64_t(std::floor(x)) / std::int64_t(std::ceil(x)) wherever those are defined.
inline std::int64_t ifloor(double x) {
  const auto i = std::int64_t(x);
  return i - (double(i) > x ? 1 : 0);
}
inline std::int64_t iceil(double x) {
  const auto i = std::int64_t(x);
  return i + (double(i) < x ? 1 : 0);
}

// ---- Traversal ------------------------------------------------------------------------------

struct Traversal {
  const FrameIndex& index;
  const std::vector<MarchFns>& march;
  const MarchParams& mp;
  double eps;  // parametric nudge past a face, to locate the next cell
  std::array<double, 3> inv_cell;  // 1 / index.cell_size (the nudge dwarfs the product's rounding)

  // Block b's first lattice point after the previous sample (which may belong to an earlier
  // block of another level, e.g. when b was too thin to hold a lattice point).
  std::int64_t next_lattice_point(const Block& b, const RayState& st) const {
    if (st.has_prev && st.prev_level == b.level) return st.prev_k + 1;
    return ifloor(st.prev_t / mp.levels[b.level].h) + 1;
  }

  // When the ray leaves a marched block into skipped space, the segment from its last sample
  // to the next lattice point still belongs to the block: it is sampled from the overlap.
  void close(const RayContext& ray, RayState& st) const {
    if (!st.open) return;
    st.open = false;
    const Block& b = *st.last;
    const std::int64_t k = next_lattice_point(b, st);
    march[std::size_t(&b - index.blocks.data())].lattice(b, k, k + 1, ray, mp, st, false);
  }

  void block_interval(const Block& b, double t_in, double t_out, const RayContext& ray, RayState& st) const {
    const double h = mp.levels[b.level].h;
    std::int64_t k0 = iceil(t_in / h);
    const std::int64_t k1 = iceil(t_out / h);
    // Never revisit a lattice point a closing segment (or the previous block) already took.
    if (st.has_prev) k0 = std::max(k0, next_lattice_point(b, st));
    bool closing = true;
    if (k0 < k1) {
      const std::size_t id = std::size_t(&b - index.blocks.data());
      closing = march[id].lattice(b, k0, k1, ray, mp, st, true);
      st.touched[id] = 1;
    }
    st.open = closing;
    st.last = &b;
  }

  // `inv`: 1 / ray.dir per axis (0 where the direction is 0).
  void trace(const RayContext& ray, const std::array<double, 3>& inv, double t, double t_end, RayState& st) const {
    const auto& c = index.cells;
    while (t < t_end && st.acc.a <= mp.termination) {
      const double tp = t + eps;
      std::array<std::int64_t, 3> cell{};
      for (int a = 0; a < 3; ++a)
        cell[a] = std::clamp(ifloor((ray.origin[a] + ray.dir[a] * tp) * inv_cell[a]),
                             std::int64_t(0), c[a] - 1);
      const std::int32_t id = index.block_at(cell[0], cell[1], cell[2]);
      const Block* b = id >= 0 ? &index.blocks[std::size_t(id)] : nullptr;
      double t_next;
      if (b && b->exclusive) {
        t_next = box_exit(ray.origin, ray.dir, b->lo, b->hi, TimesInverse{inv});
      } else {
        std::array<double, 3> lo{}, hi{};
        for (int a = 0; a < 3; ++a) {
          lo[a] = double(cell[a]) * index.cell_size[a];
          hi[a] = std::min(lo[a] + index.cell_size[a], index.volume_hi[a]);
        }
        t_next = box_exit(ray.origin, ray.dir, lo, hi, TimesInverse{inv});
      }
      t_next = std::min(std::max(t_next, tp), t_end);
      if (!b || b->culled) {
        close(ray, st);
      } else {
        // At a level change the previous block also closes its last step, so the next
        // block's first segment starts at most one of its own steps back.
        if (st.open && st.last->level != b->level) close(ray, st);
        block_interval(*b, t, t_next, ray, st);
      }
      t = t_next;
    }
    // The ray left the volume inside a block: its last partial segment still counts, so the
    // integrated length equals the chord for every step size.
    if (st.open && t >= t_end && st.acc.a <= mp.termination)
      march[std::size_t(st.last - index.blocks.data())].tail(*st.last, t_end, ray, mp, st);
  }
};

Rgba8 to_rgba8(const Rgbaf& acc, const std::array<float, 4>& bg) {
  // Over the background (straight colour, premultiplied here), then back to straight colour.
  const float w = 1.0f - acc.a;
  const float a = acc.a + w * bg[3];
  const float r = acc.r + w * bg[0] * bg[3], g = acc.g + w * bg[1] * bg[3], b = acc.b + w * bg[2] * bg[3];
  const float inv = a > 0 ? 1.0f / a : 0.0f;
  return {unit_to_byte(r * inv), unit_to_byte(g * inv), unit_to_byte(b * inv), unit_to_byte(a)};
}

// One thread's share of a frame: casts pixels, counts rays and samples, and flags the blocks
// it sampled.
struct PixelCaster {
  const Traversal& trav;
  const Camera& cam;
  const std::array<float, 4>& background;
  Image& image;
  double jitter_span;  // the coarsest level's step when rays are jittered, else 0
  std::uint32_t jitter_pass;
  std::vector<std::uint8_t> touched;  // per block
  std::uint64_t rays = 0, samples = 0;

  void operator()(int px, int py) {
    const Ray r = cam.ray(px, py);
    // Lattice points lie at whole steps from the ray's origin: moving the origin back by a
    // fraction of the coarsest step shifts every level's lattice (a level's step divides the
    // coarsest one, so its phase is that fraction times a power of two, modulo 1).
    const double shift = jitter_span * lattice_offset(px, py, jitter_pass);
    RayContext ray{{r.origin.x - r.direction.x * shift, r.origin.y - r.direction.y * shift, r.origin.z - r.direction.z * shift},
                   {r.direction.x, r.direction.y, r.direction.z},
                   {float(-r.direction.x), float(-r.direction.y), float(-r.direction.z)}};
    std::array<double, 3> inv{};
    for (int a = 0; a < 3; ++a) inv[a] = ray.dir[a] != 0 ? 1.0 / ray.dir[a] : 0.0;
    auto [t0, t1] = clip_to_box(ray.origin, ray.dir, trav.index.volume_hi, TimesInverse{inv});
    t0 = std::max(t0, shift);  // nothing behind the camera's own origin
    RayState st;
    st.touched = touched.data();
    st.prev_t = t0;  // the volume entry starts the first segment
    if (t0 < t1) {
      ++rays;
      trav.trace(ray, inv, t0, t1, st);
      samples += st.samples;
    }
    image.at(px, py) = to_rgba8(st.acc, background);
  }
};

// The step of the coarsest level the frame holds (0 for an empty frame).
double coarsest_step(const RenderJob& job) {
  int level = -1;
  for (const Block& b : job.index.blocks) level = std::max(level, b.level);
  return level >= 0 ? job.levels[std::size_t(level)].h : 0.0;
}

}  // namespace

Image run(const RenderJob& job, RenderStats& stats) {
  const FrameIndex& index = job.index;
  std::vector<MarchFns> march;
  march.reserve(index.blocks.size());
  for (const Block& b : index.blocks) march.push_back(march_function(b, job.options.preintegrated, job.options.shading));
  const Transparency& transparency = job.transparency;
  const Isa isa = active_isa();
  const MarchParams mp{isa >= Isa::avx2, isa >= Isa::avx512,
                       job.levels.data(), transparency.next_visible.data(), job.value_lo, job.value_scale, job.options.light, job.options.termination_alpha};
  double extent = 0;
  for (double v : index.volume_hi) extent = std::max(extent, v);
  const Traversal trav{index, march, mp, 1e-9 * std::max(extent, 1.0),
                       {1.0 / index.cell_size[0], 1.0 / index.cell_size[1], 1.0 / index.cell_size[2]}};

  const Camera& cam = job.camera;
  Image image(cam.width(), cam.height());
  const int threads = job.options.threads > 0 ? job.options.threads : thread_count();
  std::vector<std::uint8_t> sampled(index.blocks.size(), 0);
  stats.rays = stats.samples = 0;
  const double jitter_span = job.options.jitter ? coarsest_step(job) : 0.0;
  for_each_pixel(
      TileGrid{cam.width(), cam.height(), job.options.tile}, threads,
      [&] {
        return PixelCaster{trav, cam, job.options.background, image, jitter_span, job.options.jitter_pass,
                           std::vector<std::uint8_t>(index.blocks.size(), 0)};
      },
      [&](const PixelCaster& c) {
        stats.rays += c.rays;
        stats.samples += c.samples;
        for (std::size_t i = 0; i < c.touched.size(); ++i) sampled[i] |= c.touched[i];
      });
  stats.bricks_sampled = std::uint64_t(std::count(sampled.begin(), sampled.end(), std::uint8_t(1)));
  return image;
}

}  // namespace strata::render::detail
