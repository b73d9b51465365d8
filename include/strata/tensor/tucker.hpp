#pragma once
/// @file
/// @brief Tucker decompositions of 3-way tensors (paper 1, Appendix A.1): truncated HOSVD and HOOI
/// (alternating least squares initialised from a sequentially truncated HOSVD). Storage is float;
/// the decompositions run in double so that the fit and the orthogonality of the factors are
/// limited by float storage of the result only. The n-mode products, Gram matrices and the
/// eigen-solver are hand-written kernels compiled for AVX-512, AVX2+FMA and baseline x86-64 and
/// chosen at run time (src/tensor/decompose_kernel.hpp); calls are thread-safe and reuse
/// per-thread scratch, so a loop over bricks does not allocate beyond the returned model.
#include "strata/tensor/tensor3.hpp"

namespace strata::tensor {

/// @brief A rank-(R1, R2, R3) Tucker model A ≈ core ×1 U1 ×2 U2 ×3 U3.
struct Tucker {
  Tensor3 core;             // R1 x R2 x R3, first index fastest
  Factors<float> factors;   // factors[n - 1] = U^(n), I_n x R_n, orthonormal columns
  // 1 - ‖A - Ã‖F / ‖A‖F of the decomposition that produced this model (1 when A = 0).
  // NaN after truncate(), which cannot know it without A (use tucker_fit()).
  double fit = 0;
  int iterations = 0;  // HOOI sweeps performed; 0 for HOSVD

  Dims3 dims() const { return {factors[0].rows(), factors[1].rows(), factors[2].rows()}; }
  Ranks3 ranks() const { return {int(core.dims()[0]), int(core.dims()[1]), int(core.dims()[2])}; }
};

/// @brief Truncated higher-order SVD: U^(n) = the R_n leading left singular vectors of the mode-n
/// unfolding A_(n), core = A ×1 U1^T ×2 U2^T ×3 U3^T. With ranks == dims this is the full HOSVD
/// (square orthogonal factors, all-orthogonal core) and reproduces A exactly.
/// Singular vectors come from the eigen-decomposition of the Gram matrix A_(n) A_(n)^T when the
/// unfolding is wide (always, for bricks) and from a thin SVD of A_(n) when it is tall. Each
/// column's sign is fixed so that its largest-magnitude entry is positive (reproducible output;
/// for non-negative data the hot corner B(0,0,0) comes out positive). Singular values below
/// ~3e-7 of the largest (eigenvalues of the Gram matrix below 1e-13 of the largest, the level of
/// its rounding errors) are not resolved: their vectors are some orthonormal completion.
Tucker hosvd(const Tensor3& a, const Ranks3& ranks);

/// @brief Stopping rule and core ordering of hooi().
struct HooiOptions {
  double tolerance = 1e-5;   // stop when the fit changes by less than this between sweeps
  int max_iterations = 50;   // sweeps over the three modes
  // Rotate the result so the core is all-orthogonal with slice norms decreasing along every
  // mode (an HOSVD of the core). The fit is unchanged; truncating to the leading K < R ranks at
  // decode (the renderer's rank slider) then keeps the most energetic components first.
  bool order_core = true;
};

/// @brief Higher-order orthogonal iteration (HOOI / Tucker-ALS) for a rank-(R1, R2, R3) model,
/// initialised from the sequentially truncated HOSVD (Vannieuwenhoven, Vandebril, Meerbergen
/// 2012) in the mode order 3, 2, 1: U3 from A_(3), U2 from (A ×3 U3^T)_(2), U1 from
/// (A ×3 U3^T ×2 U2^T)_(1). That initialisation fits like the truncated HOSVD (often better) at a
/// fraction of its cost, and its last step is the first update of the first sweep. Each sweep
/// re-solves one factor with the others fixed, which never decreases the fit.
Tucker hooi(const Tensor3& a, const Ranks3& ranks, const HooiOptions& options = {});

/// @brief The leading K1 x K2 x K3 sub-core and the first K_n columns of each factor (K_n <= R_n).
Tucker truncate(const Tucker& model, const Ranks3& ranks);

/// @brief 1 - ‖A - Ã‖F / ‖A‖F computed by reconstructing the model explicitly (1 when both are zero).
double tucker_fit(const Tensor3& a, const Tucker& model);

/// @brief Eq. A.5: one voxel as Σ_r1 Σ_r2 Σ_r3 b(r1,r2,r3) u1(i1,r1) u2(i2,r2) u3(i3,r3), accumulated
/// in double. O(R1 R2 R3) per voxel: a test oracle and a random-access fallback, not the decoder.
double reconstruct_voxel(const Tucker& model, std::int64_t i1, std::int64_t i2, std::int64_t i3);

/// @brief Every voxel by Eq. A.5 (test oracle).
Tensor3 reconstruct_voxelwise(const Tucker& model);

/// @brief Throws Error unless 1 <= ranks[n] <= dims[n] for every mode.
void check_ranks(const Dims3& dims, const Ranks3& ranks, const char* context);

}  // namespace strata::tensor
