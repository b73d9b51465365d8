// The preset and slice window a dataset opens with, from its values and name.
#include <gtest/gtest.h>

#include <limits>
#include <numeric>
#include <vector>

#include "strata/render/display_defaults.hpp"

using namespace strata::render;

TEST(RenderDisplayDefaults, PercentileWindowLeavesOutliersAndInterpolatesInsideBins) {
  // 1000 samples spread evenly over [0, 100) in 100 bins, plus 4 outliers at the top: the
  // window runs from the 0.5th to the 99.5th percentile of all 1004.
  std::vector<std::uint64_t> counts(1000, 0);
  for (int i = 0; i < 100; ++i) counts[std::size_t(i)] = 10;
  counts.back() = 4;
  const auto [lo, hi] = percentile_window(counts, 0, 1000);
  // 0.5% of 1004 = 5.02 samples: half of bin 0 (10 samples, 1 value unit wide) and a bit more.
  EXPECT_NEAR(lo, 0.502, 1e-9);
  // 99.5% of 1004 = 998.98 samples: 990 lie below bin 99, so 99 + 8.98 / 10.
  EXPECT_NEAR(hi, 99.898, 1e-9);
  EXPECT_LT(hi, 100.0);  // the outliers at 999 are outside
}

TEST(RenderDisplayDefaults, WindowFallsBackToTheRange) {
  EXPECT_EQ(percentile_window(std::vector<std::uint64_t>(8, 0), -1, 1), std::make_pair(-1.0, 1.0));
  std::vector<std::uint64_t> one(8, 0);
  one[3] = 50;  // every sample in one bin: narrower than a bin
  EXPECT_EQ(percentile_window(one, 0, 8), std::make_pair(0.0, 8.0));
}

TEST(RenderDisplayDefaults, HistogramBinsFiniteSamplesAndCoarsens) {
  const std::vector<float> samples{0.0f, 0.24f, 0.5f, 1.0f, std::numeric_limits<float>::quiet_NaN()};
  const std::vector<std::uint64_t> h = value_histogram(samples, 0, 1, 4);
  EXPECT_EQ(h, (std::vector<std::uint64_t>{2, 0, 1, 1}));  // 1.0 in the last bin, NaN nowhere
  EXPECT_EQ(coarser_histogram(h, 2), (std::vector<std::uint64_t>{2, 2}));
  EXPECT_TRUE(coarser_histogram({}, 64).empty());
  EXPECT_EQ(value_bin(5, 2, 2, 16), 0);  // a constant volume
}

TEST(RenderDisplayDefaults, PresetFollowsUnitsAndName) {
  EXPECT_EQ(default_preset("chest.nrrd", -1024, 3071), "ct");          // Hounsfield units
  EXPECT_EQ(default_preset("vtkjs_lidc2_ct.nrrd", 0, 255), "ct");      // says CT
  EXPECT_EQ(default_preset("vtkjs_headsq_mri.nrrd", 0, 3926), "mri");
  EXPECT_EQ(default_preset("sub-01_T1w.nii.gz", 0, 900), "mri");
  EXPECT_EQ(default_preset("ch2better.nii.gz", 0, 130), "mri");        // NIfTI: MR's container
  EXPECT_EQ(default_preset("fibsem_medulla_250.nrrd", 26, 217), "grayscale");
  EXPECT_EQ(default_preset("smrt_density.raw", 0, 1), "grayscale");    // "mr" inside a word
  EXPECT_EQ(default_preset("cta_run.h5", 0, 1), "ct");
  EXPECT_EQ(default_preset("brain.strata", 0, 130, true), "mri");  // placed in RAS or LPS
  EXPECT_EQ(default_preset("head.strata", -1024, 2000, true), "ct");
}

TEST(RenderDisplayDefaults, IntegerSamplesGetWholeWindows) {
  EXPECT_EQ(whole_window({0.0013, 119.6}, true), std::make_pair(0.0, 120.0));
  EXPECT_EQ(whole_window({0.0013, 119.6}, false), std::make_pair(0.0013, 119.6));
}
