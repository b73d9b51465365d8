// The double-precision decomposition kernels (src/tensor/decompose_kernel.hpp) at every
// instruction-set level they are compiled for, against exact references, and HOSVD/HOOI run
// whole under each level against the generic run.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include <Eigen/QR>

#include "strata/tensor/tucker.hpp"
#include "support/isa_test.hpp"
#include "tensor/decompose_kernel.hpp"

namespace strata::tensor {
namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();

std::vector<double> random_values(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> dist(0.0, 1.0);
  std::vector<double> v(n);
  for (double& x : v) x = dist(rng);
  return v;
}

// A sum of k products rounded step by step is within gamma_k = k eps / (1 - k eps) of the
// exact value relative to the sum of the products' magnitudes (Higham, Thm. 3.1), whatever the
// order and whether each multiply-add rounds once (FMA) or twice. The reference is summed in
// long double, whose own error is far below that.
double gamma(std::int64_t k) { return double(k) * kEps / (1 - double(k) * kEps); }

}  // namespace

class TensorDecomposeKernelsPerIsa : public test::IsaTest {
 protected:
  const detail::DecomposeKernels& kernels() const { return detail::decompose_kernels(isa()); }
};

TEST_P(TensorDecomposeKernelsPerIsa, ReportTheirLevel) {
  EXPECT_EQ(kernels().isa, isa());
  const ScopedIsaLimit limit(isa());
  EXPECT_EQ(&detail::decompose_kernels(), &kernels());  // the limit picks them
}

TEST_P(TensorDecomposeKernelsPerIsa, GemmMatchesTheExactProduct) {
  // Shapes not a multiple of any vector width or tile, a batch of two, R read transposed.
  for (const bool lower : {false, true}) {
    const std::int64_t m = 37, n = 19, k = 23, batch = 2;
    const std::vector<double> l = random_values(std::size_t(m * k * batch), 1);
    const std::vector<double> r = random_values(std::size_t(k * n * batch), 2);
    std::vector<double> out(std::size_t(m * n * batch), 0.0);
    detail::DGemmArgs g;
    g.m = m, g.n = n, g.k = k;
    g.l = l.data(), g.ld_l = m;
    g.r = r.data(), g.r_k = n, g.r_n = 1;  // R stored row-major: the transposed read
    g.out = out.data(), g.ld_out = m;
    g.batch = batch, g.l_step = m * k, g.r_step = k * n, g.out_step = m * n;
    g.lower = lower;
    kernels().gemm(g);
    for (std::int64_t b = 0; b < batch; ++b)
      for (std::int64_t j = 0; j < n; ++j)
        for (std::int64_t i = lower ? j : 0; i < m; ++i) {
          long double exact = 0, magnitude = 0;
          for (std::int64_t p = 0; p < k; ++p) {
            const long double term = (long double)l[std::size_t(b * m * k + p * m + i)] * r[std::size_t(b * k * n + p * n + j)];
            exact += term;
            magnitude += std::fabs(term);
          }
          ASSERT_NEAR(out[std::size_t(b * m * n + j * m + i)], double(exact), gamma(k) * double(magnitude))
              << "lower " << lower << " batch " << b << " (" << i << ", " << j << ")";
        }
  }
}

TEST_P(TensorDecomposeKernelsPerIsa, GemmWidensFloatOperandsExactly) {
  // Reading L as float gives the bits of the product with L widened to double first in the
  // vector tiles; the scalar tail rows agree within the rounding bound.
  const std::int64_t m = 29, n = 7, k = 11;
  const std::vector<double> l = random_values(std::size_t(m * k), 3), r = random_values(std::size_t(k * n), 4);
  std::vector<float> l_f(l.begin(), l.end());
  const std::vector<double> l_widened(l_f.begin(), l_f.end());
  std::vector<double> from_float(std::size_t(m * n)), from_double(std::size_t(m * n));
  detail::DGemmArgs g;
  g.m = m, g.n = n, g.k = k, g.ld_l = m, g.r = r.data(), g.r_k = 1, g.r_n = k, g.ld_out = m;
  g.l_f = l_f.data(), g.out = from_float.data();
  kernels().gemm(g);
  g.l_f = nullptr, g.l = l_widened.data(), g.out = from_double.data();
  kernels().gemm(g);
  // Doubles per vector: 2 (SSE2), 4 (AVX2), 8 (AVX-512); rows below m / w * w are vector tiles.
  const std::int64_t width = isa() == Isa::avx512 ? 8 : isa() == Isa::avx2 ? 4 : 2, vector_rows = m / width * width;
  for (std::int64_t j = 0; j < n; ++j)
    for (std::int64_t i = 0; i < m; ++i) {
      const double a = from_float[std::size_t(j * m + i)], b = from_double[std::size_t(j * m + i)];
      if (i < vector_rows) {
        ASSERT_EQ(a, b) << "row " << i << " column " << j;
      } else {
        double magnitude = 0;
        for (std::int64_t p = 0; p < k; ++p) magnitude += std::abs(l_widened[std::size_t(p * m + i)] * r[std::size_t(j * k + p)]);
        ASSERT_NEAR(a, b, 2 * gamma(k) * magnitude) << "row " << i << " column " << j;
      }
    }
}

TEST_P(TensorDecomposeKernelsPerIsa, GramMatchesTheExactInnerProducts) {
  // Mode-2 Gram of a 13 x 10 x 6 tensor: 6 segments of length 13, column stride 13.
  const std::int64_t i1 = 13, i2 = 10, i3 = 6;
  const std::vector<double> x = random_values(std::size_t(i1 * i2 * i3), 5);
  std::vector<double> g(std::size_t(i2 * i2));
  detail::DGramArgs a;
  a.n = i2, a.segments = i3, a.seg_stride = i1 * i2, a.col_stride = i1, a.len = i1;
  a.x = x.data(), a.g = g.data();
  kernels().gram(a);
  for (std::int64_t p = 0; p < i2; ++p)
    for (std::int64_t q = 0; q < i2; ++q) {
      long double exact = 0, magnitude = 0;
      for (std::int64_t s = 0; s < i3; ++s)
        for (std::int64_t i = 0; i < i1; ++i) {
          const long double term =
              (long double)x[std::size_t(s * i1 * i2 + p * i1 + i)] * x[std::size_t(s * i1 * i2 + q * i1 + i)];
          exact += term;
          magnitude += std::fabs(term);
        }
      ASSERT_NEAR(g[std::size_t(q * i2 + p)], double(exact), gamma(i1 * i3) * double(magnitude)) << p << "," << q;
    }
}

TEST_P(TensorDecomposeKernelsPerIsa, IntegerGramIsExactAtTheLargestAllowedValues) {
  // 13 rows of 37 (the vector tails and the four-row groups both have remainders), values up
  // to the contract's limit max|x|^2 · len < 2^31, and a pair of rows that reaches it.
  const std::int64_t n = 13, len = 37;
  const auto limit = std::int16_t(std::sqrt(double(1u << 31) / double(len)) - 1);
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> value(-limit, limit);
  std::vector<std::int16_t> x(std::size_t(n * len));
  for (std::int16_t& v : x) v = std::int16_t(value(rng));
  for (std::int64_t i = 0; i < len; ++i) x[std::size_t(2 * len + i)] = x[std::size_t(5 * len + i)] = limit;
  std::vector<double> g(std::size_t(n * n), -1.0);
  kernels().gram_i16(x.data(), n, len, g.data());
  for (std::int64_t p = 0; p < n; ++p)
    for (std::int64_t q = 0; q < n; ++q) {
      std::int64_t exact = 0;
      for (std::int64_t i = 0; i < len; ++i) exact += std::int64_t(x[std::size_t(p * len + i)]) * x[std::size_t(q * len + i)];
      ASSERT_EQ(g[std::size_t(p + q * n)], double(exact)) << p << "," << q;
    }
}

TEST_P(TensorDecomposeKernelsPerIsa, LeadingEigenvectorsSpanTheKnownSubspace) {
  // A = Q diag(lambda) Q^T with well separated eigenvalues n, n-1, ..., 1: each computed
  // eigenvector must be +-Q's column. Perturbation theory bounds the angle by
  // ~ n eps ||A|| / gap = n^2 eps (gap 1); 1e-9 leaves ample room for n = 24.
  const std::int64_t n = 24, r = 7;
  const std::vector<double> random = random_values(std::size_t(n * n), 6);
  const Eigen::Map<const Eigen::MatrixXd> m(random.data(), n, n);
  const Eigen::MatrixXd q = Eigen::HouseholderQR<Eigen::MatrixXd>(m).householderQ();
  Eigen::VectorXd lambda(n);
  for (std::int64_t i = 0; i < n; ++i) lambda[i] = double(n - i);
  Eigen::MatrixXd a = q * lambda.asDiagonal() * q.transpose();
  Eigen::MatrixXd u(n, r);
  std::vector<double> work(std::size_t(detail::leading_eigen_work(n)));
  ASSERT_TRUE(kernels().leading_eigen(a.data(), n, r, u.data(), work.data()));
  for (std::int64_t c = 0; c < r; ++c) EXPECT_NEAR(std::abs(u.col(c).dot(q.col(c))), 1.0, 1e-9) << "column " << c;
  EXPECT_NEAR((u.transpose() * u - Eigen::MatrixXd::Identity(r, r)).norm(), 0.0, 1e-12);
}

TEST_P(TensorDecomposeKernelsPerIsa, SumOfSquaresMatchesTheExactSum) {
  for (const std::int64_t n : {std::int64_t(1), std::int64_t(7), std::int64_t(1001)}) {
    const std::vector<double> x = random_values(std::size_t(n), 7);
    const std::vector<float> x_f(x.begin(), x.end());
    long double exact = 0, exact_f = 0;
    for (std::int64_t i = 0; i < n; ++i) {
      exact += (long double)x[std::size_t(i)] * x[std::size_t(i)];
      exact_f += (long double)x_f[std::size_t(i)] * x_f[std::size_t(i)];
    }
    EXPECT_NEAR(kernels().sum_squares(x.data(), n), double(exact), gamma(n) * double(exact)) << n;
    EXPECT_NEAR(kernels().sum_squares_f(x_f.data(), n), double(exact_f), gamma(n) * double(exact_f)) << n;
  }
}

TEST_P(TensorDecomposeKernelsPerIsa, HooiUnderTheLimitFitsLikeTheGenericRun) {
  // The whole decomposition under each level: the same model up to rounding, so the fits agree
  // far more closely than the 1e-6 relative difference asserted.
  Tensor3 t(20, 18, 16);
  std::mt19937 rng(8);
  std::normal_distribution<float> noise(0.0f, 0.05f);
  for (std::int64_t z = 0; z < 16; ++z)
    for (std::int64_t y = 0; y < 18; ++y)
      for (std::int64_t x = 0; x < 20; ++x)
        t(x, y, z) = std::sin(0.3f * float(x)) * std::cos(0.2f * float(y + z)) + noise(rng);
  auto fit_under = [&](Isa level) {
    const ScopedIsaLimit limit(level);
    return hooi(t, {6, 6, 6}).fit;
  };
  const double generic = fit_under(Isa::generic), wide = fit_under(isa());
  EXPECT_NEAR(wide, generic, 1e-6 * std::abs(generic));
  EXPECT_GT(generic, 0.5);
}

STRATA_INSTANTIATE_PER_ISA(TensorDecomposeKernelsPerIsa, Isa::generic, Isa::avx2, Isa::avx512);

}  // namespace strata::tensor
