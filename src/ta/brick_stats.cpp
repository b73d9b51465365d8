#include "ta/brick_stats.hpp"

#include <algorithm>
#include <limits>

// GCC 12 reports the _mm512_undefined_* pass-through operands inside the AVX-512 intrinsics as
// maybe-uninitialized (a false positive, fixed in later releases). The warning is located in
// the intrinsics header, so the suppression covers that header only.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <immintrin.h>
#pragma GCC diagnostic pop

#include "strata/core/isa.hpp"
#include "strata/store/brick_histogram.hpp"

namespace strata::ta {
namespace {

using BinScale = store::HistogramBinning;  // the format's bin rule, shared with the readers

// Min, max and the 64-bin occupancy bits (bit i set when some value falls into bin i of 64 equal
// bins over [lo, hi]) of a brick's samples and decoded values: two passes over 32K floats per
// brick, so they are vectorised and compiled per ISA like the tensor kernels. The bin of v is
// trunc((double(v) - lo) * scale) clamped to [0, 63]: clamping the double before the conversion
// gives the same bin for every finite value and maps NaN to bin 0, as the scalar code does.

// Scalar reference and tail.
inline void accumulate_scalar(const float* v, std::size_t n, const BinScale& s, BrickStats& st) {
  for (std::size_t i = 0; i < n; ++i) {
    st.lo = std::min(st.lo, v[i]);
    st.hi = std::max(st.hi, v[i]);
    st.bits |= std::uint64_t(1) << s.bin(double(v[i]));
  }
}

// Vector types of VW lanes (a dependent typedef inside a template drops vector_size).
template <class T, int VW>
struct VecOf {
  typedef T type __attribute__((vector_size(VW * sizeof(T))));
};

// VW values per step: floats in one vector, their doubles and 64-bit bin masks in another.
template <int VW>
[[gnu::always_inline]] inline void accumulate_vector(const float* v, std::size_t n, const BinScale& s,
                                                     BrickStats& st) {
  using VF = typename VecOf<float, VW>::type;
  using VD = typename VecOf<double, VW>::type;
  using VI = typename VecOf<std::int32_t, VW>::type;
  using VL = typename VecOf<std::int64_t, VW>::type;
  if (n < VW) return accumulate_scalar(v, n, s, st);
  // Lanes start empty (+inf, -inf) and `f < vmin ? f : vmin` keeps vmin for a NaN f, so a
  // NaN never enters a lane and never hides the lane's other values.
  VF vmin = VF{} + std::numeric_limits<float>::infinity(), vmax = -vmin;
  VL bits{};
  const VL one = VL{} + 1;
  const VD zero{}, top = VD{} + double(store::kHistogramBins - 1);  // s.bin(), lane by lane
  std::size_t i = 0;
  for (; i + VW <= n; i += VW) {
    VF f;
    __builtin_memcpy(&f, v + i, sizeof(VF));
    vmin = f < vmin ? f : vmin;
    vmax = f > vmax ? f : vmax;
    VD x = (__builtin_convertvector(f, VD) - s.lo) * s.scale;
    x = x >= zero ? x : zero;  // also NaN -> 0
    x = x < top ? x : top;
    bits |= one << __builtin_convertvector(__builtin_convertvector(x, VI), VL);
  }
  for (int l = 0; l < VW; ++l) {
    st.lo = std::min(st.lo, vmin[l]);
    st.hi = std::max(st.hi, vmax[l]);
    st.bits |= std::uint64_t(bits[l]);
  }
  accumulate_scalar(v + i, n - i, s, st);
}

void stats_generic(const float* v, std::size_t n, const BinScale& s, BrickStats& st) {
  accumulate_scalar(v, n, s, st);
}
STRATA_TARGET_AVX2 void stats_avx2(const float* v, std::size_t n, const BinScale& s,
                                                     BrickStats& st) {
  accumulate_vector<4>(v, n, s, st);
}
// AVX-512 with intrinsics: GCC splits the generic float-to-double conversion into halves.
// The bits of the bins of 8 values; max(x, 0) returns 0 for NaN (its second operand), then
// min(., 63) leaves a bin index in [0, 63].
[[gnu::always_inline]] STRATA_TARGET_AVX512 inline __m512i bin_bits_avx512(
    __m256 f, __m512d lo, __m512d scale) {
  __m512d x = _mm512_mul_pd(_mm512_sub_pd(_mm512_cvtps_pd(f), lo), scale);
  x = _mm512_min_pd(_mm512_max_pd(x, _mm512_setzero_pd()), _mm512_set1_pd(63.0));
  return _mm512_sllv_epi64(_mm512_set1_epi64(1), _mm512_cvtepi32_epi64(_mm512_cvttpd_epi32(x)));
}

STRATA_TARGET_AVX512 void stats_avx512(const float* v, std::size_t n, const BinScale& s, BrickStats& st) {
  if (n < 16) return accumulate_scalar(v, n, s, st);
  const __m512d lo = _mm512_set1_pd(s.lo), scale = _mm512_set1_pd(s.scale);
  __m512i bits0 = _mm512_setzero_si512(), bits1 = _mm512_setzero_si512();
  // min_ps(a, b) returns b when either is NaN: the lane's running value stays (as above).
  constexpr float kInf = std::numeric_limits<float>::infinity();
  __m512 vmin = _mm512_set1_ps(kInf), vmax = _mm512_set1_ps(-kInf);
  std::size_t i = 0;
  for (; i + 16 <= n; i += 16) {
    const __m512 f = _mm512_loadu_ps(v + i);
    vmin = _mm512_min_ps(f, vmin);
    vmax = _mm512_max_ps(f, vmax);
    bits0 = _mm512_or_si512(bits0, bin_bits_avx512(_mm256_loadu_ps(v + i), lo, scale));
    bits1 = _mm512_or_si512(bits1, bin_bits_avx512(_mm256_loadu_ps(v + i + 8), lo, scale));
  }
  float lanes_min[16], lanes_max[16];
  std::uint64_t lanes_bits[8];
  _mm512_storeu_ps(lanes_min, vmin);
  _mm512_storeu_ps(lanes_max, vmax);
  _mm512_storeu_si512(lanes_bits, _mm512_or_si512(bits0, bits1));
  for (int l = 0; l < 16; ++l) {
    st.lo = std::min(st.lo, lanes_min[l]);
    st.hi = std::max(st.hi, lanes_max[l]);
  }
  for (int l = 0; l < 8; ++l) st.bits |= lanes_bits[l];
  accumulate_scalar(v + i, n - i, s, st);
}

using StatsFn = void (*)(const float*, std::size_t, const BinScale&, BrickStats&);

// The widest variant active_isa() allows.
StatsFn stats_kernel() {
  switch (active_isa()) {
    case Isa::avx512: return stats_avx512;
    case Isa::avx2: return stats_avx2;
    default: return stats_generic;
  }
}

}  // namespace

BrickStats brick_stats(std::span<const float> a, std::span<const float> b, const HistogramRange& range) {
  const BinScale s(range.lo, range.hi);
  // NaN samples are ignored by min and max (std::min keeps its first argument against NaN) and
  // fall into bin 0; a brick of NaN only reports NaN for both.
  constexpr float kInf = std::numeric_limits<float>::infinity();
  BrickStats st{kInf, -kInf, 0};
  const StatsFn fn = stats_kernel();
  fn(a.data(), a.size(), s, st);
  fn(b.data(), b.size(), s, st);
  if (st.lo > st.hi) st.lo = st.hi = std::numeric_limits<float>::quiet_NaN();
  return st;
}

}  // namespace strata::ta
