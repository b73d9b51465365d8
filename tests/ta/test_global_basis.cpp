// Global bases (ta/global_basis.hpp, paper 2): the streamed HOOI recovers an exactly low-rank
// volume, does not depend on how the volume is cut into slabs, never loses fit from sweep to
// sweep and fits at least as well as the in-memory truncated HOSVD; halved factors reconstruct
// the 2×2×2 average; row-block bases are orthonormal and span their row block; a brick of any
// level projected on its bases keeps what the global model holds, and the feature-scale table
// never claims less error than a rank has.
#include <gtest/gtest.h>

#include <random>

#include <Eigen/QR>

#include "strata/ta/global_basis.hpp"
#include "strata/tensor/ttm.hpp"
#include "strata/tensor/tucker.hpp"
#include "ta/ta_test_util.hpp"

namespace strata::ta {
namespace {

using testing::MemorySource;
using tensor::Matrix;

Matrix<double> random_orthonormal(std::int64_t rows, int cols, std::mt19937_64& rng) {
  std::normal_distribution<double> normal;
  Matrix<double> g(rows, cols);
  for (std::int64_t i = 0; i < g.size(); ++i) g.data()[i] = normal(rng);
  Eigen::HouseholderQR<Matrix<double>> qr(g);
  return qr.householderQ() * Matrix<double>::Identity(rows, cols);
}

// core ×1 U1 ×2 U2 ×3 U3 as an f32 Volume (x fastest).
Volume volume_of(const tensor::Tensor3d& core, const tensor::Factors<double>& u) {
  const tensor::Tensor3d a = tensor::reconstruct(core, u);
  Volume v(Extent{a.dim(1), a.dim(2), a.dim(3)}, DType::f32);
  auto s = v.samples<float>();
  for (std::size_t i = 0; i < s.size(); ++i) s[i] = float(a.data()[i]);
  return v;
}

tensor::Tensor3d random_core(int r, std::mt19937_64& rng) {
  std::normal_distribution<double> normal;
  tensor::Tensor3d core(r, r, r);
  for (std::int64_t i = 0; i < core.size(); ++i) core.data()[i] = normal(rng) * 10.0 / double(1 + i % 7);
  return core;
}

double orthonormality_error(const Matrix<double>& u) {
  return (u.transpose() * u - Matrix<double>::Identity(u.cols(), u.cols())).cwiseAbs().maxCoeff();
}

TEST(TaGlobalBasis, RecoversAnExactlyLowRankVolume) {
  std::mt19937_64 rng(3);
  const int r = 4;
  const tensor::Factors<double> truth{random_orthonormal(40, r, rng), random_orthonormal(36, r, rng),
                                      random_orthonormal(28, r, rng)};
  MemorySource source(volume_of(random_core(r, rng), truth));
  GlobalFitOptions o;
  o.rank = r;
  ProgressSink& quiet = silent_progress();
  const GlobalFit fit = fit_global_factors(source, o, quiet);
  // The volume is rank (4,4,4) up to float storage (relative 6e-8 per sample), so the fit is 1
  // within that, and each factor spans the true subspace.
  EXPECT_GT(fit.fit(), 1 - 1e-5);
  for (int n = 0; n < 3; ++n) {
    const auto& u = fit.factors[std::size_t(n)];
    EXPECT_LT(orthonormality_error(u), 1e-10) << n;
    const Matrix<double> residual = truth[std::size_t(n)] - u * (u.transpose() * truth[std::size_t(n)]);
    EXPECT_LT(residual.cwiseAbs().maxCoeff(), 1e-4) << n;
  }
}

TEST(TaGlobalBasis, SlabSizeChangesNothingButTheOrderOfSums) {
  MemorySource source(testing::prisms({30, 26, 22}));
  GlobalFitOptions whole;
  whole.rank = 6;
  whole.max_sweeps = 2;
  whole.tolerance = 0;
  GlobalFitOptions sliced = whole;
  sliced.slab_bytes = 1;  // one slice per step
  ProgressSink& quiet = silent_progress();
  const GlobalFit a = fit_global_factors(source, whole, quiet), b = fit_global_factors(source, sliced, quiet);
  EXPECT_EQ(a.passes, 6);
  EXPECT_NEAR(a.fit(), b.fit(), 1e-9);
  for (int n = 0; n < 3; ++n)
    EXPECT_LT((a.factors[std::size_t(n)] - b.factors[std::size_t(n)]).cwiseAbs().maxCoeff(), 1e-6) << n;
}

TEST(TaGlobalBasis, FitNeverDecreasesAndMatchesTheInMemoryDecomposition) {
  const Volume v = testing::prisms({32, 28, 24}, 11);
  MemorySource source(v);
  ProgressSink& quiet = silent_progress();
  tensor::Tensor3 a(32, 28, 24);
  std::copy(v.samples<std::uint16_t>().begin(), v.samples<std::uint16_t>().end(), a.data());
  const tensor::Ranks3 ranks{8, 8, 8};
  const double hosvd = tensor::tucker_fit(a, tensor::hosvd(a, ranks));
  for (GlobalInit init : {GlobalInit::dct, GlobalInit::random}) {
    GlobalFitOptions o;
    o.rank = 8;
    o.max_sweeps = 5;
    o.tolerance = 0;
    o.init = init;
    const GlobalFit fit = fit_global_factors(source, o, quiet);
    ASSERT_EQ(fit.fit_per_sweep.size(), 5u);
    // Each HOOI update solves its mode exactly with the others fixed, so the fit cannot drop
    // (up to the rounding of float slabs, ~1e-7 relative).
    for (std::size_t s = 1; s < fit.fit_per_sweep.size(); ++s)
      EXPECT_GE(fit.fit_per_sweep[s], fit.fit_per_sweep[s - 1] - 1e-7) << s;
    // The truncated HOSVD is HOOI's usual starting point and a lower bound in practice.
    EXPECT_GE(fit.fit(), hosvd - 1e-4) << int(init);
    // The reported fit is that of the factors: the projection's own residual agrees.
    const tensor::Factors<float> uf{fit.factors[0].cast<float>(), fit.factors[1].cast<float>(),
                                    fit.factors[2].cast<float>()};
    tensor::Tucker model;
    model.factors = uf;
    model.core = tensor::project(a, uf);
    EXPECT_NEAR(tensor::tucker_fit(a, model), fit.fit(), 1e-4) << int(init);
  }
}

TEST(TaGlobalBasis, HalvedFactorsReconstructTheAverageOfTheFinerLevel) {
  std::mt19937_64 rng(5);
  const tensor::Factors<double> u{random_orthonormal(9, 3, rng), random_orthonormal(8, 3, rng),
                                  random_orthonormal(7, 3, rng)};
  const tensor::Tensor3d core = random_core(3, rng);
  const tensor::Tensor3d fine = tensor::reconstruct(core, u);
  const tensor::Tensor3d coarse = tensor::reconstruct(core, {halve_rows(u[0]), halve_rows(u[1]), halve_rows(u[2])});
  ASSERT_EQ(coarse.dim(1), 5);  // ceil(9 / 2): the odd edge voxel is averaged with itself
  ASSERT_EQ(coarse.dim(3), 4);
  for (std::int64_t z = 0; z < coarse.dim(3); ++z)
    for (std::int64_t y = 0; y < coarse.dim(2); ++y)
      for (std::int64_t x = 0; x < coarse.dim(1); ++x) {
        double sum = 0;
        for (int k = 0; k < 8; ++k)
          sum += fine(std::min(2 * x + (k & 1), fine.dim(1) - 1), std::min(2 * y + (k >> 1 & 1), fine.dim(2) - 1),
                      std::min(2 * z + (k >> 2), fine.dim(3) - 1));
        EXPECT_NEAR(coarse(x, y, z), sum / 8, 1e-12) << x << "," << y << "," << z;
      }
  const auto mip = mipmap_factor(u[0], 4);
  ASSERT_EQ(mip.size(), 4u);
  EXPECT_EQ(mip[3].rows(), 2);  // 9 -> 5 -> 3 -> 2
}

TEST(TaGlobalBasis, RowBlocksAreOrthonormalAndSpanTheirRows) {
  std::mt19937_64 rng(9);
  const Matrix<double> u = random_orthonormal(50, 6, rng);
  for (std::int64_t first : {-2, 0, 20, 40}) {  // before the first row, inside, past the last
    const Matrix<double> q = row_block_basis(u, first, 12);
    ASSERT_EQ(q.rows(), 12);
    ASSERT_EQ(q.cols(), 6);
    EXPECT_LT(orthonormality_error(q), 1e-12) << first;
    Matrix<double> block(12, 6);
    for (int j = 0; j < 12; ++j) block.row(j) = u.row(std::clamp<std::int64_t>(first + j, 0, 49));
    EXPECT_LT((block - q * (q.transpose() * block)).cwiseAbs().maxCoeff(), 1e-12) << first;
  }
  // Fewer rows than columns: the basis has as many columns as rows.
  EXPECT_EQ(row_block_basis(u, 0, 4).cols(), 4);
}

// The brick's samples (B³, overlap included, clamped at the edges) of `level` volume `v`.
tensor::Tensor3 brick_samples(const tensor::Tensor3d& v, const OctreeGeometry& g, int level, std::int64_t bx,
                              std::int64_t by, std::int64_t bz) {
  const Box box = g.brick_sample_box(level, bx, by, bz);
  const int b = g.layout().brick;
  tensor::Tensor3 out(b, b, b);
  for (int z = 0; z < b; ++z)
    for (int y = 0; y < b; ++y)
      for (int x = 0; x < b; ++x)
        out(x, y, z) = float(v(std::clamp<std::int64_t>(box.lo.x + x, 0, v.dim(1) - 1),
                               std::clamp<std::int64_t>(box.lo.y + y, 0, v.dim(2) - 1),
                               std::clamp<std::int64_t>(box.lo.z + z, 0, v.dim(3) - 1)));
  return out;
}

// Every brick of every level of an exactly rank-(4,4,4) volume is rebuilt from its core: level
// l's samples are the model with factors halved l times, whose rows (clamped) are what the
// brick's bases span.
TEST(TaGlobalBasis, BricksOfEveryLevelProjectOntoTheirBasesExactly) {
  std::mt19937_64 rng(21);
  const int r = 4;
  const tensor::Factors<double> truth{random_orthonormal(40, r, rng), random_orthonormal(36, r, rng),
                                      random_orthonormal(28, r, rng)};
  const tensor::Tensor3d core = random_core(r, rng);
  const OctreeGeometry geometry({40, 36, 28}, {16, 2});
  ASSERT_EQ(geometry.level_count(), 3);
  const GlobalBases bases(truth, geometry);
  tensor::Factors<double> level_factors = truth;
  for (int l = 0; l < geometry.level_count(); ++l) {
    const tensor::Tensor3d level = tensor::reconstruct(core, level_factors);
    const Extent& grid = geometry.level(l).bricks;
    for (std::int64_t bz = 0; bz < grid.z; ++bz)
      for (std::int64_t by = 0; by < grid.y; ++by)
        for (std::int64_t bx = 0; bx < grid.x; ++bx) {
          const auto q = bases.brick_bases(l, bx, by, bz);
          for (const auto* m : q) {
            ASSERT_EQ(m->rows(), 16);
            ASSERT_EQ(m->cols(), r);
            EXPECT_LT(orthonormality_error(m->cast<double>()), 1e-6);  // float storage
          }
          const tensor::Tensor3 samples = brick_samples(level, geometry, l, bx, by, bz);
          const tensor::Tensor3 rebuilt =
              tensor::reconstruct(project_brick(samples, q), tensor::Factors<float>{*q[0], *q[1], *q[2]});
          double worst = 0;
          for (std::int64_t i = 0; i < samples.size(); ++i)
            worst = std::max(worst, double(std::abs(rebuilt.data()[i] - samples.data()[i])));
          EXPECT_LT(worst, 1e-4 * (1 + samples.norm() / std::sqrt(double(samples.size()))))
              << "level " << l << " brick " << bx << "," << by << "," << bz;
        }
    for (auto& u : level_factors) u = halve_rows(u);
  }
  EXPECT_EQ(test::parameter_of([&] { bases.basis(3, 1, 0); }), "level");
  EXPECT_EQ(test::parameter_of([&] { bases.basis(0, 1, 4); }), "index");  // 40 voxels: 4 bricks of 12
}

TEST(TaGlobalBasis, FeatureScaleTableNeverClaimsLessErrorThanARankHas) {
  const Volume v = testing::prisms({40, 36, 30}, 4);
  MemorySource source(v);
  GlobalFitOptions o;
  o.rank = 12;
  const GlobalFit fit = fit_global_factors(source, o, silent_progress());
  const OctreeGeometry geometry({40, 36, 30}, {16, 2});
  const GlobalBases bases(fit.factors, geometry);
  tensor::Tensor3d level0(40, 36, 30);
  std::copy(v.samples<std::uint16_t>().begin(), v.samples<std::uint16_t>().end(), level0.data());
  const std::vector<int> ladder{2, 4, 8, 12};
  const Box whole{{0, 0, 0}, {16, 16, 16}};
  for (std::int64_t bx = 0; bx < 3; ++bx) {
    const auto q = bases.brick_bases(0, bx, 1, 1);
    const tensor::Tensor3 samples = brick_samples(level0, geometry, 0, bx, 1, 1);
    const tensor::Tensor3 core = project_brick(samples, q);
    const Box inner = geometry.brick_core_box(0, bx, 1, 1);
    const Box region{{2, 2, 2}, {2 + inner.size().x, 2 + inner.size().y, 2 + inner.size().z}};
    const auto table = rank_ladder_rmse(samples, core, q, region, ladder);
    ASSERT_EQ(table.size(), ladder.size());
    for (std::size_t i = 0; i < ladder.size(); ++i) {
      // The RMSE of rank ladder[i] alone, computed here without the table's rule.
      const auto alone = rank_ladder_rmse(samples, core, q, region, {ladder[i]});
      EXPECT_GE(table[i], alone[0] - 1e-9) << i;
      if (i + 1 < ladder.size()) {
        EXPECT_GE(table[i], table[i + 1]) << i;
      }
    }
    EXPECT_EQ(table.back(), rank_ladder_rmse(samples, core, q, region, {12})[0]);
    EXPECT_GT(table.front(), table.back());  // rank 2 of a prisms brick loses detail
    // Over the whole brick, nested projections never lose accuracy: the rule changes nothing.
    const auto full = rank_ladder_rmse(samples, core, q, whole, ladder);
    for (std::size_t i = 0; i < ladder.size(); ++i)
      EXPECT_NEAR(full[i], rank_ladder_rmse(samples, core, q, whole, {ladder[i]})[0], 1e-3 * full[i] + 1e-6) << i;
  }
}

TEST(TaGlobalBasis, BadOptionsAreNamed) {
  MemorySource source(testing::prisms({8, 8, 8}));
  ProgressSink& quiet = silent_progress();
  GlobalFitOptions o;
  o.rank = 0;
  EXPECT_EQ(test::parameter_of([&] { fit_global_factors(source, o, quiet); }), "GlobalFitOptions::rank");
  o = {};
  o.max_sweeps = 0;
  EXPECT_EQ(test::parameter_of([&] { fit_global_factors(source, o, quiet); }), "GlobalFitOptions::max_sweeps");
}

}  // namespace
}  // namespace strata::ta
