#include "strata/tensor/tucker.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>

#include "strata/tensor/ttm.hpp"

namespace strata {

void check_ranks(const Dims3& dims, const Ranks3& ranks, const char* context) {
  for (std::size_t n = 0; n < 3; ++n) {
    if (ranks[n] < 1 || ranks[n] > dims[n]) {
      throw Error(std::string(context) + ": rank R" + std::to_string(n + 1) + " = " + std::to_string(ranks[n]) +
                  " must be in [1, " + std::to_string(dims[n]) + "] for a " + to_string(dims) + " tensor");
    }
  }
}

namespace {

using MatrixD = Matrix<double>;
using FactorsD = Factors<double>;

// Makes each column's largest-magnitude entry positive: singular vectors are defined only up
// to sign, and a fixed choice makes results reproducible across platforms and solvers.
void fix_signs(MatrixD& u) {
  for (Eigen::Index c = 0; c < u.cols(); ++c) {
    Eigen::Index at = 0;
    u.col(c).cwiseAbs().maxCoeff(&at);
    if (u(at, c) < 0) u.col(c) = -u.col(c);
  }
}

// The r leading eigenvectors of a symmetric positive semi-definite matrix. Eigen returns the
// eigenvalues in increasing order, so the leading vectors are the last columns, reversed.
MatrixD leading_eigenvectors(const MatrixD& g, int r) {
  Eigen::SelfAdjointEigenSolver<MatrixD> solver(g);
  if (solver.info() != Eigen::Success) throw Error("hosvd: eigen-decomposition of the Gram matrix failed");
  return solver.eigenvectors().rightCols(r).rowwise().reverse();
}

// The r leading left singular vectors of the mode-n unfolding X_(n) (I_n x J).
// Wide unfolding (I_n <= J, every brick): the I_n x I_n Gram matrix costs I_n^2 J and its
// eigen-decomposition I_n^3, far less than an SVD of the I_n x J matrix. Tall unfolding with
// r <= J: a thin SVD of X_(n) costs I_n J^2 and avoids squaring the condition number. Tall with
// r > J: X_(n) has rank <= J, so any orthonormal completion is optimal; the Gram eigenvectors
// provide one.
MatrixD leading_left_singular_vectors(const Tensor3d& x, int mode, int r) {
  const std::int64_t rows = x.dim(mode);
  const std::int64_t cols = rows == 0 ? 0 : x.size() / rows;
  MatrixD u;
  if (rows > cols && r <= cols) {
    Eigen::BDCSVD<MatrixD> svd(unfold(x, mode), Eigen::ComputeThinU);
    u = svd.matrixU().leftCols(r);
  } else {
    u = leading_eigenvectors(gram(x, mode), r);
  }
  fix_signs(u);
  return u;
}

// ‖A - Ã‖ = sqrt(‖A‖² - ‖B‖²) when the factors are orthonormal and B is the projection of A.
// The difference is clamped at 0 because rounding can make it slightly negative at full rank.
double fit_from_norms(double norm_a, double norm_core) {
  if (norm_a == 0) return 1.0;
  const double residual_sq = std::max(norm_a * norm_a - norm_core * norm_core, 0.0);
  return 1.0 - std::sqrt(residual_sq) / norm_a;
}

Tucker to_float_model(const Tensor3d& core, const FactorsD& u, double fit, int iterations) {
  Tucker t;
  t.core = core.cast<float>();
  for (std::size_t n = 0; n < 3; ++n) t.factors[n] = u[n].cast<float>();
  t.fit = fit;
  t.iterations = iterations;
  return t;
}

FactorsD hosvd_factors(const Tensor3d& a, const Ranks3& ranks) {
  FactorsD u;
  for (int n = 1; n <= 3; ++n) u[std::size_t(n - 1)] = leading_left_singular_vectors(a, n, ranks[std::size_t(n - 1)]);
  return u;
}

// One HOOI sweep: each factor becomes the leading left singular vectors of A projected on the
// other two (current) factors. A ×3 U3^T is shared by the updates of U1 and U2, because U3 only
// changes last. Returns the core of the updated factors.
Tensor3d hooi_sweep(const Tensor3d& a, const Ranks3& ranks, FactorsD& u) {
  const Tensor3d a3 = ttm_transposed(a, 3, u[2]);
  u[0] = leading_left_singular_vectors(ttm_transposed(a3, 2, u[1]), 1, ranks[0]);
  u[1] = leading_left_singular_vectors(ttm_transposed(a3, 1, u[0]), 2, ranks[1]);
  const Tensor3d a12 = ttm_transposed(ttm_transposed(a, 1, u[0]), 2, u[1]);
  u[2] = leading_left_singular_vectors(a12, 3, ranks[2]);
  return ttm_transposed(a12, 3, u[2]);
}

// Rotates (core, U) by the full HOSVD of the core: core' = core ×n V_n^T, U_n' = U_n V_n with
// square orthogonal V_n. The product is unchanged; the new core is all-orthogonal with
// decreasing slice norms, so leading-rank truncation drops the weakest components first.
void order_by_core_hosvd(Tensor3d& core, FactorsD& u) {
  const Ranks3 full{int(core.dims()[0]), int(core.dims()[1]), int(core.dims()[2])};
  const FactorsD v = hosvd_factors(core, full);
  core = project(core, v);
  for (std::size_t n = 0; n < 3; ++n) u[n] = u[n] * v[n];
}

}  // namespace

Tucker hosvd(const Tensor3& a, const Ranks3& ranks) {
  check_ranks(a.dims(), ranks, "hosvd");
  const Tensor3d ad = a.cast<double>();
  const FactorsD u = hosvd_factors(ad, ranks);
  const Tensor3d core = project(ad, u);
  return to_float_model(core, u, fit_from_norms(ad.norm(), core.norm()), 0);
}

Tucker hooi(const Tensor3& a, const Ranks3& ranks, const HooiOptions& options) {
  check_ranks(a.dims(), ranks, "hooi");
  if (options.max_iterations < 1) throw Error("hooi: max_iterations must be at least 1");
  const Tensor3d ad = a.cast<double>();
  const double norm_a = ad.norm();
  FactorsD u = hosvd_factors(ad, ranks);
  double fit = fit_from_norms(norm_a, project(ad, u).norm());
  Tensor3d core;
  int sweeps = 0;
  while (sweeps < options.max_iterations) {
    core = hooi_sweep(ad, ranks, u);
    ++sweeps;
    const double new_fit = fit_from_norms(norm_a, core.norm());
    const bool converged = std::abs(new_fit - fit) < options.tolerance;
    fit = new_fit;
    if (converged) break;
  }
  if (options.order_core) order_by_core_hosvd(core, u);
  return to_float_model(core, u, fit, sweeps);
}

Tucker truncate(const Tucker& model, const Ranks3& ranks) {
  check_ranks(model.core.dims(), ranks, "truncate");
  Tucker t;
  t.core = Tensor3(ranks[0], ranks[1], ranks[2]);
  for (int r3 = 0; r3 < ranks[2]; ++r3)
    for (int r2 = 0; r2 < ranks[1]; ++r2)
      for (int r1 = 0; r1 < ranks[0]; ++r1) t.core(r1, r2, r3) = model.core(r1, r2, r3);
  for (std::size_t n = 0; n < 3; ++n) t.factors[n] = model.factors[n].leftCols(ranks[n]);
  t.fit = std::numeric_limits<double>::quiet_NaN();
  t.iterations = model.iterations;
  return t;
}

double tucker_fit(const Tensor3& a, const Tucker& model) {
  const Tensor3 approx = reconstruct(model.core, model.factors);
  if (approx.dims() != a.dims()) {
    throw Error("tucker_fit: model reconstructs " + to_string(approx.dims()) + ", tensor is " + to_string(a.dims()));
  }
  double err = 0, ref = 0;
  for (std::int64_t i = 0; i < a.size(); ++i) {
    const double d = double(a.data()[i]) - double(approx.data()[i]);
    err += d * d;
    ref += double(a.data()[i]) * double(a.data()[i]);
  }
  if (ref == 0) return err == 0 ? 1.0 : -std::numeric_limits<double>::infinity();
  return 1.0 - std::sqrt(err / ref);
}

double reconstruct_voxel(const Tucker& model, std::int64_t i1, std::int64_t i2, std::int64_t i3) {
  const Ranks3 r = model.ranks();
  const auto& [u1, u2, u3] = model.factors;
  double sum = 0;
  for (int r3 = 0; r3 < r[2]; ++r3)
    for (int r2 = 0; r2 < r[1]; ++r2)
      for (int r1 = 0; r1 < r[0]; ++r1)
        sum += double(model.core(r1, r2, r3)) * double(u1(i1, r1)) * double(u2(i2, r2)) * double(u3(i3, r3));
  return sum;
}

Tensor3 reconstruct_voxelwise(const Tucker& model) {
  const Dims3 d = model.dims();
  Tensor3 out(d);
  for (std::int64_t i3 = 0; i3 < d[2]; ++i3)
    for (std::int64_t i2 = 0; i2 < d[1]; ++i2)
      for (std::int64_t i1 = 0; i1 < d[0]; ++i1) out(i1, i2, i3) = float(reconstruct_voxel(model, i1, i2, i3));
  return out;
}

}  // namespace strata
