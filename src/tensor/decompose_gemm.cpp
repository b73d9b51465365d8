// Batched small GEMMs of the decompositions (DGemmArgs), one entry point per instruction-set level.
#include <algorithm>
#include <cmath>

#include "tensor/decompose_simd.hpp"
#include "tensor/decompose_variants.hpp"

namespace strata::tensor::detail {
namespace {

// ---- GEMM -----------------------------------------------------------------------------------

// Out[m0 : m0 + VW*MV, n0 : n0 + NR] = L[m0 : .., :] · R[:, n0 : ..], accumulators in registers.
template <int VW, int MV, int NR, class LT, class RT>
[[gnu::always_inline]] inline void gemm_tile(const DGemmArgs& g, const LT* l, const RT* r, double* out,
                                             std::int64_t m0, std::int64_t n0) {
  using V = typename DVecOf<VW>::type;
  V acc[NR][MV];
  for (int c = 0; c < NR; ++c)
    for (int j = 0; j < MV; ++j) acc[c][j] = V{};
  // Locals, not g's fields: stores through `out` could otherwise alias them and force reloads.
  const std::int64_t depth = g.k, ld_l = g.ld_l, r_k = g.r_k, r_n = g.r_n, ld_out = g.ld_out;
  const LT* lp = l + m0;
  const RT* rp = r + n0 * r_n;
  for (std::int64_t k = 0; k < depth; ++k, lp += ld_l, rp += r_k) {
    V lv[MV];
    for (int j = 0; j < MV; ++j) lv[j] = load<VW>(lp + j * VW);
    for (int c = 0; c < NR; ++c) {
      const double b = double(rp[c * r_n]);
      for (int j = 0; j < MV; ++j) acc[c][j] += lv[j] * b;
    }
  }
  double* op = out + n0 * ld_out + m0;
  for (int c = 0; c < NR; ++c)
    for (int j = 0; j < MV; ++j) store<VW>(op + c * ld_out + j * VW, acc[c][j]);
}

// Rows that do not fill a vector.
template <class LT, class RT>
inline void gemm_scalar_rows(const DGemmArgs& g, const LT* l, const RT* r, double* out, std::int64_t m0,
                             std::int64_t n0, int columns) {
  for (int c = 0; c < columns; ++c) {
    for (std::int64_t m = m0; m < g.m; ++m) {
      double sum = 0;
      for (std::int64_t k = 0; k < g.k; ++k) sum += double(l[m + k * g.ld_l]) * double(r[k * g.r_k + (n0 + c) * g.r_n]);
      out[(n0 + c) * g.ld_out + m] = sum;
    }
  }
}

// One block of NR columns over all rows: full MV-vector tiles, then single vectors, then scalars.
template <int VW, int MV, int NR, class LT, class RT>
[[gnu::always_inline]] inline void gemm_column_block(const DGemmArgs& g, const LT* l, const RT* r, double* out,
                                                     std::int64_t n0) {
  constexpr std::int64_t rows_per_tile = std::int64_t(VW) * MV;
  std::int64_t m0 = 0;
  if (g.lower) m0 = std::min(n0 / VW * VW, g.m / VW * VW);  // rows above n0 are not needed
  for (; m0 + rows_per_tile <= g.m; m0 += rows_per_tile) gemm_tile<VW, MV, NR>(g, l, r, out, m0, n0);
  for (; m0 + VW <= g.m; m0 += VW) gemm_tile<VW, 1, NR>(g, l, r, out, m0, n0);
  if (m0 < g.m) gemm_scalar_rows(g, l, r, out, m0, n0, NR);
}

// Columns n0.. in blocks of NR, the remainder in halving block widths (NR/2, ..., 1).
template <int VW, int MV, int NR, class LT, class RT>
[[gnu::always_inline]] inline void gemm_columns_from(const DGemmArgs& g, const LT* l, const RT* r, double* out,
                                                     std::int64_t n0) {
  for (; n0 + NR <= g.n; n0 += NR) gemm_column_block<VW, MV, NR>(g, l, r, out, n0);
  if constexpr (NR > 1) {
    if (n0 < g.n) gemm_columns_from<VW, MV, NR / 2>(g, l, r, out, n0);
  }
}

template <int VW, int MV, int NR, class LT, class RT>
[[gnu::always_inline]] inline void gemm_batch_typed(const DGemmArgs& g, const LT* l, const RT* r) {
  for (std::int64_t b = 0; b < g.batch; ++b)
    gemm_columns_from<VW, MV, NR>(g, l + b * g.l_step, r + b * g.r_step, g.out + b * g.out_step, 0);
}

// Dispatches on which operands are float (l_f / r_f set).
template <int VW, int MV, int NR>
[[gnu::always_inline]] inline void gemm_batch(const DGemmArgs& g) {
  if (g.l_f) {
    if (g.r_f) gemm_batch_typed<VW, MV, NR>(g, g.l_f, g.r_f);
    else gemm_batch_typed<VW, MV, NR>(g, g.l_f, g.r);
  } else if (g.r_f) {
    gemm_batch_typed<VW, MV, NR>(g, g.l, g.r_f);
  } else {
    gemm_batch_typed<VW, MV, NR>(g, g.l, g.r);
  }
}

}  // namespace

// Tiles (measured on the brick shapes, B = 32, R = 16): AVX-512 takes 3 vectors x 8 columns
// (24 zmm accumulators) when the product has at least 24 rows, so that N = R = 16 splits into
// whole blocks, and 2 x 12 for fewer rows (the mode-1 products, R rows); AVX2 takes 3 x 4 for
// tall products and 2 x 6 otherwise, SSE2 2 x 6 (12 of 16 registers).
void gemm_generic(const DGemmArgs& g) { gemm_batch<2, 2, 6>(g); }
STRATA_TARGET_AVX2 void gemm_avx2(const DGemmArgs& g) {
  if (g.m >= 256) gemm_batch<4, 3, 4>(g);
  else gemm_batch<4, 2, 6>(g);
}
STRATA_TARGET_AVX512 void gemm_avx512(const DGemmArgs& g) {
  if (g.m >= 24) gemm_batch<8, 3, 8>(g);
  else gemm_batch<8, 2, 12>(g);
}

}  // namespace strata::tensor::detail
