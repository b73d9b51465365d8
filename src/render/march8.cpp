// The ray caster's 8-lane march (declared in march8.hpp): the AVX2 intrinsics helpers it uses,
// and its loop (march8_body.hpp) compiled once for AVX2 and once for AVX-512, each instantiated
// with and without shading for the scalar march (march.cpp) to hand over to.
#include "render/march8.hpp"

#include <algorithm>
#include <cstddef>
#include <cstdint>
#if STRATA_X86_64
#include <immintrin.h>
#endif

#include "render/shading.hpp"

namespace strata::render::detail {

// ---- AVX2 path ---------------------------------------------------------------------------------
// Eight consecutive lattice points of one block at a time (trilinear taps, transparency bins and
// table indices by 8-wide gathers), composited in order per lane. The arithmetic is the scalar
// path's, operation for operation and without FMA, so both give the same image; compiled for
// AVX2 and used when active_isa() allows it (the default build stays portable x86-64). The loop's
// source (march8_body.hpp) is compiled twice: for AVX2 and for AVX-512 (EVEX, 32 registers),
// both with fp-contract=off, since GCC would otherwise fuse multiplies and adds into FMA there.

#if STRATA_X86_64

namespace {

// 8-lane march with empty-space skipping: a chunk whose first kRealign or more points lie in
// empty cells restarts at its first point that does not (the skipped segments are transparent,
// its front value is sampled afresh, as after a skipped chunk), so fewer lanes idle.
constexpr int kRealign = 2;

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

// The trilinear values at 8 positions, clamped to the grid as GridSampler::operator() clamps
// them, then normalised ((value - vlo) * vscale, as normalised_sample).
STRATA_TARGET_AVX2 inline __m256 trilinear8(const GridSampler& s, __m256 x, __m256 y, __m256 z, __m256 vlo, __m256 vscale) {
  const __m256 zero = _mm256_setzero_ps();
  x = _mm256_min_ps(_mm256_max_ps(x, zero), _mm256_set1_ps(s.max_x));
  y = _mm256_min_ps(_mm256_max_ps(y, zero), _mm256_set1_ps(s.max_y));
  z = _mm256_min_ps(_mm256_max_ps(z, zero), _mm256_set1_ps(s.max_z));
  const __m256i ix = _mm256_cvttps_epi32(x), iy = _mm256_cvttps_epi32(y), iz = _mm256_cvttps_epi32(z);
  const __m256 fx = _mm256_sub_ps(x, _mm256_cvtepi32_ps(ix)), fy = _mm256_sub_ps(y, _mm256_cvtepi32_ps(iy)),
               fz = _mm256_sub_ps(z, _mm256_cvtepi32_ps(iz));
  const int ox = int(s.dx), oy = int(s.dy), oz = int(s.dz);
  const __m256i base = _mm256_add_epi32(_mm256_add_epi32(_mm256_mullo_epi32(ix, _mm256_set1_epi32(ox)),
                                                         _mm256_mullo_epi32(iy, _mm256_set1_epi32(oy))),
                                        _mm256_mullo_epi32(iz, _mm256_set1_epi32(oz)));
#define STRATA_TAP(off) _mm256_i32gather_ps(s.data, _mm256_add_epi32(base, _mm256_set1_epi32(off)), 4)
#define STRATA_LERP(a, b, w) _mm256_add_ps((a), _mm256_mul_ps((w), _mm256_sub_ps((b), (a))))
  __m256 p000, p100, p010, p110, p001, p101, p011, p111;
  if (ox == 1) {  // x neighbours adjacent: pairs
    const __m256i all = _mm256_set1_epi32(-1);
    gather_pairs(s.data, base, all, p000, p100);
    gather_pairs(s.data, _mm256_add_epi32(base, _mm256_set1_epi32(oy)), all, p010, p110);
    gather_pairs(s.data, _mm256_add_epi32(base, _mm256_set1_epi32(oz)), all, p001, p101);
    gather_pairs(s.data, _mm256_add_epi32(base, _mm256_set1_epi32(oy + oz)), all, p011, p111);
  } else {
    p000 = STRATA_TAP(0), p100 = STRATA_TAP(ox), p010 = STRATA_TAP(oy), p110 = STRATA_TAP(oy + ox);
    p001 = STRATA_TAP(oz), p101 = STRATA_TAP(oz + ox), p011 = STRATA_TAP(oz + oy), p111 = STRATA_TAP(oz + oy + ox);
  }
  const __m256 c00 = STRATA_LERP(p000, p100, fx), c10 = STRATA_LERP(p010, p110, fx);
  const __m256 c01 = STRATA_LERP(p001, p101, fx), c11 = STRATA_LERP(p011, p111, fx);
  const __m256 c0 = STRATA_LERP(c00, c10, fy), c1 = STRATA_LERP(c01, c11, fy);
  return _mm256_mul_ps(_mm256_sub_ps(STRATA_LERP(c0, c1, fz), vlo), vscale);
#undef STRATA_TAP
#undef STRATA_LERP
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

// Classifier::pair for 8 segments from `fr` to `bk`: table coordinates, then per lane the
// bilinear cell read with two 8-float loads, transposed to one vector per channel.
STRATA_TARGET_AVX2 inline void classify8(const Classifier& cl, __m256 fr, __m256 bk, __m256& r, __m256& g, __m256& b,
                                         __m256& a) {
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f), last = _mm256_set1_ps(cl.last);
  const __m256i size2 = _mm256_set1_epi32(cl.size - 2), cells = _mm256_set1_epi32(cl.size - 1);
  const __m256 u = _mm256_mul_ps(_mm256_min_ps(_mm256_max_ps(fr, zero), one), last);
  const __m256 w = _mm256_mul_ps(_mm256_min_ps(_mm256_max_ps(bk, zero), one), last);
  const __m256i ti = _mm256_min_epi32(_mm256_cvttps_epi32(u), size2), tj = _mm256_min_epi32(_mm256_cvttps_epi32(w), size2);
  alignas(32) float wus[8], wvs[8];
  alignas(32) int idx[8];
  _mm256_store_ps(wus, _mm256_sub_ps(u, _mm256_cvtepi32_ps(ti)));
  _mm256_store_ps(wvs, _mm256_sub_ps(w, _mm256_cvtepi32_ps(tj)));
  _mm256_store_si256(reinterpret_cast<__m256i*>(idx), _mm256_add_epi32(_mm256_mullo_epi32(ti, cells), tj));
  __m128 cs[8];
  for (int l = 0; l < 8; ++l) {
    // Cell (ti, tj): [entry (i, j), entry (i + 1, j)] and [(i, j + 1), (i + 1, j + 1)]; one
    // lerp along j gives both rows' values (Classifier::pair's r0 and r1).
    const float* c = cl.cells + std::ptrdiff_t(idx[l]) * 16;
    const __m256 x0 = _mm256_loadu_ps(c), x1 = _mm256_loadu_ps(c + 8);
    const __m256 rows = _mm256_add_ps(x0, _mm256_mul_ps(_mm256_set1_ps(wvs[l]), _mm256_sub_ps(x1, x0)));
    const __m128 l0 = _mm256_castps256_ps128(rows), l1 = _mm256_extractf128_ps(rows, 1);
    cs[l] = _mm_add_ps(l0, _mm_mul_ps(_mm_set1_ps(wus[l]), _mm_sub_ps(l1, l0)));
  }
  transpose_rgba(cs, r, g, b, a);
}

// half_segment for 8 lanes (same operations).
STRATA_TARGET_AVX2 inline void half_segment8(__m256& r, __m256& g, __m256& b, __m256& a) {
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f);
  const __m256 h = _mm256_sub_ps(one, _mm256_sqrt_ps(_mm256_max_ps(_mm256_sub_ps(one, a), zero)));
  const __m256 k = _mm256_and_ps(_mm256_div_ps(h, a), _mm256_cmp_ps(a, zero, _CMP_GT_OQ));
  r = _mm256_mul_ps(r, k);
  g = _mm256_mul_ps(g, k);
  b = _mm256_mul_ps(b, k);
  a = h;
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

}  // namespace

// The loop, once per instruction set, with the attributes march8.hpp declares.
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

template decltype(march8<false>) march8<false>;
template decltype(march8<true>) march8<true>;
template decltype(march8_avx512<false>) march8_avx512<false>;
template decltype(march8_avx512<true>) march8_avx512<true>;

#endif  // STRATA_X86_64

}  // namespace strata::render::detail
