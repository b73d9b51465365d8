// The step calibration of PSNR/RMSE budgets (ta/step_calibration.hpp): its prediction is the
// error of quantizing the block-DCT coefficients, computed here coefficient by coefficient, and
// the step it picks is the largest that meets the budget.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "strata/quant/coded_brick.hpp"
#include "ta/step_calibration.hpp"

using namespace strata;
using namespace strata::ta;

namespace {

constexpr int kBlock = 4;
const Extent kDims{16, 12, 8};  // whole blocks: the prediction covers every voxel

std::vector<float> textured_volume(std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.0f, 3.0f);
  std::vector<float> v(std::size_t(kDims.voxel_count()));
  for (std::int64_t z = 0; z < kDims.z; ++z)
    for (std::int64_t y = 0; y < kDims.y; ++y)
      for (std::int64_t x = 0; x < kDims.x; ++x)
        v[std::size_t(x + kDims.x * (y + kDims.y * z))] =
            float(50 * std::sin(0.4 * x) * std::cos(0.3 * y) + 7 * z) + noise(rng);
  return v;
}

StepCalibrator calibrated(const std::vector<float>& v) {
  StepCalibrator c(kDims, kBlock);
  const std::size_t slice = std::size_t(kDims.x * kDims.y);
  for (std::int64_t z = 0; z < kDims.z; ++z) {
    const auto first = v.begin() + std::ptrdiff_t(std::size_t(z) * slice);
    c.push_slice(std::vector<float>(first, first + std::ptrdiff_t(slice)));
  }
  c.finish();
  return c;
}

// The error of coding every block with step Δ and dead zone t, coefficient by coefficient in
// double; the DC coefficient is charged Δ²/12 as the calibrator does (the brick mean is unknown).
double exact_mse(const std::vector<float>& v, double step, double t) {
  double error = 0;
  for (std::int64_t bz = 0; bz < kDims.z / kBlock; ++bz)
    for (std::int64_t by = 0; by < kDims.y / kBlock; ++by)
      for (std::int64_t bx = 0; bx < kDims.x / kBlock; ++bx)
        for (int fz = 0; fz < kBlock; ++fz)
          for (int fy = 0; fy < kBlock; ++fy)
            for (int fx = 0; fx < kBlock; ++fx) {
              double c = 0;
              for (int k = 0; k < kBlock; ++k)
                for (int j = 0; j < kBlock; ++j)
                  for (int i = 0; i < kBlock; ++i)
                    c += double(quant::block_dct_entry(kBlock, kBlock, i, fx)) *
                         quant::block_dct_entry(kBlock, kBlock, j, fy) * quant::block_dct_entry(kBlock, kBlock, k, fz) *
                         v[std::size_t((bx * kBlock + i) + kDims.x * ((by * kBlock + j) + kDims.y * (bz * kBlock + k)))];
              if (fx + fy + fz == 0) {
                error += step * step / 12;
                continue;
              }
              const double a = std::abs(c) / step;
              const double q = a < t ? 0 : std::floor(a + 0.5);
              error += std::pow((a - q) * step, 2);
            }
  return error / double(kDims.voxel_count());
}

TEST(TaStepCalibration, PredictsTheErrorOfQuantizingTheBlockSpectrum) {
  const std::vector<float> v = textured_volume(3);
  const StepCalibrator c = calibrated(v);
  EXPECT_EQ(c.blocks(), std::uint64_t(kDims.voxel_count() / (kBlock * kBlock * kBlock)));
  // Bins are 1/16 octave wide: a bin that straddles a rounding boundary is charged as if all of
  // it rounded like its mean, which moves its share of the error by a few percent at most.
  for (double step : {0.5, 2.0, 6.0, 20.0})
    for (double t : {0.5, 0.65}) {
      const double exact = exact_mse(v, step, t);
      EXPECT_NEAR(c.predicted_mse(step, t), exact, 0.03 * exact) << "step " << step << " threshold " << t;
    }
  // The dead zone matters on this spectrum, so the prediction must follow it.
  EXPECT_GT(exact_mse(v, 6.0, 0.65), 1.1 * exact_mse(v, 6.0, 0.5));
}

TEST(TaStepCalibration, PicksTheLargestStepWithinTheBudget) {
  const StepCalibrator c = calibrated(textured_volume(4));
  for (double mse : {0.05, 1.0, 8.0}) {
    const double step = c.step_for_mse(mse, 0.65);
    EXPECT_LE(c.predicted_mse(step, 0.65), mse);
    EXPECT_GT(c.predicted_mse(step * 1.1, 0.65), mse);  // (the prediction wiggles on the scale of a bin)
  }
  // A budget above the whole signal's energy: every coefficient may go, whatever the step.
  const double loose = c.step_for_mse(1e9, 0.65);
  EXPECT_LE(c.predicted_mse(loose, 0.65), 1e9);
}

TEST(TaStepCalibration, ALevelWithFlatBlocksPredictsNoErrorForThem) {
  const std::vector<float> flat(std::size_t(kDims.voxel_count()), 42.0f);
  EXPECT_EQ(calibrated(flat).predicted_mse(3.0, 0.65), 0.0);
}

}  // namespace
