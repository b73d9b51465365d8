// Ray jitter: each pixel's sample lattice starts at its own offset, so the step's error on a
// zoomed surface is fine noise that refinement passes average away, never coherent rings.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "render/traversal.hpp"
#include "strata/core/error.hpp"
#include "strata/gen/generators.hpp"
#include "strata/render/raycaster.hpp"

using namespace strata;
using namespace strata::render;

namespace {

constexpr int kWidth = 160, kHeight = 120;

// The Marschner-Lobb signal under the CT preset, seen from close by: at step 0.5 a lattice shared
// by all rays (whole steps from the eye) draws concentric rings across its smooth surfaces.
Volume marschner_lobb() {
  gen::Params p;
  p.kind = gen::Kind::marschner_lobb;
  p.dims = {80, 80, 80};
  return gen::generate(p);
}

Camera zoomed_camera(const Extent& dims) {
  CameraSpec s;
  s.width = kWidth;
  s.height = kHeight;
  s.fov_deg = 20;
  s.orbit.azimuth_deg = 30;
  s.orbit.elevation_deg = 20;
  s.orbit.distance = 30;  // inside the volume: the view spans about 10 voxels
  return Camera(s, dims, {});
}

// The mean of jitter passes 0..passes-1 (one plain render without jitter), as floats: the mean
// of the colour channels per pixel.
std::vector<double> render_mean(const Volume& v, double step, bool jitter, int passes) {
  RenderOptions o;
  o.step = step;
  o.jitter = jitter;
  o.threads = 2;
  RayCaster caster(TransferFunction::preset("ct"), o);
  const Camera cam = zoomed_camera(v.dims());
  PreparedVolume prepared(v);
  std::vector<double> mean(std::size_t(kWidth) * kHeight, 0.0);
  for (int p = 0; p < passes; ++p) {
    caster.set_jitter_pass(std::uint32_t(p));
    const Image img = caster.render(cam, prepared);
    for (int y = 0; y < kHeight; ++y)
      for (int x = 0; x < kWidth; ++x) {
        const Rgba8 c = img.at(x, y);
        mean[std::size_t(y) * kWidth + x] += (c.r + c.g + c.b) / (3.0 * passes);
      }
  }
  return mean;
}

// Variance over the central half of the image after subtracting each pixel's 7x7 mean: the
// fine structure (rings, noise) of the surface, without its smooth shading.
double fine_variance(const std::vector<double>& img) {
  double sum = 0, sum2 = 0;
  int n = 0;
  for (int y = kHeight / 4; y < 3 * kHeight / 4; ++y)
    for (int x = kWidth / 4; x < 3 * kWidth / 4; ++x) {
      double local = 0;
      for (int dy = -3; dy <= 3; ++dy)
        for (int dx = -3; dx <= 3; ++dx) local += img[std::size_t(y + dy) * kWidth + x + dx];
      const double v = img[std::size_t(y) * kWidth + x] - local / 49;
      sum += v;
      sum2 += v * v;
      ++n;
    }
  const double m = sum / n;
  return sum2 / n - m * m;
}

}  // namespace

TEST(RenderRayJitter, RefinedStepHalfHasNoRingsBeyondStepOneTenth) {
  // Measured on this view (fine variance in 8-bit levels squared): step 0.1 without jitter
  // 0.035; step 0.5 without jitter 0.133 (the rings); one jittered pass 5.0 (fine noise of
  // similar amplitude, nothing coherent); the mean of 4 passes 0.35, of 8 passes 0.011.
  const Volume v = marschner_lobb();
  const double reference = fine_variance(render_mean(v, 0.1, false, 1));
  const double rings = fine_variance(render_mean(v, 0.5, false, 1));
  const double refined = fine_variance(render_mean(v, 0.5, true, 8));
  EXPECT_GT(rings, 2.0 * reference);  // the scene shows the artefact at all
  EXPECT_LE(refined, 1.5 * reference);
}

TEST(RenderRayJitter, JitterOffRendersEveryPassAlike) {
  const Volume v = marschner_lobb();
  auto largest_difference = [](const std::vector<double>& a, const std::vector<double>& b) {
    double d = 0;
    for (std::size_t i = 0; i < a.size(); ++i) d = std::max(d, std::abs(a[i] - b[i]));
    return d;
  };
  const std::vector<double> plain = render_mean(v, 0.5, false, 1);
  EXPECT_LT(largest_difference(plain, render_mean(v, 0.5, false, 3)), 1e-9);  // the passes are one image
  EXPECT_GE(largest_difference(plain, render_mean(v, 0.5, true, 1)), 1.0);
}

TEST(RenderRayJitter, OffsetsSpreadOverAStepInEveryPass) {
  // Neighbouring pixels far apart in phase (no smooth gradient that would draw rings of its
  // own), every phase about equally often, and each pixel's first passes evenly spread.
  for (std::uint32_t pass : {0u, 1u, 7u}) {
    std::vector<int> bins(8, 0);
    double neighbour_gap = 0;
    for (int y = 0; y < 64; ++y)
      for (int x = 0; x < 64; ++x) {
        const double u = detail::lattice_offset(x, y, pass);
        ASSERT_GE(u, 0.0);
        ASSERT_LT(u, 1.0);
        ++bins[std::size_t(u * 8)];
        const double d = std::abs(u - detail::lattice_offset(x + 1, y, pass));
        neighbour_gap += std::min(d, 1 - d) / (64 * 64);
      }
    for (int b : bins) EXPECT_NEAR(b, 64 * 64 / 8, 64 * 64 / 8 / 4) << "pass " << pass;
    EXPECT_GT(neighbour_gap, 0.15) << "pass " << pass;  // 0.25 for independent phases
  }
  std::vector<double> phases;
  for (std::uint32_t pass = 0; pass < 8; ++pass) phases.push_back(detail::lattice_offset(5, 9, pass));
  std::sort(phases.begin(), phases.end());
  for (std::size_t i = 1; i < phases.size(); ++i) EXPECT_LT(phases[i] - phases[i - 1], 0.25);
}

TEST(RenderImageMean, AveragesChannelsAndRefusesOtherSizes) {
  ImageMean mean;
  EXPECT_THROW((void)mean.mean(), Error);
  mean.add(Image(2, 1, {10, 20, 30, 255}));
  mean.add(Image(2, 1, {11, 20, 0, 255}));
  const Image m = mean.mean();
  EXPECT_EQ(m.at(1, 0), (Rgba8{11, 20, 15, 255}));  // 10.5 rounds up
  EXPECT_EQ(mean.count(), 2);
  EXPECT_THROW(mean.add(Image(1, 2)), Error);
}
