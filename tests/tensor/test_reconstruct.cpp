#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <Eigen/QR>

#include "strata/tensor/reconstruct.hpp"
#include "support/isa_test.hpp"
#include "strata/tensor/ttm.hpp"

namespace strata::tensor {
namespace {

// A random model with orthonormal factors and a core whose entries decay away from the hot
// corner, like a real brick's.
Tucker random_model(const Dims3& d, const Ranks3& r, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> dist(0.0, 1.0);
  Tucker t;
  t.core = Tensor3(r[0], r[1], r[2]);
  for (int k = 0; k < r[2]; ++k)
    for (int j = 0; j < r[1]; ++j)
      for (int i = 0; i < r[0]; ++i) t.core(i, j, k) = float(dist(rng) * 100.0 / (1 + i + j + k));
  for (std::size_t n = 0; n < 3; ++n) {
    Matrix<double> m(d[n], r[n]);
    for (Eigen::Index c = 0; c < m.cols(); ++c)
      for (Eigen::Index i = 0; i < m.rows(); ++i) m(i, c) = dist(rng);
    Eigen::HouseholderQR<Matrix<double>> qr(m);
    t.factors[n] = (qr.householderQ() * Matrix<double>::Identity(d[n], r[n])).cast<float>();
  }
  return t;
}

// Reference: the truncated model through the double-precision Eigen path.
Tensor3d reference(const Tucker& model, const Ranks3& k) {
  const Tucker t = truncate(model, k);
  Factors<double> u;
  for (std::size_t n = 0; n < 3; ++n) u[n] = t.factors[n].cast<double>();
  return reconstruct(t.core.cast<double>(), u);
}

// Each output is a sum of K1 K2 K3 terms formed in three float stages of at most R terms;
// rounding is ~R * 2^-24 relative to the magnitude of the partial sums, i.e. to ‖B‖ for
// orthonormal factors. 1e-5 * ‖B‖ leaves an order of magnitude of headroom.
void expect_close(const Tensor3& actual, const Tensor3d& expected, double core_norm) {
  double worst = 0;
  for (std::int64_t i = 0; i < actual.size(); ++i)
    worst = std::max(worst, std::abs(double(actual.data()[i]) - expected.data()[i]));
  EXPECT_LT(worst, 1e-5 * core_norm);
}

}  // namespace

// The reconstruction kernel, per instruction-set level it is compiled for (generic included:
// every level is compared with the double-precision reference).
class TensorReconstructPerIsa : public test::IsaTest {};

TEST_P(TensorReconstructPerIsa, MatchesReferenceForPaperBrick) {
  const ScopedIsaLimit limit(isa());
  const Tucker model = random_model({32, 32, 32}, {16, 16, 16}, 1);
  BrickReconstructor rec;
  for (const Ranks3& k : {Ranks3{16, 16, 16}, Ranks3{8, 8, 8}, Ranks3{5, 11, 3}, Ranks3{1, 1, 1}}) {
    SCOPED_TRACE("K=" + std::to_string(k[0]) + "," + std::to_string(k[1]) + "," + std::to_string(k[2]));
    expect_close(rec.reconstruct(model, k), reference(model, k), model.core.norm());
  }
}

// Extents that are not multiples of any vector width exercise the vector and scalar row tails
// and the halving column blocks.
TEST_P(TensorReconstructPerIsa, HandlesOddExtentsAndRanks) {
  const ScopedIsaLimit limit(isa());
  const Tucker model = random_model({17, 9, 23}, {7, 9, 5}, 2);
  BrickReconstructor rec;
  expect_close(rec.reconstruct(model, {7, 9, 5}), reference(model, {7, 9, 5}), model.core.norm());
  expect_close(rec.reconstruct(model, {3, 2, 4}), reference(model, {3, 2, 4}), model.core.norm());
}

STRATA_INSTANTIATE_PER_ISA(TensorReconstructPerIsa, Isa::generic, Isa::avx2, Isa::avx512);

namespace {

// Random samples and an orthonormal basis (e_n x r_n) per mode.
Tensor3 random_brick(const Dims3& d, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> dist(0.0f, 10.0f);
  Tensor3 x(d);
  for (float& v : x.values()) v = dist(rng);
  return x;
}

// The reference core of the box in double: the box copied out, then three Eigen products.
Tensor3d reference_projection(const Tensor3& x, const Dims3& lo, const Factors<float>& u) {
  Tensor3d box(u[0].rows(), u[1].rows(), u[2].rows());
  for (std::int64_t k = 0; k < box.dims()[2]; ++k)
    for (std::int64_t j = 0; j < box.dims()[1]; ++j)
      for (std::int64_t i = 0; i < box.dims()[0]; ++i) box(i, j, k) = x(lo[0] + i, lo[1] + j, lo[2] + k);
  Factors<double> ud;
  for (std::size_t n = 0; n < 3; ++n) ud[n] = u[n].cast<double>();
  return project(box, ud);
}

}  // namespace

// The projection (the encoder's analysis transform) on the same kernels: a box inside a brick,
// ranks that fill the padded rows and ranks that do not.
class TensorProjectPerIsa : public test::IsaTest {};

TEST_P(TensorProjectPerIsa, MatchesTheReferenceOnABoxOfABrick) {
  const ScopedIsaLimit limit(isa());
  const Tensor3 x = random_brick({32, 32, 32}, 7);
  BrickProjector projector;
  for (const Ranks3& r : {Ranks3{28, 28, 28}, Ranks3{5, 13, 7}, Ranks3{16, 1, 28}}) {
    SCOPED_TRACE("R=" + std::to_string(r[0]) + "," + std::to_string(r[1]) + "," + std::to_string(r[2]));
    const Tucker bases = random_model({28, 28, 28}, r, 8);
    TuckerView view = view_of(bases);
    view.core = nullptr;  // not read
    Tensor3 core;
    projector.project(x.values(), x.dims(), {2, 2, 2}, view, core);
    const Tensor3d expected = reference_projection(x, {2, 2, 2}, bases.factors);
    ASSERT_EQ(core.dims(), expected.dims());
    // Each coefficient is a sum of 28^3 products formed in three float stages of 28 terms: with
    // orthonormal bases the partial sums stay below the box's norm, so rounding stays below
    // 3 · 28 · 2^-24 ≈ 5e-6 of it.
    double box_norm = 0;
    for (std::int64_t k = 2; k < 30; ++k)
      for (std::int64_t j = 2; j < 30; ++j)
        for (std::int64_t i = 2; i < 30; ++i) box_norm += double(x(i, j, k)) * x(i, j, k);
    box_norm = std::sqrt(box_norm);
    double worst = 0;
    for (std::int64_t i = 0; i < core.size(); ++i)
      worst = std::max(worst, std::abs(double(core.data()[i]) - expected.data()[i]));
    EXPECT_LT(worst, 1e-5 * box_norm);
    EXPECT_GT(expected.norm(), 1e-3 * box_norm);  // a real projection, not an empty one
  }
}

STRATA_INSTANTIATE_PER_ISA(TensorProjectPerIsa, Isa::generic, Isa::avx2, Isa::avx512);

// The FMA variants round each multiply-add once, the generic one twice: over a 32^3 brick some
// voxel differs in its last bits, which shows the limit really switched kernels (the same
// reconstructor object, so the choice is made per call).
class TensorReconstructFmaPerIsa : public test::IsaTest {};

TEST_P(TensorReconstructFmaPerIsa, TheLimitSelectsTheVariant) {
  const Tucker model = random_model({32, 32, 32}, {16, 16, 16}, 6);
  BrickReconstructor rec;
  auto run = [&](Isa level) {
    const ScopedIsaLimit limit(level);
    return rec.reconstruct(model, {16, 16, 16});
  };
  const Tensor3 wide = run(isa()), generic = run(Isa::generic);
  EXPECT_FALSE(std::equal(wide.values().begin(), wide.values().end(), generic.values().begin()));
}

STRATA_INSTANTIATE_PER_ISA(TensorReconstructFmaPerIsa, Isa::avx2, Isa::avx512);

namespace {

TEST(TensorBrickReconstructor, ReusesScratchAcrossBricksOfDifferentSizes) {
  BrickReconstructor rec;
  const Tucker big = random_model({32, 32, 32}, {16, 16, 16}, 3);
  const Tucker small = random_model({8, 8, 8}, {4, 4, 4}, 4);
  std::vector<float> out_big(32 * 32 * 32), out_small(8 * 8 * 8);
  rec.reconstruct(view_of(big), out_big);
  rec.reconstruct(view_of(small), out_small);
  rec.reconstruct(view_of(big), {8, 8, 8}, out_big);
  Tensor3 again(32, 32, 32);
  rec.reconstruct(view_of(big), {8, 8, 8}, again.values());
  EXPECT_TRUE(std::equal(out_big.begin(), out_big.end(), again.values().begin()));
  Tensor3 small_tensor(8, 8, 8);
  std::copy(out_small.begin(), out_small.end(), small_tensor.values().begin());
  expect_close(small_tensor, reference(small, {4, 4, 4}), small.core.norm());
}

TEST(TensorBrickReconstructor, RejectsBadRanksAndBufferSizes) {
  const Tucker model = random_model({8, 8, 8}, {4, 4, 4}, 5);
  BrickReconstructor rec;
  std::vector<float> out(8 * 8 * 8);
  EXPECT_THROW(rec.reconstruct(view_of(model), {5, 4, 4}, out), Error);
  EXPECT_THROW(rec.reconstruct(view_of(model), {0, 4, 4}, out), Error);
  std::vector<float> short_out(100);
  EXPECT_THROW(rec.reconstruct(view_of(model), short_out), Error);
  TuckerView broken = view_of(model);
  broken.core = nullptr;
  EXPECT_THROW(rec.reconstruct(broken, out), Error);
}

TEST(TensorBrickProjector, RejectsABoxOutsideTheBrickAndMissingBases) {
  const Tensor3 x = random_brick({8, 8, 8}, 9);
  const Tucker bases = random_model({6, 6, 6}, {3, 3, 3}, 10);
  BrickProjector projector;
  Tensor3 core;
  EXPECT_THROW(projector.project(x.values(), x.dims(), {3, 0, 0}, view_of(bases), core), Error);
  EXPECT_THROW(projector.project(x.values(), {8, 8, 7}, {0, 0, 0}, view_of(bases), core), Error);
  TuckerView broken = view_of(bases);
  broken.factors[2] = nullptr;
  EXPECT_THROW(projector.project(x.values(), x.dims(), {1, 1, 1}, broken, core), Error);
  EXPECT_NO_THROW(projector.project(x.values(), x.dims(), {2, 2, 2}, view_of(bases), core));
  EXPECT_EQ(core.dims(), (Dims3{3, 3, 3}));
}

}  // namespace
}  // namespace strata::tensor
