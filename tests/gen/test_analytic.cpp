// Marschner–Lobb and sphere against their closed forms, written out here independently.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "gen/gen_test_util.hpp"

namespace strata::gen {
namespace {

double expected_marschner_lobb(double x, double y, double z) {
  const double alpha = 0.25, fm = 6.0, pi = std::numbers::pi;
  const double r = std::sqrt(x * x + y * y);
  const double rho_r = std::cos(2 * pi * fm * std::cos(pi * r / 2));
  return (1 - std::sin(pi * z / 2) + alpha * (1 + rho_r)) / (2 * (1 + alpha));
}

TEST(GenMarschnerLobb, MatchesTheFormulaOnTheUnitGrid) {
  const Extent d{41, 33, 25};
  const Volume v = generate(helpers::params(Kind::marschner_lobb, d));
  ASSERT_EQ(v.dtype(), DType::f32);
  auto at = [&](std::int64_t i, std::int64_t n) { return -1.0 + 2.0 * double(i) / double(n - 1); };
  const std::int64_t points[][3] = {{0, 0, 0}, {40, 32, 24}, {20, 16, 12}, {7, 29, 3}, {33, 5, 18}, {13, 13, 13}};
  for (const auto& p : points) {
    const double expected = expected_marschner_lobb(at(p[0], d.x), at(p[1], d.y), at(p[2], d.z));
    EXPECT_NEAR(v.value(p[0], p[1], p[2]), expected, 1e-6) << p[0] << "," << p[1] << "," << p[2];
  }
}

TEST(GenMarschnerLobb, StaysInTheUnitInterval) {
  const Volume v = generate(helpers::params(Kind::marschner_lobb, {48, 48, 48}));
  const auto s = v.samples<float>();
  const auto [lo, hi] = std::minmax_element(s.begin(), s.end());
  EXPECT_GE(*lo, 0.0f);
  EXPECT_LE(*hi, 1.0f);
  EXPECT_LT(*lo, 0.1f);  // the signal spans most of [0, 1]
  EXPECT_GT(*hi, 0.9f);
}

double expected_sphere(const Extent& d, double radius, std::int64_t x, std::int64_t y, std::int64_t z) {
  const double dx = x - (d.x - 1) / 2.0, dy = y - (d.y - 1) / 2.0, dz = z - (d.z - 1) / 2.0;
  return std::clamp(radius - std::sqrt(dx * dx + dy * dy + dz * dz) + 0.5, 0.0, 1.0);
}

TEST(GenSphere, MatchesTheFormulaEverywhere) {
  const Extent d{30, 26, 20};  // radius 0.4 * 20 = 8
  const Volume v = generate(helpers::params(Kind::sphere, d));
  for (std::int64_t z = 0; z < d.z; ++z)
    for (std::int64_t y = 0; y < d.y; ++y)
      for (std::int64_t x = 0; x < d.x; ++x)
        ASSERT_NEAR(v.value(x, y, z), expected_sphere(d, 8.0, x, y, z), 1e-6) << x << "," << y << "," << z;
  EXPECT_EQ(v.value(0, 0, 0), 0.0);
  EXPECT_EQ(v.value(15, 13, 10), 1.0);
}

TEST(GenSphere, CountSetsTheRadius) {
  const Extent d{32, 32, 32};
  const Volume v = generate(helpers::params(Kind::sphere, d, 1, 5));
  for (std::int64_t x = 0; x < d.x; ++x) EXPECT_NEAR(v.value(x, 16, 16), expected_sphere(d, 5.0, x, 16, 16), 1e-6);
  // The volume of the ramped sphere approximates 4/3 pi r^3.
  double sum = 0;
  for (float s : v.samples<float>()) sum += s;
  EXPECT_NEAR(sum, 4.0 / 3.0 * std::numbers::pi * 125.0, 0.03 * 4.0 / 3.0 * std::numbers::pi * 125.0);
}

}  // namespace
}  // namespace strata::gen
