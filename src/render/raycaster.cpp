#include "strata/render/raycaster.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define STRATA_RENDER_AVX2 1
#else
#define STRATA_RENDER_AVX2 0
#endif
#include <type_traits>
#include <limits>
#include <nlohmann/json.hpp>

#include "render/frame_index.hpp"
#include "render/shading.hpp"
#include "strata/core/error.hpp"
#include "strata/core/threads.hpp"

namespace strata::render {

using detail::Block;
using detail::CellFlags;
using detail::CellRanges;
using detail::FrameIndex;

// Classification tables of one level: the step ratio h_l / reference differs per level.
struct RayCaster::Tables {
  PreintegratedTable preintegrated;
  LookupTable lookup;
};

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

constexpr double kInf = std::numeric_limits<double>::infinity();

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
// Samples below this opacity skip the gradient (six extra trilinear taps).
constexpr float kShadeThreshold = 1.0f / 1024.0f;
// 8-lane march with empty-space skipping: a chunk whose first kRealign or more points lie in
// empty cells restarts at its first point that does not (the skipped segments are transparent,
// its front value is sampled afresh, as after a skipped chunk), so fewer lanes idle.
constexpr int kRealign = 2;

// ---- Sampling -------------------------------------------------------------------------------

// Trilinear interpolation in a block's samples; positions are clamped to the sample grid so
// pre-samples and closing samples just outside a brick's overlap read edge values.
struct GridSampler {
  const float* data;
  std::ptrdiff_t dx, dy, dz;  // neighbour offsets (0 along an axis with one sample)
  float max_x, max_y, max_z;
  int nx, ny, nz;

  explicit GridSampler(const Block& b)
      : data(b.data),
        dx(b.n[0] > 1 ? 1 : 0),
        dy(b.n[1] > 1 ? std::ptrdiff_t(b.n[0]) : 0),
        dz(b.n[2] > 1 ? std::ptrdiff_t(b.n[0]) * b.n[1] : 0),
        max_x(limit(b.n[0])),
        max_y(limit(b.n[1])),
        max_z(limit(b.n[2])),
        nx(b.n[0]),
        ny(b.n[1]),
        nz(b.n[2]) {}

  // Largest coordinate whose +1 neighbour still exists.
  static float limit(int n) { return n > 1 ? float(n - 1) * (1.0f - 1e-6f) : 0.0f; }

  [[gnu::always_inline]] inline float operator()(float x, float y, float z) const {
    x = std::clamp(x, 0.0f, max_x);
    y = std::clamp(y, 0.0f, max_y);
    z = std::clamp(z, 0.0f, max_z);
    const int ix = int(x), iy = int(y), iz = int(z);
    const float fx = x - float(ix), fy = y - float(iy), fz = z - float(iz);
    const float* p = data + ix * dx + std::ptrdiff_t(iy) * dy + std::ptrdiff_t(iz) * dz;
    const float c00 = p[0] + fx * (p[dx] - p[0]);
    const float c10 = p[dy] + fx * (p[dy + dx] - p[dy]);
    const float c01 = p[dz] + fx * (p[dz + dx] - p[dz]);
    const float c11 = p[dz + dy] + fx * (p[dz + dy + dx] - p[dz + dy]);
    const float c0 = c00 + fy * (c10 - c00);
    const float c1 = c01 + fy * (c11 - c01);
    return c0 + fz * (c1 - c0);
  }

  // Central differences one voxel either side, in local voxel units (times 2): f(p + e_a) -
  // f(p - e_a) of the trilinear interpolant f. Trilinear interpolation is linear in the samples
  // and the taps are whole voxels apart, so this equals the trilinear interpolation of the
  // per-voxel differences v[i + 1] - v[i - 1]: one 4x2x2 / 2x4x2 / 2x2x4 stencil of 32 voxels
  // around the sample instead of six separate trilinear taps (same value up to rounding).
  void gradient(float x, float y, float z, float g[3]) const {
    // Near the grid's faces each tap is clamped on its own (as six trilinear taps).
    if (!(x >= 1.0f && y >= 1.0f && z >= 1.0f && x < float(nx - 2) && y < float(ny - 2) && z < float(nz - 2))) {
      g[0] = (*this)(x + 1, y, z) - (*this)(x - 1, y, z);
      g[1] = (*this)(x, y + 1, z) - (*this)(x, y - 1, z);
      g[2] = (*this)(x, y, z + 1) - (*this)(x, y, z - 1);
      return;
    }
    const int ix = int(x), iy = int(y), iz = int(z);
    const float fx = x - float(ix), fy = y - float(iy), fz = z - float(iz);
    const float* p = data + ix + std::ptrdiff_t(iy) * dy + std::ptrdiff_t(iz) * dz;
    // Rows along x through (y, z): the interpolated value and x difference.
    auto row = [&](std::ptrdiff_t off, float& l, float& d) {
      const float* r = p + off;
      const float a = r[-1], b = r[0], c = r[1], e = r[2];
      l = b + fx * (c - b);
      d = (c - a) + fx * ((e - b) - (c - a));
    };
    auto lin = [&](std::ptrdiff_t off) {
      const float* r = p + off;
      return r[0] + fx * (r[1] - r[0]);
    };
    float l00, l10, l01, l11, d00, d10, d01, d11;  // l{y}{z}
    row(0, l00, d00);
    row(dy, l10, d10);
    row(dz, l01, d01);
    row(dy + dz, l11, d11);
    const float gx0 = d00 + fy * (d10 - d00), gx1 = d01 + fy * (d11 - d01);
    g[0] = gx0 + fz * (gx1 - gx0);
    auto diff = [](float f, float lo_m, float l0, float l1, float hi_p) {  // lerp of (l1 - lo_m) and (hi_p - l0)
      const float a = l1 - lo_m, b = hi_p - l0;
      return a + f * (b - a);
    };
    const float gy0 = diff(fy, lin(-dy), l00, l10, lin(2 * dy));
    const float gy1 = diff(fy, lin(dz - dy), l01, l11, lin(dz + 2 * dy));
    g[1] = gy0 + fz * (gy1 - gy0);
    const float gz0 = diff(fz, lin(-dz), l00, l01, lin(2 * dz));
    const float gz1 = diff(fz, lin(dy - dz), l10, l11, lin(dy + 2 * dz));
    g[2] = gz0 + fy * (gz1 - gz0);
  }
};

struct ConstantSampler {
  float value;
  explicit ConstantSampler(const Block& b) : value(b.constant) {}
  float operator()(float, float, float) const { return value; }
  void gradient(float, float, float, float g[3]) const { g[0] = g[1] = g[2] = 0; }
};

// ---- Classification -------------------------------------------------------------------------

struct Classifier {
  const Rgbaf* table = nullptr;
  int size = 0;
  float last = 0;  // size - 1

  [[gnu::always_inline]] inline Rgbaf pair(float front, float back) const {  // bilinear in the pre-integrated table
    const float u = std::clamp(front, 0.0f, 1.0f) * last, v = std::clamp(back, 0.0f, 1.0f) * last;
    const int i = std::min(int(u), size - 2), j = std::min(int(v), size - 2);
    const float wu = u - float(i), wv = v - float(j);
    const Rgbaf* r0 = table + std::ptrdiff_t(i) * size + j;
    const Rgbaf* r1 = r0 + size;
    auto lerp = [](const Rgbaf& a, const Rgbaf& b, float w) {
      return Rgbaf{a.r + w * (b.r - a.r), a.g + w * (b.g - a.g), a.b + w * (b.b - a.b), a.a + w * (b.a - a.a)};
    };
    return lerp(lerp(r0[0], r0[1], wv), lerp(r1[0], r1[1], wv), wu);
  }

  [[gnu::always_inline]] inline Rgbaf single(float x) const {  // linear in the post-classification table
    const float u = std::clamp(x, 0.0f, 1.0f) * last;
    const int i = std::min(int(u), size - 2);
    const float w = u - float(i);
    const Rgbaf& a = table[i];
    const Rgbaf& b = table[i + 1];
    return {a.r + w * (b.r - a.r), a.g + w * (b.g - a.g), a.b + w * (b.b - a.b), a.a + w * (b.a - a.a)};
  }
};

// Rescales a premultiplied segment colour from its table length to `ratio` times that length.
Rgbaf rescale_segment(const Rgbaf& c, double ratio) {
  if (c.a <= 0.0f) return c;
  const float a = correct_opacity(std::min(c.a, 1.0f), ratio);
  const float k = a / c.a;
  return {c.r * k, c.g * k, c.b * k, a};
}

// ---- Per-ray state --------------------------------------------------------------------------

struct RayContext {
  std::array<double, 3> origin, dir;
  std::array<float, 3> light;  // unit vector towards the light (the eye: a headlight)
};

struct RayState {
  Rgbaf acc;                   // premultiplied, front to back
  bool has_prev = false;       // a sample exists behind the current position
  bool open = false;           // the last region marched was a block (a closing segment is due)
  const Block* last = nullptr;
  int prev_level = 0;
  std::int64_t prev_k = 0;     // lattice index of the previous sample (at prev_level)
  double prev_t = 0;           // parameter of the previous sample (before the first: the volume entry)
  float prev_x = 0;            // normalised value of the previous sample
  std::uint64_t samples = 0;
  std::uint8_t* touched = nullptr;  // per-thread flags: blocks this thread sampled
};

struct LevelParams {
  double h = 1;                // world step of the level
  Classifier classify;
};

// Transparent-segment test without touching the classification tables: a segment whose value
// range lies in bins where the TF is zero contributes nothing (pre-integrated or not).
struct Transparency {
  static constexpr int kBins = 1024;
  std::vector<std::uint16_t> next_visible;  // first visible bin >= i (kBins = none)

  explicit Transparency(const TransferFunction& tf) : next_visible(kBins + 1, kBins) {
    for (int i = kBins - 1; i >= 0; --i)
      next_visible[std::size_t(i)] = tf.visible(double(i) / kBins, double(i + 1) / kBins)
                                         ? std::uint16_t(i)
                                         : next_visible[std::size_t(i) + 1];
  }
  static int bin(float x) { return std::min(int(std::clamp(x, 0.0f, 1.0f) * float(kBins)), kBins - 1); }
};

struct MarchParams {
  bool simd;    // 8-lane path for pre-integrated grid blocks (march8)
  bool avx512;  // ... in its AVX-512 build
  const LevelParams* levels;
  const std::uint16_t* next_visible;
  float value_lo, value_scale;  // normalisation
  ShadingParams light;
  float termination;
};

// Straight-line local position of ray parameter t in block b.
inline void local_position(const Block& b, const RayContext& ray, double t, float p[3]) {
  for (int a = 0; a < 3; ++a) p[a] = float((ray.origin[a] + ray.dir[a] * t) * b.scale[a] + b.offset[a]);
}

// ---- AVX2 path ---------------------------------------------------------------------------------
// Eight consecutive lattice points of one block at a time (trilinear taps, transparency bins and
// table indices by 8-wide gathers), composited in order per lane. The arithmetic is the scalar
// path's, operation for operation and without FMA, so both give the same image; compiled for
// AVX2 and used only when the CPU has it (the default build stays portable x86-64). The loop's
// source (march8_body.hpp) is compiled twice: for AVX2 and for AVX-512 (EVEX, 32 registers),
// both with fp-contract=off, since GCC would otherwise fuse multiplies and adds into FMA there.

bool have_avx2() {
#if STRATA_RENDER_AVX2
  static const bool yes = __builtin_cpu_supports("avx2");
  return yes;
#else
  return false;
#endif
}

bool have_avx512() {
#if STRATA_RENDER_AVX2
  static const bool yes = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("avx512f") &&
                          __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512bw") &&
                          __builtin_cpu_supports("avx512dq");
  return yes;
#else
  return false;
#endif
}

#if STRATA_RENDER_AVX2

// a[l] = data[idx[l]], b[l] = data[idx[l] + 1] for 8 lanes: two 4-lane gathers of float pairs
// (half the gathered elements of two 8-lane float gathers), deinterleaved. Lanes outside
// `mask` (all bits set or clear per lane) load nothing and hold zeros.
[[gnu::target("avx2")]] inline void gather_pairs(const float* data, __m256i idx, __m256i mask, __m256& a, __m256& b) {
  const double* base = reinterpret_cast<const double*>(data);
  const __m256d zero = _mm256_setzero_pd();
  const __m256d m0 = _mm256_castsi256_pd(_mm256_cvtepi32_epi64(_mm256_castsi256_si128(mask)));
  const __m256d m1 = _mm256_castsi256_pd(_mm256_cvtepi32_epi64(_mm256_extracti128_si256(mask, 1)));
  const __m256 lo = _mm256_castpd_ps(_mm256_mask_i32gather_pd(zero, base, _mm256_castsi256_si128(idx), m0, 4));
  const __m256 hi = _mm256_castpd_ps(_mm256_mask_i32gather_pd(zero, base, _mm256_extracti128_si256(idx, 1), m1, 4));
  a = _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(_mm256_shuffle_ps(lo, hi, 0x88)), 0xD8));
  b = _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(_mm256_shuffle_ps(lo, hi, 0xDD)), 0xD8));
}

// Linear interpolation along x between data[idx + off] and its +x neighbour (masked lanes).
[[gnu::target("avx2")]] inline __m256 lin_pair(const float* data, __m256i idx, int off, __m256i mask, __m256 fx) {
  __m256 a, b;
  gather_pairs(data, _mm256_add_epi32(idx, _mm256_set1_epi32(off)), mask, a, b);
  return _mm256_add_ps(a, _mm256_mul_ps(fx, _mm256_sub_ps(b, a)));
}

// (c - a) + fx * ((e - b) - (c - a)) for a row a, b, c, e along x (GridSampler::gradient's row):
// each tap gathered once.
[[gnu::target("avx2")]] inline __m256 row_diff(__m256 a, __m256 b, __m256 c, __m256 e, __m256 fx) {
  const __m256 ca = _mm256_sub_ps(c, a);
  return _mm256_add_ps(ca, _mm256_mul_ps(fx, _mm256_sub_ps(_mm256_sub_ps(e, b), ca)));
}

// Marches lattice points k..k1-1 (k0: the block's first lattice point, p / dp its local position
// and step). `front` holds the value at `last` (== k - 1 on entry). Returns where it stopped
// (k1, or one past the sample that terminated the ray).
#define STRATA_MARCH8_NAME march8
#define STRATA_MARCH8_ATTRS [[gnu::target("avx2"), gnu::optimize("fp-contract=off")]]
#include "render/march8_body.hpp"
#undef STRATA_MARCH8_NAME
#undef STRATA_MARCH8_ATTRS
#define STRATA_MARCH8_NAME march8_avx512
#define STRATA_MARCH8_ATTRS \
  [[gnu::target("avx2,avx512f,avx512vl,avx512bw,avx512dq"), gnu::optimize("fp-contract=off")]]
#include "render/march8_body.hpp"
#undef STRATA_MARCH8_NAME
#undef STRATA_MARCH8_ATTRS
#endif  // STRATA_RENDER_AVX2

template <class Sampler, bool Preint, bool Shade>
struct Marcher {
  // Classifies the segment from `front` to the sample at (x, y, z), `ratio` steps long
  // (1 inside a block; other values only where a segment meets an entry, exit or level
  // change), shades it and composites it under `acc`. Returns the sample's normalised value.
  [[gnu::always_inline]] static inline float segment(const Sampler& sample, const Block& b, const LevelParams& lp, const MarchParams& mp,
                       const RayContext& ray, float x, float y, float z, float front, double ratio, Rgbaf& acc) {
    const float v = (sample(x, y, z) - mp.value_lo) * mp.value_scale;
    const float lo = Preint ? std::min(front, v) : v, hi = Preint ? std::max(front, v) : v;
    if (mp.next_visible[Transparency::bin(lo)] > Transparency::bin(hi)) return v;
    Rgbaf c = Preint ? lp.classify.pair(front, v) : lp.classify.single(v);
    if (ratio != 1.0) c = rescale_segment(c, ratio);
    if (c.a <= 0.0f) return v;
    if constexpr (Shade) {
      if (c.a > kShadeThreshold) {
        float g[3];
        sample.gradient(x, y, z, g);
        g[0] *= b.gradient_scale[0];
        g[1] *= b.gradient_scale[1];
        g[2] *= b.gradient_scale[2];
        const float len2 = g[0] * g[0] + g[1] * g[1] + g[2] * g[2];
        if (len2 > 1e-12f) {
          // Two-sided Blinn-Phong with a headlight: the half vector equals the light vector.
          const float ndl = std::abs(g[0] * ray.light[0] + g[1] * ray.light[1] + g[2] * ray.light[2]) / std::sqrt(len2);
          const float diffuse = mp.light.ambient + mp.light.diffuse * ndl;
          const float spec = mp.light.specular * detail::specular_power(ndl, mp.light.shininess) * c.a;
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
        front = (sample(e[0], e[1], e[2]) - mp.value_lo) * mp.value_scale;
      }
    } else {
      front = (sample(p[0] - dp[0], p[1] - dp[1], p[2] - dp[2]) - mp.value_lo) * mp.value_scale;
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
      front = segment(sample, b, lp, mp, ray, p[0], p[1], p[2], front, first_ratio, acc);
      ++taken;
      last = k;
      ++k;
    }
    const bool use_skip = skip && b.empty;
    bool vectorised = false;
#if STRATA_RENDER_AVX2
    if constexpr (std::is_same_v<Sampler, GridSampler> && Preint) {
      if (simd_block && k < k1 && acc.a <= mp.termination) {
        k = mp.avx512 ? march8_avx512<Shade>(sample, b, lp, mp, ray, p, dp, k0, k, k1, use_skip, front, last, acc, taken)
                      : march8<Shade>(sample, b, lp, mp, ray, p, dp, k0, k, k1, use_skip, front, last, acc, taken);
        vectorised = true;
      }
    }
#endif
    if (vectorised) {
    } else if (!use_skip) {
      const std::int64_t k_loop = k;
      for (; k < k1 && acc.a <= mp.termination; ++k) {
        const float j = float(k - k0);
        front = segment(sample, b, lp, mp, ray, p[0] + dp[0] * j, p[1] + dp[1] * j, p[2] + dp[2] * j, front, 1.0, acc);
      }
      taken += std::uint64_t(k - k_loop);
      if (k > k_loop) last = k - 1;
    } else {
      for (; k < k1 && acc.a <= mp.termination; ++k) {
        const float j = float(k - k0);
        const float x = p[0] + dp[0] * j, y = p[1] + dp[1] * j, z = p[2] + dp[2] * j;
        if (b.empty_at(x, y, z)) continue;
        if (last != k - 1) {  // resuming after skipped segments: the front sample afresh
          front = (sample(x - dp[0], y - dp[1], z - dp[2]) - mp.value_lo) * mp.value_scale;
          ++taken;
        }
        front = segment(sample, b, lp, mp, ray, x, y, z, front, 1.0, acc);
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
          front = (sample(p[0] + dp[0] * jl, p[1] + dp[1] * jl, p[2] + dp[2] * jl) - mp.value_lo) * mp.value_scale;
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
      front = (sample(p[0], p[1], p[2]) - mp.value_lo) * mp.value_scale;
    }
    local_position(b, ray, t_end, p);
    segment(sample, b, lp, mp, ray, p[0], p[1], p[2], front, ratio, st.acc);
    ++st.samples;
  }
};

struct MarchFns {
  bool (*lattice)(const Block&, std::int64_t, std::int64_t, const RayContext&, const MarchParams&, RayState&, bool);
  void (*tail)(const Block&, double, const RayContext&, const MarchParams&, RayState&);
};

template <class Sampler, bool Preint, bool Shade>
MarchFns fns() {
  return {&Marcher<Sampler, Preint, Shade>::lattice, &Marcher<Sampler, Preint, Shade>::tail};
}

template <bool Preint, bool Shade>
MarchFns pick(bool constant) {
  return constant ? fns<ConstantSampler, Preint, false>() : fns<GridSampler, Preint, Shade>();
}

MarchFns march_function(const Block& b, bool preint, bool shade) {
  const bool constant = b.data == nullptr;
  if (preint) return shade ? pick<true, true>(constant) : pick<true, false>(constant);
  return shade ? pick<false, true>(constant) : pick<false, false>(constant);
}

// ---- Traversal ------------------------------------------------------------------------------

// Parametric exit of the ray from an axis-aligned box it is inside of.
double box_exit(const RayContext& r, const std::array<double, 3>& inv, const std::array<double, 3>& lo,
                const std::array<double, 3>& hi) {
  double t = kInf;
  for (int a = 0; a < 3; ++a) {
    if (r.dir[a] > 0) t = std::min(t, (hi[a] - r.origin[a]) * inv[a]);
    else if (r.dir[a] < 0) t = std::min(t, (lo[a] - r.origin[a]) * inv[a]);
  }
  return t;
}

// [t_enter, t_exit] of the ray inside [0, hi]; empty when enter >= exit.
std::pair<double, double> clip_to_box(const RayContext& r, const std::array<double, 3>& inv,
                                      const std::array<double, 3>& hi) {
  double t0 = 0, t1 = kInf;
  for (int a = 0; a < 3; ++a) {
    if (r.dir[a] == 0) {
      if (r.origin[a] < 0 || r.origin[a] > hi[a]) return {1, 0};
      continue;
    }
    double ta = (0 - r.origin[a]) * inv[a], tb = (hi[a] - r.origin[a]) * inv[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  return {t0, t1};
}

struct Traversal {
  const FrameIndex& index;
  const std::vector<MarchFns>& march;
  const MarchParams& mp;
  double eps;  // parametric nudge past a face, to locate the next cell

  // When the ray leaves a marched block into skipped space, the segment from its last sample
  // to the next lattice point still belongs to the block: it is sampled from the overlap.
  void close(const RayContext& ray, RayState& st) const {
    if (!st.open) return;
    st.open = false;
    const Block& b = *st.last;
    // The block's next lattice point after the previous sample (which may belong to an
    // earlier block of another level when this one was too thin to hold a lattice point).
    const std::int64_t k = st.has_prev && st.prev_level == b.level
                               ? st.prev_k + 1
                               : ifloor(st.prev_t / mp.levels[b.level].h) + 1;
    march[std::size_t(&b - index.blocks.data())].lattice(b, k, k + 1, ray, mp, st, false);
  }

  void block_interval(const Block& b, double t_in, double t_out, const RayContext& ray, RayState& st) const {
    const double h = mp.levels[b.level].h;
    std::int64_t k0 = iceil(t_in / h);
    const std::int64_t k1 = iceil(t_out / h);
    if (st.has_prev) {
      // Never revisit a lattice point a closing segment (or the previous block) already took.
      if (st.prev_level == b.level) k0 = std::max(k0, st.prev_k + 1);
      else k0 = std::max(k0, ifloor(st.prev_t / h) + 1);
    }
    bool closing = true;
    if (k0 < k1) {
      const std::size_t id = std::size_t(&b - index.blocks.data());
      closing = march[id].lattice(b, k0, k1, ray, mp, st, true);
      st.touched[id] = 1;
    }
    st.open = closing;
    st.last = &b;
  }

  void trace(const RayContext& ray, double t, double t_end, RayState& st) const {
    std::array<double, 3> inv{};
    for (int a = 0; a < 3; ++a) inv[a] = ray.dir[a] != 0 ? 1.0 / ray.dir[a] : 0.0;
    const auto& c = index.cells;
    while (t < t_end && st.acc.a <= mp.termination) {
      const double tp = t + eps;
      std::array<std::int64_t, 3> cell{};
      for (int a = 0; a < 3; ++a)
        cell[a] = std::clamp(ifloor((ray.origin[a] + ray.dir[a] * tp) / index.cell_size[a]),
                             std::int64_t(0), c[a] - 1);
      const std::int32_t id = index.block_at(cell[0], cell[1], cell[2]);
      const Block* b = id >= 0 ? &index.blocks[std::size_t(id)] : nullptr;
      double t_next;
      if (b && b->exclusive) {
        t_next = box_exit(ray, inv, b->lo, b->hi);
      } else {
        std::array<double, 3> lo{}, hi{};
        for (int a = 0; a < 3; ++a) {
          lo[a] = double(cell[a]) * index.cell_size[a];
          hi[a] = std::min(lo[a] + index.cell_size[a], index.volume_hi[a]);
        }
        t_next = box_exit(ray, inv, lo, hi);
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
  auto q = [](float v) { return std::uint8_t(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f)); };
  return {q(r * inv), q(g * inv), q(b * inv), q(a)};
}

void validate(const RenderOptions& o) {
  if (!(o.step > 0)) throw Error("render: --step must be positive");
  if (o.table_size < 2 || o.table_size > 4096) throw Error("render: table size must lie in 2..4096");
  if (o.tile < 1) throw Error("render: tile size must be positive");
  if (!(o.termination_alpha > 0 && o.termination_alpha <= 1)) throw Error("render: termination alpha must lie in (0, 1]");
  for (float c : o.background)
    if (!(c >= 0 && c <= 1)) throw Error("render: background components must lie in [0, 1]");
}

}  // namespace

RayCaster::RayCaster(TransferFunction tf, RenderOptions options) : tf_(std::move(tf)), options_(options) {
  validate(options_);
}
RayCaster::~RayCaster() = default;
RayCaster::RayCaster(RayCaster&&) noexcept = default;
RayCaster& RayCaster::operator=(RayCaster&&) noexcept = default;

namespace {

struct RenderJob {
  const TransferFunction& tf;
  const Camera& camera;
  const FrameIndex& index;
  const RenderOptions& options;
  const std::vector<LevelParams>& levels;
  float value_lo, value_scale;
};

Image run(const RenderJob& job, RenderStats& stats) {
  const FrameIndex& index = job.index;
  std::vector<MarchFns> march;
  march.reserve(index.blocks.size());
  for (const Block& b : index.blocks) march.push_back(march_function(b, job.options.preintegrated, job.options.shading));
  const Transparency transparency(job.tf);
  const bool simd = job.options.simd && have_avx2();
  const MarchParams mp{simd, simd && job.options.avx512 && have_avx512(),
                       job.levels.data(), transparency.next_visible.data(), job.value_lo, job.value_scale, job.options.light, job.options.termination_alpha};
  double extent = 0;
  for (double v : index.volume_hi) extent = std::max(extent, v);
  const Traversal trav{index, march, mp, 1e-9 * std::max(extent, 1.0)};

  const Camera& cam = job.camera;
  const int width = cam.width(), height = cam.height();
  Image image(width, height);
  const int tile = job.options.tile;
  const int tiles_x = (width + tile - 1) / tile, tiles_y = (height + tile - 1) / tile;
  const int threads = job.options.threads > 0 ? job.options.threads : thread_count();
  std::uint64_t rays = 0, samples = 0;
  std::vector<std::uint8_t> sampled(index.blocks.size(), 0);
#pragma omp parallel num_threads(threads) reduction(+ : rays, samples)
  {
    std::vector<std::uint8_t> touched(index.blocks.size(), 0);
#pragma omp for schedule(dynamic, 1)
    for (int t = 0; t < tiles_x * tiles_y; ++t) {
      const int x0 = (t % tiles_x) * tile, y0 = (t / tiles_x) * tile;
      for (int py = y0; py < std::min(y0 + tile, height); ++py)
        for (int px = x0; px < std::min(x0 + tile, width); ++px) {
          const Ray r = cam.ray(px, py);
          RayContext ray{{r.origin.x, r.origin.y, r.origin.z},
                         {r.direction.x, r.direction.y, r.direction.z},
                         {float(-r.direction.x), float(-r.direction.y), float(-r.direction.z)}};
          std::array<double, 3> inv{};
          for (int a = 0; a < 3; ++a) inv[a] = ray.dir[a] != 0 ? 1.0 / ray.dir[a] : 0.0;
          const auto [t0, t1] = clip_to_box(ray, inv, index.volume_hi);
          RayState st;
          st.touched = touched.data();
          st.prev_t = t0;  // the volume entry starts the first segment
          if (t0 < t1) {
            ++rays;
            trav.trace(ray, t0, t1, st);
            samples += st.samples;
          }
          image.at(px, py) = to_rgba8(st.acc, job.options.background);
        }
    }
#pragma omp critical
    for (std::size_t i = 0; i < touched.size(); ++i) sampled[i] |= touched[i];
  }
  stats.rays = rays;
  stats.samples = samples;
  stats.bricks_sampled = std::uint64_t(std::count(sampled.begin(), sampled.end(), std::uint8_t(1)));
  return image;
}

// Macro-cell dilation for a step (in local voxels): a segment is at most one step long per axis.
int skip_dilation(const RenderOptions& o) {
  if (!o.skip_cells) return 0;
  const int d = int(std::ceil(o.step - 1e-9));
  return d <= 2 ? std::max(d, 1) : 0;  // longer steps: cells too coarse to be worth it
}

// One flag per macro-cell of a block's samples: set where the (dilated) value range is
// transparent under the TF, i.e. where every segment ending in the cell is transparent.
std::shared_ptr<const CellFlags> cell_flags(const Block& b, int dilation, const Transparency& tr, float value_lo,
                                            float value_scale) {
  const CellRanges r = detail::compute_cell_ranges(b.data, b.n, dilation);
  auto f = std::make_shared<CellFlags>();
  f->cells = r.cells;
  f->empty.resize(r.lo.size() + 3);  // padded for 32-bit gathers (march8)
  for (std::size_t c = 0; c < r.lo.size(); ++c) {
    // Normalised exactly as samples are, widened by a few float roundings of the trilinear
    // interpolation so a sample can never leave the range the flag was decided on.
    const float nlo = (r.lo[c] - value_lo) * value_scale, nhi = (r.hi[c] - value_lo) * value_scale;
    const float margin = 1e-5f + 4e-6f * std::max(std::abs(r.lo[c]), std::abs(r.hi[c])) * value_scale;
    const bool e = tr.next_visible[std::size_t(Transparency::bin(nlo - margin))] > Transparency::bin(nhi + margin);
    f->empty[c] = e ? 1 : 0;
    f->empty_count += e ? 1 : 0;
  }
  return f;
}

void attach_flags(Block& b, const std::shared_ptr<const CellFlags>& f, RenderStats& stats) {
  if (!f) return;
  stats.cells_total += std::uint64_t(f->cells[0]) * std::uint64_t(f->cells[1]) * std::uint64_t(f->cells[2]);
  stats.cells_empty += f->empty_count;
  b.cells = f->cells;
  b.empty = f->empty_count > 0 ? f->empty.data() : nullptr;
}

}  // namespace

Image RayCaster::render(const Camera& camera, const FrameInput& frame, RenderStats* stats) {
  const auto t0 = Clock::now();
  FrameIndex index = detail::build_frame_index(frame, tf_);
  RenderStats local;
  local.bricks_in_frame = index.blocks.size();
  for (const Block& b : index.blocks) local.bricks_culled += b.culled ? 1 : 0;
  const ValueMapping mapping = tf_.mapping(frame.value_min, frame.value_max);
  std::vector<std::shared_ptr<const CellFlags>> flags;  // kept alive for the frame
  if (const int dilation = skip_dilation(options_)) {
    // Macro-cell flags of the visible bricks: memoised per brick, computed in parallel when new.
    if (!cell_flags_) cell_flags_ = std::make_unique<detail::CellFlagCache>();
    detail::CellFlagCache& cache = *cell_flags_;
    cache.sweep();
    const std::array<double, 3> key{double(float(mapping.lo)), double(float(mapping.scale())), double(dilation)};
    if (cache.key != key) {
      cache.clear();
      cache.key = key;
    }
    const auto& bricks = frame.bricks->bricks;
    flags.resize(bricks.size());
    std::vector<std::size_t> missing;
    for (std::size_t i = 0; i < bricks.size(); ++i) {
      if (index.blocks[i].culled || bricks[i].is_constant()) continue;
      flags[i] = cache.find(bricks[i].samples);
      if (!flags[i]) missing.push_back(i);
    }
    const Transparency tr(tf_);
    const std::int64_t n_missing = std::int64_t(missing.size());
    const int threads = options_.threads > 0 ? options_.threads : thread_count();
#pragma omp parallel for schedule(dynamic, 4) num_threads(threads)
    for (std::int64_t m = 0; m < n_missing; ++m) {
      const std::size_t i = missing[std::size_t(m)];
      flags[i] = cell_flags(index.blocks[i], dilation, tr, float(mapping.lo), float(mapping.scale()));
    }
    for (std::size_t i : missing) cache.insert(bricks[i].samples, flags[i]);
    local.cell_ranges_built = missing.size();
    for (std::size_t i = 0; i < bricks.size(); ++i) attach_flags(index.blocks[i], flags[i], local);
  }
  Image image;
  {
    std::vector<LevelParams> levels(std::size_t(index.max_level) + 1);
    for (int l = 0; l <= index.max_level; ++l) {
      if (std::size_t(l) >= tables_.size()) tables_.resize(std::size_t(l) + 1);
      const double ratio = options_.step * std::ldexp(1.0, l);
      if (!tables_[std::size_t(l)]) {
        auto t = std::make_unique<Tables>();
        if (options_.preintegrated) t->preintegrated = tf_.preintegrated_table(options_.table_size, ratio);
        else t->lookup = tf_.lookup_table(16 * options_.table_size, ratio);
        tables_[std::size_t(l)] = std::move(t);
      }
      const Tables& t = *tables_[std::size_t(l)];
      levels[std::size_t(l)].h = ratio * index.min_spacing;
      levels[std::size_t(l)].classify = options_.preintegrated
                                            ? Classifier{t.preintegrated.entries.data(), t.preintegrated.size,
                                                         float(t.preintegrated.size - 1)}
                                            : Classifier{t.lookup.entries.data(), t.lookup.size, float(t.lookup.size - 1)};
    }
    const ValueMapping& m = mapping;
    local.setup_ms = ms_since(t0);
    const auto t1 = Clock::now();
    image = run({tf_, camera, index, options_, levels, float(m.lo), float(m.scale())}, local);
    local.raycast_ms = ms_since(t1);
  }
  local.total_ms = ms_since(t0);
  if (stats) *stats = local;
  return image;
}

Image RayCaster::render(const Camera& camera, const Volume& volume, double value_min, double value_max,
                        RenderStats* stats) {
  // The same traversal over a one-cell index: an empty brick list, the volume as block 0.
  const auto t0 = Clock::now();
  FrameIndex index = detail::build_volume_index(volume, tf_, value_min, value_max);
  const ValueMapping m = tf_.mapping(value_min, value_max);
  RenderStats local;
  std::shared_ptr<const CellFlags> flags;
  if (const int dilation = skip_dilation(options_); dilation && !index.blocks[0].culled) {
    flags = cell_flags(index.blocks[0], dilation, Transparency(tf_), float(m.lo), float(m.scale()));
    local.cell_ranges_built = 1;
    attach_flags(index.blocks[0], flags, local);
  }
  if (tables_.empty()) tables_.resize(1);
  if (!tables_[0]) {
    auto t = std::make_unique<Tables>();
    if (options_.preintegrated) t->preintegrated = tf_.preintegrated_table(options_.table_size, options_.step);
    else t->lookup = tf_.lookup_table(16 * options_.table_size, options_.step);
    tables_[0] = std::move(t);
  }
  const Tables& t = *tables_[0];
  std::vector<LevelParams> levels(1);
  levels[0].h = options_.step * index.min_spacing;
  levels[0].classify = options_.preintegrated
                           ? Classifier{t.preintegrated.entries.data(), t.preintegrated.size, float(t.preintegrated.size - 1)}
                           : Classifier{t.lookup.entries.data(), t.lookup.size, float(t.lookup.size - 1)};
  local.bricks_in_frame = 1;
  local.bricks_culled = index.blocks[0].culled ? 1 : 0;
  local.setup_ms = ms_since(t0);
  const auto t1 = Clock::now();
  Image image = run({tf_, camera, index, options_, levels, float(m.lo), float(m.scale())}, local);
  local.raycast_ms = ms_since(t1);
  local.total_ms = ms_since(t0);
  if (stats) *stats = local;
  return image;
}

nlohmann::json stats_json(const RenderStats& s, const lod::LoadStats* load) {
  nlohmann::json j;
  j["render"] = {{"rays", s.rays},
                 {"samples", s.samples},
                 {"bricks_in_frame", s.bricks_in_frame},
                 {"bricks_culled", s.bricks_culled},
                 {"bricks_sampled", s.bricks_sampled},
                 {"cells_empty", s.cells_empty},
                 {"cells_total", s.cells_total},
                 {"cell_ranges_built", s.cell_ranges_built},
                 {"setup_ms", s.setup_ms},
                 {"raycast_ms", s.raycast_ms},
                 {"total_ms", s.total_ms}};
  if (load)
    j["load"] = {{"selected", load->selected},     {"resident", load->resident},
                 {"cache_hits", load->cache_hits}, {"cache_misses", load->cache_misses},
                 {"bytes_read", load->bytes_read}, {"decode_ms", load->decode_ms},
                 {"pending", load->pending}};
  return j;
}

}  // namespace strata::render
