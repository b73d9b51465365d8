#include "strata/core/isa.hpp"
#include "strata/core/stopwatch.hpp"
#include "strata/render/raycaster.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define STRATA_RENDER_AVX2 1
#else
#define STRATA_RENDER_AVX2 0
#endif
#include <type_traits>
#include <limits>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "render/frame_index.hpp"
#include "render/ray_sampling.hpp"
#include "render/ray_traversal.hpp"
#include "render/shading.hpp"
#include "strata/core/error.hpp"
#include "strata/core/threads.hpp"

namespace strata::render {

using detail::Block;
using detail::CellFlags;
using detail::CellRanges;
using detail::Classifier;
using detail::ConstantSampler;
using detail::FrameIndex;
using detail::GridSampler;
using detail::LevelParams;
using detail::MarchFns;
using detail::MarchParams;
using detail::normalised_sample;
using detail::RayContext;
using detail::RayState;
using detail::rescale_segment;
using detail::run;
using detail::Transparency;

// Classification tables of one level: the step ratio h_l / reference differs per level.
struct detail::LevelTables {
  std::vector<float> cells;  // the pre-integrated table as bilinear cells (Classifier::cells)
  LookupTable lookup;
};

namespace {

// Samples below this opacity skip the gradient (six extra trilinear taps).
constexpr float kShadeThreshold = 1.0f / 1024.0f;
// 8-lane march with empty-space skipping: a chunk whose first kRealign or more points lie in
// empty cells restarts at its first point that does not (the skipped segments are transparent,
// its front value is sampled afresh, as after a skipped chunk), so fewer lanes idle.
constexpr int kRealign = 2;

// Straight-line local position of ray parameter t in block b.
inline void local_position(const Block& b, const RayContext& ray, double t, float p[3]) {
  for (int a = 0; a < 3; ++a) p[a] = float((ray.origin[a] + ray.dir[a] * t) * b.scale[a] + b.offset[a]);
}

}  // namespace

// ---- AVX2 path ---------------------------------------------------------------------------------
// Eight consecutive lattice points of one block at a time (trilinear taps, transparency bins and
// table indices by 8-wide gathers), composited in order per lane. The arithmetic is the scalar
// path's, operation for operation and without FMA, so both give the same image; compiled for
// AVX2 and used when active_isa() allows it (the default build stays portable x86-64). The loop's
// source (march8_body.hpp) is compiled twice: for AVX2 and for AVX-512 (EVEX, 32 registers),
// both with fp-contract=off, since GCC would otherwise fuse multiplies and adds into FMA there.

namespace {

#if STRATA_RENDER_AVX2

// a[l] = data[idx[l]], b[l] = data[idx[l] + 1] for 8 lanes: two 4-lane gathers of float pairs
// (half the gathered elements of two 8-lane float gathers), deinterleaved. Lanes outside
// `mask` (all bits set or clear per lane) load nothing and hold zeros.
STRATA_TARGET_AVX2 inline void gather_pairs(const float* data, __m256i idx, __m256i mask, __m256& a, __m256& b) {
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
STRATA_TARGET_AVX2 inline __m256 lin_pair(const float* data, __m256i idx, int off, __m256i mask, __m256 fx) {
  __m256 a, b;
  gather_pairs(data, _mm256_add_epi32(idx, _mm256_set1_epi32(off)), mask, a, b);
  return _mm256_add_ps(a, _mm256_mul_ps(fx, _mm256_sub_ps(b, a)));
}

// (c - a) + fx * ((e - b) - (c - a)) for a row a, b, c, e along x (GridSampler::gradient's row):
// each tap gathered once.
STRATA_TARGET_AVX2 inline __m256 row_diff(__m256 a, __m256 b, __m256 c, __m256 e, __m256 fx) {
  const __m256 ca = _mm256_sub_ps(c, a);
  return _mm256_add_ps(ca, _mm256_mul_ps(fx, _mm256_sub_ps(_mm256_sub_ps(e, b), ca)));
}

// Four-channel colours of 8 lanes (one SSE vector each) as one 8-lane vector per channel.
STRATA_TARGET_AVX2 inline void transpose_rgba(const __m128 c[8], __m256& r, __m256& g, __m256& b, __m256& a) {
  const __m256 t0 = _mm256_insertf128_ps(_mm256_castps128_ps256(c[0]), c[4], 1);
  const __m256 t1 = _mm256_insertf128_ps(_mm256_castps128_ps256(c[1]), c[5], 1);
  const __m256 t2 = _mm256_insertf128_ps(_mm256_castps128_ps256(c[2]), c[6], 1);
  const __m256 t3 = _mm256_insertf128_ps(_mm256_castps128_ps256(c[3]), c[7], 1);
  const __m256 rg01 = _mm256_unpacklo_ps(t0, t1), ba01 = _mm256_unpackhi_ps(t0, t1);  // r0 r1 g0 g1 | r4 r5 g4 g5
  const __m256 rg23 = _mm256_unpacklo_ps(t2, t3), ba23 = _mm256_unpackhi_ps(t2, t3);
  r = _mm256_shuffle_ps(rg01, rg23, 0x44);
  g = _mm256_shuffle_ps(rg01, rg23, 0xEE);
  b = _mm256_shuffle_ps(ba01, ba23, 0x44);
  a = _mm256_shuffle_ps(ba01, ba23, 0xEE);
}

// x shifted up by `Lanes` lanes, ones shifted in at the bottom.
template <int Lanes>
STRATA_TARGET_AVX2 inline __m256 shift_up_ones(__m256 x) {
  static_assert(Lanes == 1 || Lanes == 2 || Lanes == 4);
  const __m256i from = _mm256_setr_epi32(0 - Lanes, 1 - Lanes, 2 - Lanes, 3 - Lanes, 4 - Lanes, 5 - Lanes, 6 - Lanes, 7 - Lanes);
  const __m256 moved = _mm256_permutevar8x32_ps(x, _mm256_max_epi32(from, _mm256_setzero_si256()));
  return _mm256_blend_ps(moved, _mm256_set1_ps(1.0f), (1 << Lanes) - 1);
}

// Exclusive prefix product of the 8 lanes (lane 0: 1), by three doubling steps.
STRATA_TARGET_AVX2 inline __m256 exclusive_transmittance(__m256 keep) {
  __m256 p = _mm256_mul_ps(keep, shift_up_ones<1>(keep));
  p = _mm256_mul_ps(p, shift_up_ones<2>(p));
  p = _mm256_mul_ps(p, shift_up_ones<4>(p));
  return shift_up_ones<1>(p);
}

// acc + (1 - acc.a) * sum over lanes of through * (r, g, b, a): 8 premultiplied segments
// composited under `acc`, each weighted by the transmittance in front of it.
STRATA_TARGET_AVX2 inline __m128 composite_chunk(__m128 acc, __m256 r, __m256 g, __m256 b, __m256 a, __m256 through) {
  const __m256 rg = _mm256_hadd_ps(_mm256_mul_ps(through, r), _mm256_mul_ps(through, g));
  const __m256 ba = _mm256_hadd_ps(_mm256_mul_ps(through, b), _mm256_mul_ps(through, a));
  const __m256 rgba = _mm256_hadd_ps(rg, ba);  // r0123 g0123 b0123 a0123 | r4567 ...
  const __m128 sum = _mm_add_ps(_mm256_castps256_ps128(rgba), _mm256_extractf128_ps(rgba, 1));
  const __m128 w = _mm_sub_ps(_mm_set1_ps(1.0f), _mm_shuffle_ps(acc, acc, 0xff));
  return _mm_add_ps(acc, _mm_mul_ps(w, sum));
}

// Marches lattice points k..k1-1 (k0: the block's first lattice point, p / dp its local position
// and step). `front` holds the value at `last` (== k - 1 on entry). Returns where it stopped
// (k1, or one past the sample that terminated the ray).
#define STRATA_MARCH8_NAME march8
#define STRATA_MARCH8_ATTRS [[gnu::optimize("fp-contract=off")]] STRATA_TARGET_AVX2
#include "render/march8_body.hpp"
#undef STRATA_MARCH8_NAME
#undef STRATA_MARCH8_ATTRS
#define STRATA_MARCH8_NAME march8_avx512
#define STRATA_MARCH8_ATTRS [[gnu::optimize("fp-contract=off")]] STRATA_TARGET_AVX512
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
    const float v = normalised_sample(sample, x, y, z, mp.value_lo, mp.value_scale);
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
    if (!vectorised && !use_skip) {
      const std::int64_t k_loop = k;
      for (; k < k1 && acc.a <= mp.termination; ++k) {
        const float j = float(k - k0);
        front = segment(sample, b, lp, mp, ray, p[0] + dp[0] * j, p[1] + dp[1] * j, p[2] + dp[2] * j, front, 1.0, acc);
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
    segment(sample, b, lp, mp, ray, p[0], p[1], p[2], front, ratio, st.acc);
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

MarchFns detail::march_function(const Block& b, bool preint, bool shade) {
  const bool constant = b.data == nullptr;
  if (preint) return shade ? pick<true, true>(constant) : pick<true, false>(constant);
  return shade ? pick<false, true>(constant) : pick<false, false>(constant);
}

namespace {

void validate(const RenderOptions& o) {
  if (!(o.step > 0)) throw ParameterError("RenderOptions::step", fmt::format("must be positive, got {}", o.step));
  if (o.table_size < 2 || o.table_size > 4096)
    throw ParameterError("RenderOptions::table_size", "must lie in 2..4096, got " + std::to_string(o.table_size));
  if (o.tile < 1) throw ParameterError("RenderOptions::tile", "must be positive, got " + std::to_string(o.tile));
  if (!(o.termination_alpha > 0 && o.termination_alpha <= 1))
    throw ParameterError("RenderOptions::termination_alpha",
                         fmt::format("must lie in (0, 1], got {}", o.termination_alpha));
  for (float c : o.background)
    if (!(c >= 0 && c <= 1))
      throw ParameterError("RenderOptions::background", fmt::format("components must lie in [0, 1], got {}", c));
}

// Tells PreparedVolume which caster's empty-space cells it holds.
std::atomic<std::uint64_t> next_caster_id{0};

}  // namespace

RayCaster::RayCaster(TransferFunction tf, RenderOptions options)
    : tf_(std::move(tf)),
      options_(options),
      transparency_(std::make_unique<const Transparency>(tf_)),
      id_(next_caster_id.fetch_add(1)) {
  validate(options_);
}
RayCaster::~RayCaster() = default;
RayCaster::RayCaster(RayCaster&&) noexcept = default;
RayCaster& RayCaster::operator=(RayCaster&&) noexcept = default;

namespace {

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

// The pre-integrated table regrouped into bilinear cells (Classifier::cells).
std::vector<float> bilinear_cells(const PreintegratedTable& t) {
  const std::size_t n = std::size_t(t.size), m = n - 1;
  std::vector<float> cells(m * m * 16);
  for (std::size_t i = 0; i < m; ++i)
    for (std::size_t j = 0; j < m; ++j) {
      float* c = cells.data() + (i * m + j) * 16;
      const Rgbaf* corners[4] = {&t.entries[i * n + j], &t.entries[(i + 1) * n + j], &t.entries[i * n + j + 1],
                                 &t.entries[(i + 1) * n + j + 1]};
      for (int q = 0; q < 4; ++q) {
        c[4 * q + 0] = corners[q]->r;
        c[4 * q + 1] = corners[q]->g;
        c[4 * q + 2] = corners[q]->b;
        c[4 * q + 3] = corners[q]->a;
      }
    }
  return cells;
}

// Levels 0..max_level: world step and classification tables (built into `tables` on first
// use; the step ratio, and so the table, differs per level).
std::vector<LevelParams> level_params(std::vector<std::unique_ptr<detail::LevelTables>>& tables,
                                      const TransferFunction& tf, const RenderOptions& options, int max_level,
                                      double min_spacing) {
  std::vector<LevelParams> levels(std::size_t(max_level) + 1);
  if (tables.size() < levels.size()) tables.resize(levels.size());
  for (std::size_t l = 0; l < levels.size(); ++l) {
    const double ratio = options.step * std::ldexp(1.0, int(l));
    if (!tables[l]) {
      auto t = std::make_unique<detail::LevelTables>();
      if (options.preintegrated) {
        t->cells = bilinear_cells(tf.preintegrated_table(options.table_size, ratio));
      } else {
        t->lookup = tf.lookup_table(16 * options.table_size, ratio);
      }
      tables[l] = std::move(t);
    }
    const detail::LevelTables& t = *tables[l];
    levels[l].h = ratio * min_spacing;
    // The pre-integrated table is options.table_size^2 entries (read through its cells only).
    levels[l].classify = options.preintegrated
                             ? Classifier{nullptr, options.table_size, float(options.table_size - 1), t.cells.data()}
                             : Classifier{t.lookup.entries.data(), t.lookup.size, float(t.lookup.size - 1)};
  }
  return levels;
}

}  // namespace

Image RayCaster::render(const Camera& camera, const FrameInput& frame, RenderStats* stats) {
  const auto t0 = SteadyClock::now();
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
    const std::array<double, 2> key{double(float(mapping.lo)), double(float(mapping.scale()))};
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
    const std::int64_t n_missing = std::int64_t(missing.size());
    const int threads = options_.threads > 0 ? options_.threads : thread_count();
#pragma omp parallel for schedule(dynamic, 4) num_threads(threads)
    for (std::int64_t m = 0; m < n_missing; ++m) {
      const std::size_t i = missing[std::size_t(m)];
      flags[i] = cell_flags(index.blocks[i], dilation, *transparency_, float(mapping.lo), float(mapping.scale()));
    }
    for (std::size_t i : missing) cache.insert(bricks[i].samples, flags[i]);
    local.cell_ranges_built = missing.size();
    for (std::size_t i = 0; i < bricks.size(); ++i) attach_flags(index.blocks[i], flags[i], local);
  }
  return cast(camera, index, mapping, t0, local, stats);
}

Image RayCaster::cast(const Camera& camera, const FrameIndex& index, const ValueMapping& mapping,
                      SteadyClock::time_point t0, RenderStats& local, RenderStats* stats) {
  const std::vector<LevelParams> levels = level_params(tables_, tf_, options_, index.max_level, index.min_spacing);
  local.setup_ms = ms_since(t0);
  const auto t1 = SteadyClock::now();
  Image image = run({*transparency_, camera, index, options_, levels, float(mapping.lo), float(mapping.scale())}, local);
  local.raycast_ms = ms_since(t1);
  local.total_ms = ms_since(t0);
  if (stats) *stats = local;
  return image;
}

PreparedVolume::PreparedVolume(const Volume& volume, double value_min, double value_max)
    : index_(std::make_unique<FrameIndex>(detail::build_volume_index(volume))),
      value_min_(value_min),
      value_max_(value_max) {}
PreparedVolume::PreparedVolume(const Volume& volume)
    : index_(std::make_unique<FrameIndex>(detail::build_volume_index(volume))),
      value_min_(index_->blocks[0].value_lo),
      value_max_(index_->blocks[0].value_hi) {}
PreparedVolume::~PreparedVolume() = default;
PreparedVolume::PreparedVolume(PreparedVolume&&) noexcept = default;
PreparedVolume& PreparedVolume::operator=(PreparedVolume&&) noexcept = default;

Image RayCaster::render(const Camera& camera, const Volume& volume, double value_min, double value_max,
                        RenderStats* stats) {
  const auto t0 = SteadyClock::now();
  PreparedVolume prepared(volume, value_min, value_max);
  const double prepare_ms = ms_since(t0);
  Image image = render(camera, prepared, stats);
  if (stats) {
    stats->setup_ms += prepare_ms;
    stats->total_ms += prepare_ms;
  }
  return image;
}

Image RayCaster::render(const Camera& camera, PreparedVolume& volume, RenderStats* stats) {
  // The same traversal over a one-cell index: an empty brick list, the volume as block 0.
  const auto t0 = SteadyClock::now();
  FrameIndex& index = *volume.index_;
  detail::cull_blocks(index, tf_, volume.value_min_, volume.value_max_);
  const ValueMapping m = tf_.mapping(volume.value_min_, volume.value_max_);
  RenderStats local;
  Block& block = index.blocks[0];
  block.empty = nullptr;
  if (const int dilation = skip_dilation(options_); dilation && !block.culled) {
    if (!volume.flags_ || volume.flags_owner_ != id_) {
      volume.flags_ = cell_flags(block, dilation, *transparency_, float(m.lo), float(m.scale()));
      volume.flags_owner_ = id_;
      local.cell_ranges_built = 1;
    }
    attach_flags(block, volume.flags_, local);
  }
  local.bricks_in_frame = 1;
  local.bricks_culled = block.culled ? 1 : 0;
  return cast(camera, index, m, t0, local, stats);
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
