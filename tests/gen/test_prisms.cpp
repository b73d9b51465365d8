// prisms: value range and structure at several scales.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "gen/gen_test_util.hpp"

namespace strata::gen {
namespace {

double stddev(const std::vector<double>& v) {
  double sum = 0, sum2 = 0;
  for (double x : v) sum += x, sum2 += x * x;
  const double mean = sum / double(v.size());
  return std::sqrt(std::max(0.0, sum2 / double(v.size()) - mean * mean));
}

// Means over 4x4x4 blocks: the coarse part of the signal.
std::vector<double> block_means(const Volume& v, std::int64_t b) {
  const Extent d = v.dims();
  std::vector<double> out;
  for (std::int64_t z = 0; z + b <= d.z; z += b)
    for (std::int64_t y = 0; y + b <= d.y; y += b)
      for (std::int64_t x = 0; x + b <= d.x; x += b) {
        double sum = 0;
        for (std::int64_t k = 0; k < b; ++k)
          for (std::int64_t j = 0; j < b; ++j)
            for (std::int64_t i = 0; i < b; ++i) sum += v.value(x + i, y + j, z + k);
        out.push_back(sum / double(b * b * b));
      }
  return out;
}

// Differences between x-neighbours: the fine part of the signal (tube edges and noise).
std::vector<double> x_differences(const Volume& v) {
  const Extent d = v.dims();
  const auto view = v.view<std::uint16_t>();
  std::vector<double> out;
  for (std::int64_t z = 0; z < d.z; ++z)
    for (std::int64_t y = 0; y < d.y; ++y)
      for (std::int64_t x = 0; x + 1 < d.x; ++x) out.push_back(double(view(x + 1, y, z)) - double(view(x, y, z)));
  return out;
}

TEST(GenPrisms, UsesMostOfTheU16Range) {
  const Volume v = generate(helpers::params(Kind::prisms, {96, 96, 96}));
  ASSERT_EQ(v.dtype(), DType::u16);
  const auto s = v.samples<std::uint16_t>();
  const auto [lo, hi] = std::minmax_element(s.begin(), s.end());
  EXPECT_LT(*lo, 12000);
  EXPECT_GT(*hi, 50000);
}

// A narrower output type gets the native u16 range mapped onto its own, so `generate prisms
// --dtype u8` keeps its structure (it used to clamp every sample to 255).
TEST(GenPrisms, NarrowerIntegerOutputsAreRescaledNotSaturated) {
  Params p;
  p.kind = Kind::prisms;
  p.dims = {32, 32, 32};
  p.seed = 3;
  const Volume native = generate(p);
  for (DType out : {DType::u8, DType::i8}) {
    p.output_dtype = out;
    const Volume narrow = generate(p);
    ASSERT_EQ(narrow.dtype(), out);
    const double lo = out == DType::u8 ? 0 : -128;
    for (std::int64_t i = 0; i < native.dims().voxel_count(); i += 97) {
      const Extent at{i % 32, i / 32 % 32, i / 1024};
      const double expected = lo + native.value(at.x, at.y, at.z) * 255.0 / 65535.0;
      EXPECT_NEAR(narrow.value(at.x, at.y, at.z), expected, 0.5 + 1e-9) << i;
    }
  }
  p.output_dtype = DType::f32;  // wider types keep the values
  EXPECT_EQ(generate(p).value(5, 6, 7), native.value(5, 6, 7));
}

TEST(GenPrisms, HasStructureAtCoarseAndFineScales) {
  const Volume v = generate(helpers::params(Kind::prisms, {96, 96, 96}));
  std::vector<double> all(v.samples<std::uint16_t>().begin(), v.samples<std::uint16_t>().end());
  const double total = stddev(all);
  const double coarse = stddev(block_means(v, 4));
  const double fine = stddev(x_differences(v));
  // Pure noise of amplitude 0.012 has neighbour differences of about 0.012 * 65535 * sqrt(2/3).
  const double noise_only = 0.012 * 65535.0 * std::sqrt(2.0 / 3.0);
  EXPECT_GT(total, 6000.0);
  EXPECT_GT(coarse, 0.6 * total);     // blobs and bundles survive 4x averaging
  EXPECT_GT(fine, 4.0 * noise_only);  // tube edges add fine detail beyond the noise
  RecordProperty("stddev", std::to_string(total));
}

TEST(GenPrisms, CountChangesTheBlobs) {
  const Volume few = generate(helpers::params(Kind::prisms, {48, 48, 48}, 1, 4));
  const Volume many = generate(helpers::params(Kind::prisms, {48, 48, 48}, 1, 80));
  double sum_few = 0, sum_many = 0;
  for (auto s : few.samples<std::uint16_t>()) sum_few += s;
  for (auto s : many.samples<std::uint16_t>()) sum_many += s;
  EXPECT_GT(sum_many, 1.2 * sum_few);
}

}  // namespace
}  // namespace strata::gen
