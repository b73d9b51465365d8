// The march over one block's lattice points: the scalar loop (Marcher, per sampler, table kind
// and shading), which hands pre-integrated grid blocks to the 8-lane march (march8.cpp) when the
// CPU allows it, and march_function, which picks a block's march for the traversal.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <type_traits>

#include "render/march8.hpp"
#include "render/ray_sampling.hpp"
#include "render/ray_traversal.hpp"
#include "render/shading.hpp"

namespace strata::render::detail {

namespace {

// Straight-line local position of ray parameter t in block b.
inline void local_position(const Block& b, const RayContext& ray, double t, float p[3]) {
  for (int a = 0; a < 3; ++a) p[a] = float((ray.origin[a] + ray.dir[a] * t) * b.scale[a] + b.offset[a]);
}

template <class Sampler, bool Preint, bool Shade>
struct Marcher {
  // Classifies the segment from `front` to the sample at (x, y, z), `ratio` steps long
  // (1 inside a block; other values only where a segment meets an entry, exit or level
  // change), shades it and composites it under `acc`. Returns the sample's normalised value.
  // `half_step` is half of one step in local voxels: a pre-integrated segment is classified
  // through its midpoint value (split_pair) and shaded by the gradient there, (x, y, z) - ratio
  // * half_step. Shading it by its back sample's gradient would shift the lighting half a step
  // along the ray, an error proportional to the step.
  [[gnu::always_inline]] static inline float segment(const Sampler& sample, const Block& b, const LevelParams& lp, const MarchParams& mp,
                       const RayContext& ray, float x, float y, float z, float front, double ratio,
                       const float half_step[3], Rgbaf& acc) {
    const float v = normalised_sample(sample, x, y, z, mp.value_lo, mp.value_scale);
    const float r = float(ratio);
    const float mx = x - half_step[0] * r, my = y - half_step[1] * r, mz = z - half_step[2] * r;
    const float mid = Preint ? normalised_sample(sample, mx, my, mz, mp.value_lo, mp.value_scale) : v;
    // NaN or infinite voxels (masked cells, outside a field of view) are empty space, and so is a
    // segment that starts, passes or ends in them.
    if (!std::isfinite(v) || (Preint && !(std::isfinite(front) && std::isfinite(mid)))) return v;
    const float lo = Preint ? std::min(std::min(front, v), mid) : v, hi = Preint ? std::max(std::max(front, v), mid) : v;
    if (mp.next_visible[Transparency::bin(lo)] > Transparency::bin(hi)) return v;
    Rgbaf c;
    if constexpr (Preint) {
      c = split_pair(lp.classify, front, mid, v, ratio);
    } else {
      c = lp.classify.single(v);
      if (ratio != 1.0) c = rescale_segment(c, ratio);
    }
    if (c.a <= 0.0f) return v;
    if constexpr (Shade) {
      if (c.a > lp.shade_threshold) {
        float g[3];
        sample.gradient(mx, my, mz, g);
        if (!std::isfinite(g[0]) || !std::isfinite(g[1]) || !std::isfinite(g[2])) sample.finite_gradient(mx, my, mz, g);
        g[0] *= b.gradient_scale[0];
        g[1] *= b.gradient_scale[1];
        g[2] *= b.gradient_scale[2];
        const float len2 = g[0] * g[0] + g[1] * g[1] + g[2] * g[2];
        if (len2 > 1e-12f) {
          // Two-sided Blinn-Phong with a headlight: the half vector equals the light vector.
          const float ndl = std::abs(g[0] * ray.light[0] + g[1] * ray.light[1] + g[2] * ray.light[2]) / std::sqrt(len2);
          const float diffuse = mp.light.ambient + mp.light.diffuse * ndl;
          const float spec = mp.light.specular * specular_power(ndl, mp.light.shininess) * c.a;
          c.r = c.r * diffuse + spec;
          c.g = c.g * diffuse + spec;
          c.b = c.b * diffuse + spec;
        }
      }
    }
    const float w = 1.0f - acc.a;
    acc.r += w * c.r;
    acc.g += w * c.g;
    acc.b += w * c.b;
    acc.a += w * c.a;
    return v;
  }

  // Composites lattice points k0..k1-1 of block `b` (at its level's step). The first segment
  // starts at the previous sample when it lies within one step (its true length is used), at
  // the volume entry when the ray has no sample yet, and otherwise (after skipped space) one
  // step back, sampled here. With `skip` and the block's macro-cell flags, later lattice points
  // whose segment ends in an empty cell are not sampled (render/occupancy.hpp): such a segment
  // is transparent; the next sampled segment takes its front value afresh. Returns false when
  // the segment after k1 - 1 (the block's closing segment) is transparent for the same reason,
  // so neither a closing segment nor a tail is due.
  static bool lattice(const Block& b, std::int64_t k0, std::int64_t k1, const RayContext& ray, const MarchParams& mp,
                      RayState& st, bool skip) {
    const Sampler sample(b);
    const LevelParams& lp = mp.levels[b.level];
    const double h = lp.h;
    float p[3], dp[3];
    local_position(b, ray, double(k0) * h, p);
    for (int a = 0; a < 3; ++a) dp[a] = float(ray.dir[a] * h * b.scale[a]);
    const float half_step[3] = {0.5f * dp[0], 0.5f * dp[1], 0.5f * dp[2]};
    const double t0 = double(k0) * h;
    float front;
    double first_ratio = 1.0;
    std::uint64_t taken = 0;  // samples taken
    if (t0 - st.prev_t <= h * (1 + 1e-9)) {
      first_ratio = (t0 - st.prev_t) / h;
      if (st.has_prev) {
        front = st.prev_x;
      } else {
        float e[3];
        local_position(b, ray, st.prev_t, e);
        front = normalised_sample(sample, e[0], e[1], e[2], mp.value_lo, mp.value_scale);
      }
    } else {
      front = normalised_sample(sample, p[0] - dp[0], p[1] - dp[1], p[2] - dp[2], mp.value_lo, mp.value_scale);
    }
    if (std::abs(first_ratio - 1.0) < 1e-6) first_ratio = 1.0;
    Rgbaf acc = st.acc;
    std::int64_t k = k0;
    std::int64_t last = k0 - 1;  // last lattice point whose value `front` holds
    bool closing = true;
    // The AVX2 loop takes every segment one step long, so also a first segment of ratio 1
    // (front then holds the value one step back).
    bool simd_block = false;
    if constexpr (std::is_same_v<Sampler, GridSampler> && Preint)  // gather indices are 32-bit
      simd_block = mp.simd && std::int64_t(b.n[0]) * b.n[1] * b.n[2] < (std::int64_t(1) << 31);
    if (k < k1 && !(simd_block && first_ratio == 1.0)) {  // the first segment, peeled
      front = segment(sample, b, lp, mp, ray, p[0], p[1], p[2], front, first_ratio, half_step, acc);
      ++taken;
      last = k;
      ++k;
    }
    const bool use_skip = skip && b.empty;
    bool vectorised = false;
#if STRATA_X86_64
    if constexpr (std::is_same_v<Sampler, GridSampler> && Preint) {
      if (simd_block && k < k1 && acc.a <= mp.termination) {
        k = mp.avx512 ? march8_avx512<Shade>(sample, b, lp, mp, ray, p, dp, k0, k, k1, use_skip, front, last, acc, taken)
                      : march8<Shade>(sample, b, lp, mp, ray, p, dp, k0, k, k1, use_skip, front, last, acc, taken);
        vectorised = true;
      }
    }
#endif
    if (!vectorised && !use_skip) {
      const std::int64_t k_loop = k;
      for (; k < k1 && acc.a <= mp.termination; ++k) {
        const float j = float(k - k0);
        front = segment(sample, b, lp, mp, ray, p[0] + dp[0] * j, p[1] + dp[1] * j, p[2] + dp[2] * j, front, 1.0,
                        half_step, acc);
      }
      taken += std::uint64_t(k - k_loop);
      if (k > k_loop) last = k - 1;
    } else if (!vectorised) {
      for (; k < k1 && acc.a <= mp.termination; ++k) {
        const float j = float(k - k0);
        const float x = p[0] + dp[0] * j, y = p[1] + dp[1] * j, z = p[2] + dp[2] * j;
        if (b.empty_at(x, y, z)) continue;
        if (last != k - 1) {  // resuming after skipped segments: the front sample afresh
          front = normalised_sample(sample, x - dp[0], y - dp[1], z - dp[2], mp.value_lo, mp.value_scale);
          ++taken;
        }
        front = segment(sample, b, lp, mp, ray, x, y, z, front, 1.0, half_step, acc);
        ++taken;
        last = k;
      }
    }
    if (use_skip) {
      if (k == k1 && acc.a <= mp.termination && last < k1 - 1 && k1 - 1 >= k0) {
        // The ray goes on past the block: the closing segment (k1 - 1, k1] is due only when it
        // can be visible, and then it needs the value at k1 - 1.
        const float j = float(k1 - k0);
        if (b.empty_at(p[0] + dp[0] * j, p[1] + dp[1] * j, p[2] + dp[2] * j)) {
          closing = false;
        } else {
          const float jl = j - 1.0f;
          front = normalised_sample(sample, p[0] + dp[0] * jl, p[1] + dp[1] * jl, p[2] + dp[2] * jl, mp.value_lo,
                                    mp.value_scale);
          ++taken;
          last = k1 - 1;
        }
      }
    }
    st.samples += taken;
    st.acc = acc;
    if (last >= k0) {
      st.has_prev = true;
      st.prev_k = last;
      st.prev_level = b.level;
      st.prev_t = double(last) * h;
      st.prev_x = front;
    }
    if (!closing) {
      // Everything up to lattice point k1 is transparent: the next segment starts from
      // k1 - 1 (sampled by whatever comes next), never from a sample before the skipped run.
      st.has_prev = false;
      st.prev_t = double(k1 - 1) * h;
    }
    return closing;
  }

  // The partial segment from the last sample to the volume exit at t_end.
  static void tail(const Block& b, double t_end, const RayContext& ray, const MarchParams& mp, RayState& st) {
    const LevelParams& lp = mp.levels[b.level];
    const double ratio = (t_end - st.prev_t) / lp.h;
    // Longer than one step only when the last block was too thin for a lattice point of its
    // own (at most the previous level's step plus this one's): composited as one segment.
    if (ratio <= 1e-6) return;
    const Sampler sample(b);
    float p[3];
    float front = st.prev_x;
    if (!st.has_prev) {  // a chord shorter than one step: from the entry to the exit
      local_position(b, ray, st.prev_t, p);
      front = normalised_sample(sample, p[0], p[1], p[2], mp.value_lo, mp.value_scale);
    }
    local_position(b, ray, t_end, p);
    float half_step[3];
    for (int a = 0; a < 3; ++a) half_step[a] = 0.5f * float(ray.dir[a] * lp.h * b.scale[a]);
    segment(sample, b, lp, mp, ray, p[0], p[1], p[2], front, ratio, half_step, st.acc);
    ++st.samples;
  }
};

template <class Sampler, bool Preint, bool Shade>
MarchFns fns() {
  return {&Marcher<Sampler, Preint, Shade>::lattice, &Marcher<Sampler, Preint, Shade>::tail};
}

template <bool Preint, bool Shade>
MarchFns pick(bool constant) {
  return constant ? fns<ConstantSampler, Preint, false>() : fns<GridSampler, Preint, Shade>();
}

}  // namespace

MarchFns march_function(const Block& b, bool preint, bool shade) {
  const bool constant = b.data == nullptr;
  if (preint) return shade ? pick<true, true>(constant) : pick<true, false>(constant);
  return shade ? pick<false, true>(constant) : pick<false, false>(constant);
}

}  // namespace strata::render::detail
