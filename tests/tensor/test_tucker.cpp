#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "strata/tensor/ttm.hpp"
#include "strata/tensor/tucker.hpp"

namespace strata::tensor {
namespace {

Tensor3 random_tensor(const Dims3& d, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> dist(-1.0f, 1.0f);
  Tensor3 t(d);
  for (float& v : t.values()) v = dist(rng);
  return t;
}

// A smooth blob, an oblique wave (not axis-separable) and a little noise, positive like a scan.
Tensor3 structured_tensor(std::int64_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.0f, 0.02f);
  Tensor3 t(n, n, n);
  const double c = 0.4 * double(n);
  for (std::int64_t k = 0; k < n; ++k)
    for (std::int64_t j = 0; j < n; ++j)
      for (std::int64_t i = 0; i < n; ++i) {
        const double r2 = (i - c) * (i - c) + (j - c) * (j - c) + (k - c) * (k - c);
        const double blob = std::exp(-r2 / (0.1 * double(n * n)));
        const double wave = 0.3 * std::sin(0.35 * double(i) + 0.2 * double(j) - 0.15 * double(k));
        t(i, j, k) = float(1.0 + blob + wave) + noise(rng);
      }
  return t;
}

double relative_error(const Tensor3& a, const Tensor3& b) {
  EXPECT_EQ(a.dims(), b.dims());
  double err = 0, ref = 0;
  for (std::int64_t i = 0; i < a.size(); ++i) {
    const double d = double(a.data()[i]) - double(b.data()[i]);
    err += d * d;
    ref += double(a.data()[i]) * double(a.data()[i]);
  }
  return std::sqrt(err / ref);
}

// Factors are orthonormal in double, then rounded to float (relative 2^-24 per entry): each
// entry of U^T U moves by at most 2 * 2^-24 * ‖u_i‖‖u_j‖ ≈ 1.2e-7, far inside 1e-5.
double orthonormality_defect(const Matrix<float>& u) {
  const Matrix<double> ud = u.cast<double>();
  return (ud.transpose() * ud - Matrix<double>::Identity(u.cols(), u.cols())).cwiseAbs().maxCoeff();
}

// Inner product of core slices α and β along `mode` (the other two indices summed over).
double slice_inner_product(const Tensor3& core, int mode, std::int64_t alpha, std::int64_t beta) {
  const Dims3& d = core.dims();
  double sum = 0;
  for (std::int64_t k = 0; k < d[2]; ++k)
    for (std::int64_t j = 0; j < d[1]; ++j)
      for (std::int64_t i = 0; i < d[0]; ++i) {
        const std::int64_t idx[3] = {i, j, k};
        if (idx[mode - 1] != alpha) continue;
        std::int64_t other[3] = {i, j, k};
        other[mode - 1] = beta;
        sum += double(core(i, j, k)) * double(core(other[0], other[1], other[2]));
      }
  return sum;
}

TEST(TensorHosvd, FactorsAreOrthonormal) {
  const Tensor3 a = random_tensor({12, 10, 14}, 1);
  for (const Ranks3& r : {Ranks3{12, 10, 14}, Ranks3{4, 5, 6}, Ranks3{1, 1, 1}}) {
    const Tucker t = hosvd(a, r);
    for (const auto& u : t.factors) EXPECT_LT(orthonormality_defect(u), 1e-5);
    EXPECT_EQ(t.ranks(), r);
    EXPECT_EQ(t.dims(), a.dims());
  }
}

// Full rank: square orthogonal factors, so Ã = A up to float rounding of core and factors
// (relative ~1e-7 per product), well below the 1e-5 bound.
TEST(TensorHosvd, FullRankReconstructsInput) {
  for (const Tensor3& a : {random_tensor({9, 7, 8}, 2), structured_tensor(16, 3)}) {
    const Tucker t = hosvd(a, {int(a.dims()[0]), int(a.dims()[1]), int(a.dims()[2])});
    EXPECT_LT(relative_error(a, reconstruct(t.core, t.factors)), 1e-5);
    EXPECT_GT(t.fit, 1.0 - 1e-5);
  }
}

// A tall unfolding (I_n > product of the other extents) goes through the thin-SVD branch.
TEST(TensorHosvd, TallUnfoldingsUseSvdAndStayExact) {
  const Tensor3 a = random_tensor({20, 3, 2}, 4);
  const Tucker t = hosvd(a, {6, 3, 2});
  for (const auto& u : t.factors) EXPECT_LT(orthonormality_defect(u), 1e-5);
  EXPECT_LT(relative_error(a, reconstruct(t.core, t.factors)), 1e-5);  // rank of A_(1) is <= 6
}

// De Lathauwer et al.: the full HOSVD core is all-orthogonal (slices along any mode are
// mutually orthogonal) and the slice norms are the mode-n singular values, in decreasing order.
// Float rounding of the core perturbs inner products by ~1e-7 ‖A‖², hence the 1e-5 ‖A‖² bound.
TEST(TensorHosvd, CoreIsAllOrthogonalWithDecreasingSliceNorms) {
  const Tensor3 a = structured_tensor(10, 5);
  const Tucker t = hosvd(a, {10, 10, 10});
  const double energy = a.norm() * a.norm();
  for (int mode = 1; mode <= 3; ++mode) {
    double previous = INFINITY;
    for (std::int64_t alpha = 0; alpha < 10; ++alpha) {
      for (std::int64_t beta = alpha + 1; beta < 10; ++beta) {
        EXPECT_LT(std::abs(slice_inner_product(t.core, mode, alpha, beta)), 1e-5 * energy);
      }
      const double norm = std::sqrt(slice_inner_product(t.core, mode, alpha, alpha));
      EXPECT_LE(norm, previous + 1e-5 * a.norm()) << "mode " << mode << " slice " << alpha;
      previous = norm;
    }
  }
}

TEST(TensorHosvd, SeparableRankOneInputIsRecoveredExactly) {
  Tensor3 a(8, 6, 7);
  for (std::int64_t k = 0; k < 7; ++k)
    for (std::int64_t j = 0; j < 6; ++j)
      for (std::int64_t i = 0; i < 8; ++i)
        a(i, j, k) = float((1.0 + 0.5 * double(i)) * std::cos(0.3 * double(j)) * (2.0 - 0.1 * double(k)));
  for (const Tucker& t : {hosvd(a, {1, 1, 1}), hooi(a, {1, 1, 1})}) {
    EXPECT_LT(relative_error(a, reconstruct(t.core, t.factors)), 1e-5);
    // The fit comes from sqrt(‖A‖² - ‖B‖²): cancellation in double leaves ~sqrt(1e-16) = 1e-8.
    EXPECT_GT(t.fit, 1.0 - 1e-6);
  }
}

TEST(TensorHosvd, ReportedFitMatchesExplicitFit) {
  const Tensor3 a = structured_tensor(16, 6);
  const Tucker t = hosvd(a, {4, 4, 4});
  // Both are 1 - ‖A - Ã‖/‖A‖; they differ by float rounding of the stored model only.
  EXPECT_NEAR(t.fit, tucker_fit(a, t), 1e-5);
}

// ALS never decreases the fit, and it starts from the truncated HOSVD. Both fits are computed in
// double from the same ‖A‖; the tolerance covers rounding in the projections (~1e-12).
TEST(TensorHooi, FitsAtLeastAsWellAsTruncatedHosvd) {
  const Tensor3 inputs[] = {random_tensor({16, 16, 16}, 7), structured_tensor(16, 8), random_tensor({12, 9, 10}, 9)};
  for (const Tensor3& a : inputs) {
    for (const Ranks3& r : {Ranks3{4, 4, 4}, Ranks3{8, 3, 5}}) {
      const Tucker h = hosvd(a, r);
      const Tucker o = hooi(a, r);
      EXPECT_GE(o.fit, h.fit - 1e-9) << "ranks " << r[0] << "," << r[1] << "," << r[2];
      EXPECT_GE(o.iterations, 1);
      EXPECT_NEAR(o.fit, tucker_fit(a, o), 1e-5);
    }
  }
}

TEST(TensorHooi, ImprovesOnRandomDataAndStopsOnTolerance) {
  const Tensor3 a = random_tensor({16, 16, 16}, 10);
  const Tucker h = hosvd(a, {5, 5, 5});
  const Tucker o = hooi(a, {5, 5, 5}, {.tolerance = 1e-9, .max_iterations = 200});
  EXPECT_GT(o.fit, h.fit);  // random data: truncated HOSVD is not a stationary point
  EXPECT_LT(o.iterations, 200);
  const Tucker once = hooi(a, {5, 5, 5}, {.tolerance = 0, .max_iterations = 1});
  EXPECT_EQ(once.iterations, 1);
}

TEST(TensorHooi, OrderedCoreIsAllOrthogonalAndFactorsOrthonormal) {
  const Tensor3 a = structured_tensor(16, 11);
  const Tucker t = hooi(a, {6, 6, 6});
  for (const auto& u : t.factors) EXPECT_LT(orthonormality_defect(u), 1e-5);
  const double energy = a.norm() * a.norm();
  for (int mode = 1; mode <= 3; ++mode) {
    double previous = INFINITY;
    for (std::int64_t alpha = 0; alpha < 6; ++alpha) {
      for (std::int64_t beta = alpha + 1; beta < 6; ++beta)
        EXPECT_LT(std::abs(slice_inner_product(t.core, mode, alpha, beta)), 1e-5 * energy);
      const double norm = std::sqrt(slice_inner_product(t.core, mode, alpha, alpha));
      EXPECT_LE(norm, previous + 1e-5 * a.norm());
      previous = norm;
    }
  }
  EXPECT_GT(t.core(0, 0, 0), 0.0f);  // positive data, sign convention: positive hot corner
}

TEST(TensorTucker, VoxelwiseEqA5EqualsTtmEqA3) {
  const Tensor3 a = structured_tensor(12, 12);
  const Tucker t = hooi(a, {5, 4, 6});
  const Tensor3 by_ttm = reconstruct(t.core, t.factors);
  const Tensor3 by_voxel = reconstruct_voxelwise(t);
  // Same sums in a different order: float TTM rounding (~R * 6e-8 relative) dominates.
  EXPECT_LT(relative_error(by_voxel, by_ttm), 1e-5);
  EXPECT_NEAR(reconstruct_voxel(t, 3, 7, 2), by_ttm(3, 7, 2), 1e-5 * std::abs(by_ttm(3, 7, 2)) + 1e-6);
}

TEST(TensorTucker, TruncateTakesLeadingBlockAndColumns) {
  const Tensor3 a = structured_tensor(12, 13);
  const Tucker t = hooi(a, {6, 6, 6});
  const Tucker k = truncate(t, {3, 2, 4});
  EXPECT_EQ(k.ranks(), (Ranks3{3, 2, 4}));
  EXPECT_EQ(k.core(2, 1, 3), t.core(2, 1, 3));
  EXPECT_EQ(k.factors[1](11, 1), t.factors[1](11, 1));
  EXPECT_TRUE(std::isnan(k.fit));
  // The ordered core puts the energy first: the truncation keeps most of the fit.
  EXPECT_GT(tucker_fit(a, k), 0.5 * t.fit);
  EXPECT_THROW(truncate(t, {7, 1, 1}), Error);
}

TEST(TensorTucker, RejectsRanksOutsideDims) {
  const Tensor3 a = random_tensor({4, 5, 6}, 14);
  EXPECT_THROW(hosvd(a, {0, 2, 2}), Error);
  EXPECT_THROW(hosvd(a, {5, 2, 2}), Error);
  EXPECT_THROW(hooi(a, {2, 2, 7}), Error);
  EXPECT_THROW(hooi(a, {2, 2, 2}, {.max_iterations = 0}), Error);
}

TEST(TensorTucker, ZeroTensorHasPerfectFit) {
  const Tensor3 a(6, 6, 6);
  const Tucker t = hooi(a, {2, 2, 2});
  EXPECT_EQ(t.fit, 1.0);
  EXPECT_EQ(reconstruct(t.core, t.factors).norm(), 0.0);
}

}  // namespace
}  // namespace strata::tensor
