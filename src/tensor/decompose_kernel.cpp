// The decomposition kernels' dispatch: one table of entry points per instruction-set level
// (decompose_gemm.cpp, decompose_gram.cpp, decompose_eigen.cpp), picked by active_isa().
#include <string>

#include "strata/core/error.hpp"
#include "strata/core/isa.hpp"
#include "tensor/decompose_kernel.hpp"
#include "tensor/decompose_variants.hpp"

namespace strata::tensor::detail {
namespace {

const DecomposeKernels kGeneric{Isa::generic, gemm_generic, gram_generic, leading_eigen_generic,
                                sum_squares_generic, sum_squares_f_generic};
const DecomposeKernels kAvx2{Isa::avx2, gemm_avx2, gram_avx2, leading_eigen_avx2, sum_squares_avx2,
                             sum_squares_f_avx2};
const DecomposeKernels kAvx512{Isa::avx512, gemm_avx512, gram_avx512, leading_eigen_avx512, sum_squares_avx512,
                               sum_squares_f_avx512};

}  // namespace

std::int64_t leading_eigen_work(std::int64_t n) { return n * n + (8 + 4 * 16) * n; }

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
