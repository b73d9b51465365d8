// The brick reconstruction GEMM, compiled three times with different target attributes. The
// code is written once with GCC vector extensions: a vector of VW floats becomes one SSE, AVX2
// or AVX-512 register depending on the target of the function it is inlined into, and `acc +=
// l * b` contracts to an FMA where the target has one. Tile sizes differ per target because the
// register files differ (16 xmm/ymm vs 32 zmm): the accumulators plus the loaded column of L
// must fit, or the compiler spills and throughput halves.
#include "reconstruct_kernel.hpp"
#include "strata/core/isa.hpp"

namespace strata::tensor::detail {
namespace {

template <int VW>
struct VecOf {
  typedef float type __attribute__((vector_size(VW * sizeof(float))));
};

// Out[m0 : m0 + VW*MV, n0 : n0 + NR] = L[m0 : .., :] · R[:, n0 : ..], accumulators in registers.
template <int VW, int MV, int NR>
[[gnu::always_inline]] inline void tile(const GemmArgs& g, std::int64_t m0, std::int64_t n0) {
  using V = typename VecOf<VW>::type;
  V acc[NR][MV];
  for (int c = 0; c < NR; ++c)
    for (int j = 0; j < MV; ++j) acc[c][j] = V{};
  // Locals, not g's fields: stores through `out` could otherwise alias them and force reloads.
  const std::int64_t depth = g.k, ld_l = g.ld_l, r_k = g.r_k, r_n = g.r_n, ld_out = g.ld_out;
  const float* l = g.l + m0;
  const float* r = g.r + n0 * r_n;
  for (std::int64_t k = 0; k < depth; ++k, l += ld_l, r += r_k) {
    V lv[MV];
    for (int j = 0; j < MV; ++j) __builtin_memcpy(&lv[j], l + j * VW, sizeof(V));  // unaligned load
    for (int c = 0; c < NR; ++c) {
      const float b = r[c * r_n];
      for (int j = 0; j < MV; ++j) acc[c][j] += lv[j] * b;
    }
  }
  float* out = g.out + n0 * ld_out + m0;
  for (int c = 0; c < NR; ++c)
    for (int j = 0; j < MV; ++j) __builtin_memcpy(out + c * ld_out + j * VW, &acc[c][j], sizeof(V));
}

// Rows that do not fill a vector (only when I1 is not a multiple of the vector width).
inline void scalar_rows(const GemmArgs& g, std::int64_t m0, std::int64_t n0, int columns) {
  for (int c = 0; c < columns; ++c) {
    for (std::int64_t m = m0; m < g.m; ++m) {
      float sum = 0;
      for (std::int64_t k = 0; k < g.k; ++k) sum += g.l[m + k * g.ld_l] * g.r[k * g.r_k + (n0 + c) * g.r_n];
      g.out[(n0 + c) * g.ld_out + m] = sum;
    }
  }
}

// One block of NR columns over all rows: full MV-vector tiles, then single vectors, then scalars.
template <int VW, int MV, int NR>
[[gnu::always_inline]] inline void column_block(const GemmArgs& g, std::int64_t n0) {
  constexpr std::int64_t rows_per_tile = std::int64_t(VW) * MV;
  std::int64_t m0 = 0;
  for (; m0 + rows_per_tile <= g.m; m0 += rows_per_tile) tile<VW, MV, NR>(g, m0, n0);
  for (; m0 + VW <= g.m; m0 += VW) tile<VW, 1, NR>(g, m0, n0);
  if (m0 < g.m) scalar_rows(g, m0, n0, NR);
}

// Columns n0.. in blocks of NR, the remainder in halving block widths (NR/2, ..., 1).
template <int VW, int MV, int NR>
[[gnu::always_inline]] inline void columns_from(const GemmArgs& g, std::int64_t n0) {
  for (; n0 + NR <= g.n; n0 += NR) column_block<VW, MV, NR>(g, n0);
  if constexpr (NR > 1) {
    if (n0 < g.n) columns_from<VW, MV, NR / 2>(g, n0);
  }
}

template <int VW, int MV, int NR>
[[gnu::always_inline]] inline void gemm(const GemmArgs& g) {
  columns_from<VW, MV, NR>(g, 0);
}

}  // namespace

// Tile shapes (vector width VW, vectors per column MV, columns NR) were chosen by measurement
// (bench_tensor, B = 32, R = 16). With 16 registers (SSE, AVX2) 2x6 accumulators plus two loaded
// vectors fit, a 4x3 tile spills. With 32 zmm registers the last product, which has I1 I2 rows,
// takes a taller 4x6 tile (fewer broadcasts per FMA); the first two, with I1 = 32 rows, take 2x12.
// The projection's products have the same shapes (a narrow row count, then a wide one), so
// they take the same tiles.
namespace {
void gemm_sse(const GemmArgs& g) { gemm<4, 2, 6>(g); }
STRATA_TARGET_AVX2 void gemm_avx2(const GemmArgs& g) { gemm<8, 2, 6>(g); }
STRATA_TARGET_AVX512 void gemm_avx512_narrow(const GemmArgs& g) { gemm<16, 2, 12>(g); }
STRATA_TARGET_AVX512 void gemm_avx512_wide(const GemmArgs& g) { gemm<16, 4, 6>(g); }
}  // namespace

void reconstruct_generic(const ReconstructArgs& a) { reconstruct_with(a, gemm_sse, gemm_sse); }
void reconstruct_avx2(const ReconstructArgs& a) { reconstruct_with(a, gemm_avx2, gemm_avx2); }
void reconstruct_avx512(const ReconstructArgs& a) { reconstruct_with(a, gemm_avx512_narrow, gemm_avx512_wide); }

void project_generic(const ProjectArgs& a) { project_with(a, gemm_sse, gemm_sse); }
void project_avx2(const ProjectArgs& a) { project_with(a, gemm_avx2, gemm_avx2); }
void project_avx512(const ProjectArgs& a) { project_with(a, gemm_avx512_narrow, gemm_avx512_wide); }

}  // namespace strata::tensor::detail
