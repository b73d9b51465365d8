// Gram matrices of mode unfoldings (never formed) and sums of squares, one entry point per
// instruction-set level.
#include <algorithm>
#include <cmath>

#include "tensor/decompose_simd.hpp"
#include "tensor/decompose_variants.hpp"

namespace strata::tensor::detail {
namespace {

// ---- Gram matrices of unfoldings ------------------------------------------------------------

// Blocks of B x B column pairs (p, q), q-block >= p-block; B^2 vector accumulators plus 2 B
// loaded vectors stay in registers. Columns past n repeat the last one and are not written.
template <int VW, int B, class T>
[[gnu::always_inline]] inline void gram_dot_typed(const DGramArgs& a, const T* x) {
  using V = typename DVecOf<VW>::type;
  const std::int64_t n = a.n, len = a.len, vec_len = len / VW * VW;
  for (std::int64_t p0 = 0; p0 < n; p0 += B) {
    for (std::int64_t q0 = p0; q0 < n; q0 += B) {
      std::int64_t po[B], qo[B];
      for (int i = 0; i < B; ++i) {
        po[i] = std::min(p0 + i, n - 1) * a.col_stride;
        qo[i] = std::min(q0 + i, n - 1) * a.col_stride;
      }
      V acc[B][B];
      double tail[B][B];
      for (int i = 0; i < B; ++i)
        for (int j = 0; j < B; ++j) {
          acc[i][j] = V{};
          tail[i][j] = 0;
        }
      for (std::int64_t s = 0; s < a.segments; ++s) {
        const T* base = x + s * a.seg_stride;
        for (std::int64_t t = 0; t < vec_len; t += VW) {
          V xp[B], xq[B];
          for (int i = 0; i < B; ++i) xp[i] = load<VW>(base + po[i] + t);
          for (int j = 0; j < B; ++j) xq[j] = load<VW>(base + qo[j] + t);
          for (int i = 0; i < B; ++i)
            for (int j = 0; j < B; ++j) acc[i][j] += xp[i] * xq[j];
        }
        for (std::int64_t t = vec_len; t < len; ++t)
          for (int i = 0; i < B; ++i)
            for (int j = 0; j < B; ++j) tail[i][j] += double(base[po[i] + t]) * double(base[qo[j] + t]);
      }
      for (int i = 0; i < B; ++i) {
        for (int j = 0; j < B; ++j) {
          const std::int64_t p = p0 + i, q = q0 + j;
          if (p >= n || q >= n) continue;
          const double v = hsum<VW>(acc[i][j]) + tail[i][j];
          a.g[p + q * n] = v;
          a.g[q + p * n] = v;
        }
      }
    }
  }
}

template <int VW, int B>
[[gnu::always_inline]] inline void gram_dot(const DGramArgs& a) {
  if (a.x_f) gram_dot_typed<VW, B>(a, a.x_f);
  else gram_dot_typed<VW, B>(a, a.x);
}

// ---- Gram matrices of small integers -------------------------------------------------------

// Rows of 16-bit integers whose products sum exactly in 32 bits: the loop is the widening dot
// product GCC turns into pmaddwd (8 multiply-adds per SSE2 instruction, 16 with AVX2, 32 with
// AVX-512BW). Four rows q share each load of row p.
[[gnu::always_inline]] inline void gram_i16_impl(const std::int16_t* x, std::int64_t n, std::int64_t len, double* g) {
  for (std::int64_t p = 0; p < n; ++p) {
    const std::int16_t* xp = x + p * len;
    std::int64_t q = p;
    for (; q + 4 <= n; q += 4) {
      const std::int16_t *x0 = x + q * len, *x1 = x0 + len, *x2 = x1 + len, *x3 = x2 + len;
      std::int32_t s0 = 0, s1 = 0, s2 = 0, s3 = 0;
      for (std::int64_t i = 0; i < len; ++i) {
        const std::int32_t a = xp[i];
        s0 += a * x0[i];
        s1 += a * x1[i];
        s2 += a * x2[i];
        s3 += a * x3[i];
      }
      const std::int32_t sums[4] = {s0, s1, s2, s3};
      for (int j = 0; j < 4; ++j) g[p + (q + j) * n] = g[(q + j) + p * n] = double(sums[j]);
    }
    for (; q < n; ++q) {
      const std::int16_t* xq = x + q * len;
      std::int32_t sum = 0;
      for (std::int64_t i = 0; i < len; ++i) sum += std::int32_t(xp[i]) * xq[i];
      g[p + q * n] = g[q + p * n] = double(sum);
    }
  }
}

// ---- Conversions and norms ------------------------------------------------------------------

template <int VW, class T>
[[gnu::always_inline]] inline double sum_squares_impl(const T* x, std::int64_t n) {
  using V = typename DVecOf<VW>::type;
  V acc0{}, acc1{};
  std::int64_t i = 0;
  for (; i + 2 * VW <= n; i += 2 * VW) {
    const V a = load<VW>(x + i), b = load<VW>(x + i + VW);
    acc0 += a * a;
    acc1 += b * b;
  }
  double s = hsum<VW>(acc0 + acc1);
  for (; i < n; ++i) s += double(x[i]) * double(x[i]);
  return s;
}

}  // namespace

// Gram blocks: 4 x 4 pairs (16 + 8 zmm), 3 x 3 on 16 registers.
void gram_generic(const DGramArgs& a) { gram_dot<2, 3>(a); }
STRATA_TARGET_AVX2 void gram_avx2(const DGramArgs& a) { gram_dot<4, 3>(a); }
STRATA_TARGET_AVX512 void gram_avx512(const DGramArgs& a) { gram_dot<8, 4>(a); }
void gram_i16_generic(const std::int16_t* x, std::int64_t n, std::int64_t len, double* g) { gram_i16_impl(x, n, len, g); }
STRATA_TARGET_AVX2 void gram_i16_avx2(const std::int16_t* x, std::int64_t n, std::int64_t len, double* g) {
  gram_i16_impl(x, n, len, g);
}
STRATA_TARGET_AVX512 void gram_i16_avx512(const std::int16_t* x, std::int64_t n, std::int64_t len, double* g) {
  gram_i16_impl(x, n, len, g);
}
double sum_squares_generic(const double* x, std::int64_t n) { return sum_squares_impl<2>(x, n); }
double sum_squares_f_generic(const float* x, std::int64_t n) { return sum_squares_impl<2>(x, n); }
STRATA_TARGET_AVX2 double sum_squares_avx2(const double* x, std::int64_t n) { return sum_squares_impl<4>(x, n); }
STRATA_TARGET_AVX2 double sum_squares_f_avx2(const float* x, std::int64_t n) { return sum_squares_impl<4>(x, n); }
STRATA_TARGET_AVX512 double sum_squares_avx512(const double* x, std::int64_t n) { return sum_squares_impl<8>(x, n); }
STRATA_TARGET_AVX512 double sum_squares_f_avx512(const float* x, std::int64_t n) {
  return sum_squares_impl<8>(x, n);
}

}  // namespace strata::tensor::detail
