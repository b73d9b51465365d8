#pragma once
#include <optional>
#include <span>
// n-mode products (tensor times matrix, TTM) on the general path: each product is one Eigen GEMM
// (modes 1 and 3) or one GEMM per frontal slice (mode 2) on reshaped views of the contiguous
// storage, so nothing is permuted in memory. Used by the decompositions and as the reference for
// the hand-tuned brick reconstruction in reconstruct.hpp. Modes are numbered 1..3 (paper, Eq. A.6).
#include "strata/tensor/tensor3.hpp"

namespace strata::tensor {

// Y = X ×n U, i.e. Y_(n) = U X_(n). U is J x I_n; mode n of Y has extent J.
template <class T>
BasicTensor3<T> ttm(const BasicTensor3<T>& x, int mode, const Matrix<T>& u);

// Y = X ×n U^T, i.e. Y_(n) = U^T X_(n). U is I_n x J (a factor matrix); mode n of Y has extent J.
template <class T>
BasicTensor3<T> ttm_transposed(const BasicTensor3<T>& x, int mode, const Matrix<T>& u);

// A ×1 U1^T ×2 U2^T ×3 U3^T: the core of A in the bases U (R1 x R2 x R3).
template <class T>
BasicTensor3<T> project(const BasicTensor3<T>& a, const Factors<T>& u);

// B ×1 U1 ×2 U2 ×3 U3 (paper Eq. A.3): the tensor a Tucker model represents (I1 x I2 x I3).
template <class T>
BasicTensor3<T> reconstruct(const BasicTensor3<T>& core, const Factors<T>& u);

// Mode-n unfolding X_(n), I_n x (product of the other extents), columns in Kolda-Bader order
// (the lower remaining mode varies fastest). For tests and small tensors; the kernels never
// form it.
template <class T>
Matrix<T> unfold(const BasicTensor3<T>& x, int mode);

// X_(n) X_(n)^T (I_n x I_n), accumulated in double, without forming the unfolding (the
// decompositions' dispatched Gram kernels).
template <class T>
Matrix<double> gram(const BasicTensor3<T>& x, int mode);

/// @brief gram() of an integer tensor (`values` of extents `dims`, first index fastest), exact,
/// on 16-bit multiply-add kernels (several times the double kernel's speed): the encoder's
/// quantized cores. Nothing when the values are too large for that (max|v|^2 times the row
/// length must stay below 2^31); gram() of the values then serves.
std::optional<Matrix<double>> integer_gram(std::span<const std::int32_t> values, const Dims3& dims, int mode);

// Throws Error unless mode is 1, 2 or 3.
void check_mode(int mode, const char* context);

}  // namespace strata::tensor
