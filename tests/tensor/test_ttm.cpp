#include <gtest/gtest.h>

#include <random>

#include <Eigen/QR>

#include "strata/core/error.hpp"
#include "strata/tensor/ttm.hpp"

namespace strata::tensor {
namespace {

Tensor3d random_tensor(std::int64_t i1, std::int64_t i2, std::int64_t i3, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> dist(-1.0, 1.0);
  Tensor3d t(i1, i2, i3);
  for (double& v : t.values()) v = dist(rng);
  return t;
}

Matrix<double> random_matrix(std::int64_t rows, std::int64_t cols, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> dist(-1.0, 1.0);
  Matrix<double> m(rows, cols);
  for (Eigen::Index c = 0; c < cols; ++c)
    for (Eigen::Index r = 0; r < rows; ++r) m(r, c) = dist(rng);
  return m;
}

// Definition of the n-mode product (Kolda & Bader): y(.., j, ..) = Σ_i x(.., i, ..) u(j, i).
Tensor3d naive_ttm(const Tensor3d& x, int mode, const Matrix<double>& u) {
  Dims3 d = x.dims();
  d[std::size_t(mode - 1)] = u.rows();
  Tensor3d y(d);
  for (std::int64_t a = 0; a < d[0]; ++a)
    for (std::int64_t b = 0; b < d[1]; ++b)
      for (std::int64_t c = 0; c < d[2]; ++c) {
        double sum = 0;
        for (std::int64_t i = 0; i < x.dim(mode); ++i) {
          const double xv = mode == 1 ? x(i, b, c) : mode == 2 ? x(a, i, c) : x(a, b, i);
          const std::int64_t j = mode == 1 ? a : mode == 2 ? b : c;
          sum += xv * u(j, i);
        }
        y(a, b, c) = sum;
      }
  return y;
}

double max_abs_difference(const Tensor3d& a, const Tensor3d& b) {
  EXPECT_EQ(a.dims(), b.dims());
  double m = 0;
  for (std::int64_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(a.data()[i] - b.data()[i]));
  return m;
}

// Entries are sums of at most 7 products of values in [-1, 1]: double rounding is ~1e-15.
constexpr double kDoubleTolerance = 1e-12;

TEST(TensorTtm, MatchesNaiveTripleLoopInEveryMode) {
  const Tensor3d x = random_tensor(5, 7, 3, 1);
  for (int mode = 1; mode <= 3; ++mode) {
    const Matrix<double> u = random_matrix(4, x.dim(mode), 10 + mode);
    EXPECT_LT(max_abs_difference(ttm(x, mode, u), naive_ttm(x, mode, u)), kDoubleTolerance) << "mode " << mode;
  }
}

TEST(TensorTtm, TransposedFormEqualsProductWithTranspose) {
  const Tensor3d x = random_tensor(6, 4, 5, 2);
  for (int mode = 1; mode <= 3; ++mode) {
    const Matrix<double> u = random_matrix(x.dim(mode), 3, 20 + mode);  // a factor matrix, I_n x R
    const Matrix<double> ut = u.transpose();
    EXPECT_LT(max_abs_difference(ttm_transposed(x, mode, u), naive_ttm(x, mode, ut)), kDoubleTolerance);
  }
}

TEST(TensorTtm, MatchesUnfoldedMatrixProductEqA6) {
  const Tensor3d x = random_tensor(4, 5, 6, 3);
  for (int mode = 1; mode <= 3; ++mode) {
    const Matrix<double> u = random_matrix(3, x.dim(mode), 30 + mode);
    const Matrix<double> expected = u * unfold(x, mode);
    const Matrix<double> actual = unfold(ttm(x, mode, u), mode);
    EXPECT_LT((expected - actual).cwiseAbs().maxCoeff(), kDoubleTolerance) << "mode " << mode;
  }
}

TEST(TensorTtm, GramEqualsUnfoldingTimesItsTranspose) {
  const Tensor3 x = random_tensor(4, 6, 5, 4).cast<float>();
  for (int mode = 1; mode <= 3; ++mode) {
    const Matrix<double> unf = unfold(x, mode).cast<double>();
    EXPECT_LT((gram(x, mode) - unf * unf.transpose()).cwiseAbs().maxCoeff(), kDoubleTolerance) << "mode " << mode;
  }
}

TEST(TensorTtm, IntegerGramEqualsTheGramOfTheValues) {
  // Small integers are exact in float and their products' sums exact in double: both Grams
  // must agree bit for bit, in every mode.
  const Dims3 dims{5, 6, 7};
  std::mt19937 rng(21);
  std::uniform_int_distribution<int> value(-300, 300);
  std::vector<std::int32_t> codes(std::size_t(dims[0] * dims[1] * dims[2]));
  Tensor3 x(dims);
  for (std::size_t i = 0; i < codes.size(); ++i) x.values()[i] = float(codes[i] = value(rng));
  for (int mode = 1; mode <= 3; ++mode) {
    const std::optional<Matrix<double>> g = integer_gram(codes, dims, mode);
    ASSERT_TRUE(g.has_value()) << "mode " << mode;
    EXPECT_EQ(*g, gram(x, mode)) << "mode " << mode;
  }
}

TEST(TensorTtm, IntegerGramDeclinesValuesWhoseSumsCouldOverflow) {
  // Rows of 36: values below 2^12 pass (2^24 · 36 < 2^31); 2^13 (bound 2^14) and anything
  // beyond 16 bits do not.
  const Dims3 dims{6, 6, 6};
  std::vector<std::int32_t> codes(216, 1);
  codes[100] = -4095;
  EXPECT_TRUE(integer_gram(codes, dims, 2).has_value());
  codes[100] = 8192;
  EXPECT_FALSE(integer_gram(codes, dims, 2).has_value());
  codes[100] = -70000;
  EXPECT_FALSE(integer_gram(codes, dims, 1).has_value());
  EXPECT_THROW(integer_gram(std::span(codes).first(215), dims, 1), Error);
}

TEST(TensorTtm, ProjectThenReconstructWithOrthogonalFactorsIsIdentity) {
  const Tensor3d x = random_tensor(5, 4, 6, 5);
  Factors<double> u;
  for (std::size_t n = 0; n < 3; ++n) {
    Eigen::HouseholderQR<Matrix<double>> qr(random_matrix(x.dims()[n], x.dims()[n], 40 + unsigned(n)));
    u[n] = qr.householderQ();
  }
  EXPECT_LT(max_abs_difference(reconstruct(project(x, u), u), x), kDoubleTolerance);
}

TEST(TensorTtm, FloatProductsAgreeWithDouble) {
  const Tensor3d x = random_tensor(8, 8, 8, 6);
  const Matrix<double> u = random_matrix(8, 8, 7);
  const Tensor3d expected = ttm(x, 2, u);
  const Tensor3d actual = ttm(x.cast<float>(), 2, Matrix<float>(u.cast<float>())).cast<double>();
  // 8 products of float-rounded inputs (relative 6e-8 each) of magnitude <= 1.
  EXPECT_LT(max_abs_difference(expected, actual), 8 * 4 * 6e-8);
}

TEST(TensorTtm, RejectsBadModeAndMismatchedMatrix) {
  const Tensor3d x = random_tensor(3, 4, 5, 8);
  EXPECT_THROW(ttm(x, 0, random_matrix(2, 3, 1)), Error);
  EXPECT_THROW(ttm(x, 4, random_matrix(2, 3, 1)), Error);
  EXPECT_THROW(ttm(x, 2, random_matrix(2, 3, 1)), Error);  // mode 2 has extent 4
  EXPECT_THROW(ttm_transposed(x, 3, random_matrix(4, 2, 1)), Error);
}

}  // namespace
}  // namespace strata::tensor
