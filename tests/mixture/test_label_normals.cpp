// Normals of a segmentation for pre-filtered shading (paper 4, "Lighting"): estimated from the
// window moment of the neighbouring labels, quantized to the 9-bit codebook with error
// diffusion, and stored as a second Mixture Graph that decodes to exactly those codes.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "strata/core/error.hpp"
#include "strata/mixture/encoded_labels.hpp"
#include "strata/mixture/label_normals.hpp"
#include "support/label_volumes.hpp"
#include "support/test_support.hpp"

using namespace strata;
using namespace strata::mixture;

namespace {

using Normal = std::array<float, 3>;

double angle_deg(const Normal& a, const Normal& b) {
  const double d = double(a[0]) * b[0] + double(a[1]) * b[1] + double(a[2]) * b[2];
  const double na = std::sqrt(double(a[0]) * a[0] + double(a[1]) * a[1] + double(a[2]) * a[2]);
  const double nb = std::sqrt(double(b[0]) * b[0] + double(b[1]) * b[1] + double(b[2]) * b[2]);
  return std::acos(std::clamp(d / (na * nb), -1.0, 1.0)) * 180 / std::numbers::pi;
}

// A ball of label 7 (radius r voxels) in a background of 0, centred off the voxel grid.
Volume ball(std::int64_t n, double r) { return test::label_ball(n, r, 0.5 * double(n) + 0.3, 7); }

Normal radial(std::int64_t n, std::int64_t x, std::int64_t y, std::int64_t z) {
  const double c = 0.5 * double(n) + 0.3;
  return {float(x + 0.5 - c), float(y + 0.5 - c), float(z + 0.5 - c)};
}

// The codebook's covering radius: the largest angle from any direction to its nearest code,
// over a dense Fibonacci sampling of the sphere.
double covering_radius_deg() {
  const auto& book = normal_codebook();
  double worst = 0;
  const int samples = 20000;
  for (int i = 0; i < samples; ++i) {
    const double z = 1 - (2.0 * i + 1) / samples, r = std::sqrt(1 - z * z), phi = i * 2.399963229728653;
    const Normal n{float(r * std::cos(phi)), float(r * std::sin(phi)), float(z)};
    double best = 180;
    for (int c = 1; c < kNormalCodes; ++c) best = std::min(best, angle_deg(n, book[std::size_t(c)]));
    worst = std::max(worst, best);
  }
  return worst;
}

}  // namespace

TEST(MixtureLabelNormals, CodebookIsUnitAndTheLookupFindsTheNearestCode) {
  const auto& book = normal_codebook();
  EXPECT_EQ(book[0], (Normal{0, 0, 0}));
  for (int c = 1; c < kNormalCodes; ++c)
    EXPECT_NEAR(std::sqrt(book[std::size_t(c)][0] * book[std::size_t(c)][0] + book[std::size_t(c)][1] * book[std::size_t(c)][1] +
                          book[std::size_t(c)][2] * book[std::size_t(c)][2]),
                1.0, 1e-6);
  const double rho = covering_radius_deg();
  EXPECT_LT(rho, 7.0) << "511 evenly spread codes";
  // The table's candidates hold the exact nearest code.
  for (int i = 0; i < 2000; ++i) {
    const double z = 1 - (2.0 * i + 1) / 2000, r = std::sqrt(1 - z * z), phi = i * 2.399963229728653;
    const Normal n{float(r * std::cos(phi)), float(r * std::sin(phi)), float(z)};
    double best = 180;
    for (int c = 1; c < kNormalCodes; ++c) best = std::min(best, angle_deg(n, book[std::size_t(c)]));
    EXPECT_LE(angle_deg(n, book[nearest_normal_code(n)]), best + 1e-3) << i;
  }
  EXPECT_EQ(nearest_normal_code({0, 0, 0}), 0);
}

// On a ball the estimated normals are radial: outwards inside the ball, inwards (towards the
// ball, the "other" label) in the background, so |cos| to the radius is 1 up to the
// voxelization of the surface.
TEST(MixtureLabelNormals, BallNormalsAreRadial) {
  const std::int64_t n = 40;
  const Volume v = ball(n, 13);
  LabelNormals counts;
  const auto normals = estimate_label_normals(v, {}, &counts);
  const auto labels = v.view<std::uint8_t>();
  double sum = 0, worst = 0;
  std::int64_t count = 0;
  for (std::int64_t z = 0; z < n; ++z)
    for (std::int64_t y = 0; y < n; ++y)
      for (std::int64_t x = 0; x < n; ++x) {
        const Normal& e = normals[std::size_t((z * n + y) * n + x)];
        if (e == Normal{0, 0, 0}) continue;
        Normal want = radial(n, x, y, z);
        if (labels(x, y, z) == 0) want = {-want[0], -want[1], -want[2]};
        const double a = angle_deg(e, want);
        sum += a, worst = std::max(worst, a), ++count;
      }
  EXPECT_GT(count, 4000);
  EXPECT_EQ(std::uint64_t(count), counts.band_voxels + counts.interior_voxels);
  EXPECT_LT(sum / double(count), 4.0) << "mean angle to the radius";
  EXPECT_LT(worst, 15.0);
}

// Quantized, each code is within the covering radius of what it coded: the normal itself
// without dithering, the normal plus the carried residual (at most one more covering radius
// of error, spread over neighbours) with it.
TEST(MixtureLabelNormals, CodesStayWithinTheQuantizationError) {
  const std::int64_t n = 40;
  const Volume v = ball(n, 13);
  const auto normals = estimate_label_normals(v);
  const double rho = covering_radius_deg();
  for (bool dither : {false, true}) {
    NormalOptions o;
    o.error_diffusion = dither;
    const LabelNormals q = quantize_label_normals(v, o);
    const auto codes = q.codes.samples<std::uint16_t>();
    double worst = 0, sum = 0;
    std::int64_t count = 0;
    for (std::size_t i = 0; i < normals.size(); ++i) {
      if (normals[i] == Normal{0, 0, 0}) {
        EXPECT_EQ(codes[i], 0) << i;
        continue;
      }
      ASSERT_GT(codes[i], 0) << i;
      const double a = angle_deg(normals[i], normal_codebook()[codes[i]]);
      worst = std::max(worst, a), sum += a, ++count;
    }
    EXPECT_LE(worst, dither ? 2 * rho : rho) << (dither ? "dithered" : "plain");
    EXPECT_LT(sum / double(count), rho) << (dither ? "dithered" : "plain");
  }
}

// `--normals` stores the codes as a second graph that decodes to them exactly; its levels
// match the labels'; a file without them says so.
TEST(MixtureLabelNormals, TheNormalsGraphDecodesToTheCodes) {
  test::TempDir dir;
  const Volume v = ball(24, 8);
  EncodeOptions o;
  o.normals = true;
  const EncodeReport r = encode_labels(v, dir / "n.strata", o);
  EXPECT_GT(r.normals_bytes, 0u);
  const EncodedLabels labels(dir / "n.strata");
  ASSERT_TRUE(labels.has_normals());
  EXPECT_EQ(labels.metadata()["normals"]["codebook"], "fibonacci-511");
  const auto normals = labels.open_normals();
  EXPECT_EQ(normals->level_count(), labels.level_count());
  EXPECT_EQ(normals->name(), labels.name() + " (normals)");
  const Volume codes = normals->decode_level0();
  const LabelNormals want = quantize_label_normals(v);
  ASSERT_EQ(codes.dims(), want.codes.dims());
  for (std::size_t i = 0; i < std::size_t(v.voxel_count()); ++i) {
    const std::int64_t got = codes.dtype() == DType::u16 ? codes.samples<std::uint16_t>()[i] : -1;
    ASSERT_EQ(got, want.codes.samples<std::uint16_t>()[i]) << i;
  }
  // Without --normals there is no section, and asking for it names the file.
  encode_labels(v, dir / "plain.strata", EncodeOptions{});
  const EncodedLabels plain(dir / "plain.strata");
  EXPECT_FALSE(plain.has_normals());
  const std::string message = test::error_of([&] { (void)plain.open_normals(); });
  EXPECT_NE(message.find("plain.strata: section normals: missing"), std::string::npos) << message;
}

TEST(MixtureLabelNormals, BadOptionsAreNamed) {
  const Volume v = ball(8, 3);
  NormalOptions o;
  o.radius = 5;
  EXPECT_EQ(test::parameter_of([&] { quantize_label_normals(v, o); }), "NormalOptions::radius");
  o = {};
  o.band = 4;
  EXPECT_EQ(test::parameter_of([&] { quantize_label_normals(v, o); }), "NormalOptions::band");
  o = {};
  o.diffusion = -1;
  EXPECT_EQ(test::parameter_of([&] { quantize_label_normals(v, o); }), "NormalOptions::diffusion");
  const Volume f(Extent{4, 4, 4}, DType::f32);
  EXPECT_THROW(quantize_label_normals(f), Error);
}
