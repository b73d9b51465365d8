#pragma once
// Tucker decompositions of 3-way tensors (paper 1, Appendix A.1): truncated HOSVD and HOOI
// (alternating least squares initialised from HOSVD). Storage is float; the decompositions run
// in double so that the fit and the orthogonality of the factors are limited by float storage
// of the result only.
#include "strata/tensor/tensor3.hpp"

namespace strata {

// A rank-(R1, R2, R3) Tucker model A ≈ core ×1 U1 ×2 U2 ×3 U3.
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

// Truncated higher-order SVD: U^(n) = the R_n leading left singular vectors of the mode-n
// unfolding A_(n), core = A ×1 U1^T ×2 U2^T ×3 U3^T. With ranks == dims this is the full HOSVD
// (square orthogonal factors, all-orthogonal core) and reproduces A exactly.
// Singular vectors come from the eigen-decomposition of the Gram matrix A_(n) A_(n)^T when the
// unfolding is wide (always, for bricks) and from a thin SVD of A_(n) when it is tall. Each
// column's sign is fixed so that its largest-magnitude entry is positive (reproducible output;
// for non-negative data the hot corner B(0,0,0) comes out positive).
Tucker hosvd(const Tensor3& a, const Ranks3& ranks);

struct HooiOptions {
  double tolerance = 1e-5;   // stop when the fit changes by less than this between sweeps
  int max_iterations = 50;   // sweeps over the three modes
  // Rotate the result so the core is all-orthogonal with slice norms decreasing along every
  // mode (an HOSVD of the core). The fit is unchanged; truncating to the leading K < R ranks at
  // decode (the renderer's rank slider) then keeps the most energetic components first.
  bool order_core = true;
};

// Higher-order orthogonal iteration (HOOI / Tucker-ALS) for a rank-(R1, R2, R3) model,
// initialised from the truncated HOSVD. Each sweep re-solves one factor with the others fixed,
// which never decreases the fit, so the result fits at least as well as hosvd(a, ranks).
Tucker hooi(const Tensor3& a, const Ranks3& ranks, const HooiOptions& options = {});

// The leading K1 x K2 x K3 sub-core and the first K_n columns of each factor (K_n <= R_n).
Tucker truncate(const Tucker& model, const Ranks3& ranks);

// 1 - ‖A - Ã‖F / ‖A‖F computed by reconstructing the model explicitly (1 when both are zero).
double tucker_fit(const Tensor3& a, const Tucker& model);

// Eq. A.5: one voxel as Σ_r1 Σ_r2 Σ_r3 b(r1,r2,r3) u1(i1,r1) u2(i2,r2) u3(i3,r3), accumulated
// in double. O(R1 R2 R3) per voxel: a test oracle and a random-access fallback, not the decoder.
double reconstruct_voxel(const Tucker& model, std::int64_t i1, std::int64_t i2, std::int64_t i3);

// Every voxel by Eq. A.5 (test oracle).
Tensor3 reconstruct_voxelwise(const Tucker& model);

// Throws Error unless 1 <= ranks[n] <= dims[n] for every mode.
void check_ranks(const Dims3& dims, const Ranks3& ranks, const char* context);

}  // namespace strata
