#pragma once
// Double-precision kernels of the Tucker decompositions (tucker.cpp): small GEMMs for the n-mode
// products, Gram matrices of mode unfoldings (never formed) and a symmetric eigen-solver. Private
// to src/tensor. Like the reconstruction kernel (reconstruct_kernel.cpp) each is written once with
// GCC vector extensions and compiled for AVX-512, AVX2+FMA and baseline x86-64; the widest variant
// active_isa() allows (strata/core/isa.hpp) is picked at run time, so the portable build needs no
// -march=native.
#include <array>
#include <cstdint>

#include "strata/core/isa.hpp"

namespace strata::tensor::detail {

// Out(M x N) = L(M x K) · R(K x N) for `batch` independent products.
// L and Out are column-major with leading dimensions ld_l and ld_out; R is read one scalar at a
// time at r[k * r_k + n * r_n], so it can be a matrix, its transpose or a tensor's unfolding.
// Product b uses l + b * l_step, r + b * r_step and out + b * out_step.
// With `lower`, only Out(i, j) with i >= j is needed: tiles wholly above the diagonal are skipped
// and the entries there are left unspecified (symmetric products, e.g. X X^T).
// Setting l_f (r_f) reads that operand as float instead (the decompositions' float input tensor,
// widened exactly on the fly): vector tiles give the bits of a double copy; the scalar tail rows
// (m not a multiple of the vector width) agree to rounding, since the compiler may contract
// their multiply-adds into FMA differently in the float and double instantiations.
struct DGemmArgs {
  std::int64_t m = 0, n = 0, k = 0;
  const double* l = nullptr;
  std::int64_t ld_l = 0;
  const double* r = nullptr;
  std::int64_t r_k = 0, r_n = 0;
  double* out = nullptr;
  std::int64_t ld_out = 0;
  std::int64_t batch = 1, l_step = 0, r_step = 0, out_step = 0;
  bool lower = false;
  const float* l_f = nullptr;
  const float* r_f = nullptr;
};

// Symmetric G (n x n, column-major, ld n, both triangles written) of inner products of columns
// made of contiguous runs: G(p, q) = Σ_s Σ_{i < len} x[s seg_stride + p col_stride + i] ·
// x[s seg_stride + q col_stride + i]. The mode-3 Gram of an I1 x I2 x I3 tensor is one segment of
// length I1 I2 (column stride I1 I2); the mode-2 Gram is I3 segments of length I1 (segment
// stride I1 I2, column stride I1).
// x_f instead of x reads a float tensor.
struct DGramArgs {
  std::int64_t n = 0, segments = 1, seg_stride = 0, col_stride = 0, len = 0;
  const double* x = nullptr;
  double* g = nullptr;
  const float* x_f = nullptr;
};

struct DecomposeKernels {
  Isa isa = Isa::generic;  // the level this variant is compiled for
  void (*gemm)(const DGemmArgs&) = nullptr;
  void (*gram)(const DGramArgs&) = nullptr;
  // G (n x n, both triangles) of n contiguous rows of `len` 16-bit integers, exactly; the caller
  // guarantees max|x|^2 · len < 2^31, so every sum fits its 32-bit accumulator.
  void (*gram_i16)(const std::int16_t* x, std::int64_t n, std::int64_t len, double* g) = nullptr;
  // The r eigenvectors of the r largest eigenvalues of the symmetric n x n matrix `a` (both
  // triangles read, destroyed), in order of decreasing eigenvalue, as the columns of u (n x r,
  // column-major), orthonormal to working precision. Eigenvectors of (numerically) equal
  // eigenvalues are any orthonormal basis of their space. `work` holds leading_eigen_work(n)
  // doubles. Returns false if the eigen-decomposition fails (never for finite input).
  bool (*leading_eigen)(double* a, std::int64_t n, std::int64_t r, double* u, double* work) = nullptr;
  // Sum of squares, accumulated in double.
  double (*sum_squares)(const double* x, std::int64_t n) = nullptr;
  double (*sum_squares_f)(const float* x, std::int64_t n) = nullptr;
};

std::int64_t leading_eigen_work(std::int64_t n);

// G = X_(n) X_(n)^T (d[n-1] x d[n-1], column-major, both triangles) of a d[0] x d[1] x d[2]
// tensor (first index fastest) without forming the unfolding: `x` in double, or `x_f` (x null)
// in float, widened exactly. All modes run on the Gram kernel (mode 1 on a transposed copy).
void mode_gram(const DecomposeKernels& k, const std::array<std::int64_t, 3>& d, const double* x, const float* x_f,
               int mode, double* g);

// The widest variants active_isa() allows.
const DecomposeKernels& decompose_kernels();
// The widest variants at or below `isa`; throws Error if this CPU does not support `isa`.
const DecomposeKernels& decompose_kernels(Isa isa);

}  // namespace strata::tensor::detail
