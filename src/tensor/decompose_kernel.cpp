// The decomposition kernels' dispatch: one table of entry points per instruction-set level
// (decompose_gemm.cpp, decompose_gram.cpp, decompose_eigen.cpp), picked by active_isa().
#include <string>
#include <vector>

#include "strata/core/error.hpp"
#include "strata/core/isa.hpp"
#include "tensor/decompose_kernel.hpp"
#include "tensor/decompose_variants.hpp"

namespace strata::tensor::detail {
namespace {

const DecomposeKernels kGeneric{Isa::generic,          gemm_generic,        gram_generic,
                                gram_i16_generic,      leading_eigen_generic, sum_squares_generic,
                                sum_squares_f_generic};
const DecomposeKernels kAvx2{Isa::avx2,         gemm_avx2,          gram_avx2,        gram_i16_avx2,
                             leading_eigen_avx2, sum_squares_avx2, sum_squares_f_avx2};
const DecomposeKernels kAvx512{Isa::avx512,         gemm_avx512,          gram_avx512,        gram_i16_avx512,
                               leading_eigen_avx512, sum_squares_avx512, sum_squares_f_avx512};

}  // namespace

std::int64_t leading_eigen_work(std::int64_t n) { return n * n + (8 + 4 * 16) * n; }

void mode_gram(const DecomposeKernels& k, const std::array<std::int64_t, 3>& d, const double* x, const float* x_f,
               int mode, double* g) {
  const std::int64_t i1 = d[0], i2 = d[1], i3 = d[2];
  if (mode == 1) {
    // The rows of X_(1) are strided in X. Transposed to (I2 I3) x I1 they are contiguous
    // columns, which the Gram kernel takes at about three times the speed of a GEMM of X with
    // its own transpose (measured on 28^3 brick cores).
    const std::int64_t cols = i2 * i3;
    thread_local std::vector<double> transposed;
    thread_local std::vector<float> transposed_f;
    DGramArgs a{i1, 1, 0, cols, cols, nullptr, g};
    if (x_f) {
      transposed_f.resize(std::size_t(i1 * cols));
      for (std::int64_t c = 0; c < cols; ++c)
        for (std::int64_t r = 0; r < i1; ++r) transposed_f[std::size_t(c + r * cols)] = x_f[r + c * i1];
      a.x_f = transposed_f.data();
    } else {
      transposed.resize(std::size_t(i1 * cols));
      for (std::int64_t c = 0; c < cols; ++c)
        for (std::int64_t r = 0; r < i1; ++r) transposed[std::size_t(c + r * cols)] = x[r + c * i1];
      a.x = transposed.data();
    }
    k.gram(a);
  } else if (mode == 2) {
    // Columns of X_(2) are the rows of the frontal slices: runs of I1 per slice.
    DGramArgs a{i2, i3, i1 * i2, i1, i1, x, g};
    a.x_f = x_f;
    k.gram(a);
  } else {
    // X viewed as (I1 I2) x I3: inner products of whole frontal slices.
    DGramArgs a{i3, 1, 0, i1 * i2, i1 * i2, x, g};
    a.x_f = x_f;
    k.gram(a);
  }
}

const DecomposeKernels& decompose_kernels(Isa isa) {
  if (!isa_supported(isa))
    throw Error("decomposition kernels: this CPU does not support " + std::string(isa_name(isa)));
  switch (isa) {
    case Isa::avx512: return kAvx512;
    case Isa::avx2: return kAvx2;
    default: return kGeneric;
  }
}

const DecomposeKernels& decompose_kernels() { return decompose_kernels(active_isa()); }

}  // namespace strata::tensor::detail
