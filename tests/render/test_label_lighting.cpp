// Label lighting (paper 4, Fig. 7): the normals graph shades a ball as a ball, smoothly along
// any scanline, where opacity gradients show the voxel staircase; and normals lighting needs a
// file that has the graph.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "strata/core/error.hpp"
#include "strata/mixture/encoded_labels.hpp"
#include "strata/render/label_raycaster.hpp"
#include "strata/render/label_shading.hpp"
#include "support/label_volumes.hpp"
#include "support/test_support.hpp"

namespace strata::render {
namespace {

constexpr std::int64_t kN = 40;
constexpr double kRadius = 13, kCentre = 0.5 * kN + 0.3;
constexpr int kPixels = 160;  // over kN world units: 4 pixels per voxel

// A ball of label 7 in background 0, centred off the voxel grid.
Volume ball() { return test::label_ball(kN, kRadius, kCentre, 7); }

// `labels` encoded into dir/name (without the error report), with or without a normals graph.
std::unique_ptr<mixture::EncodedLabels> encoded(const Volume& labels, const test::TempDir& dir, const char* name,
                                                bool normals) {
  mixture::EncodeOptions o;
  o.measure_error = false;
  o.normals = normals;
  mixture::encode_labels(labels, dir / name, o);
  return std::make_unique<mixture::EncodedLabels>(dir / name);
}

// Orthographic, looking along +y: pixel column px sees world x = (px + 0.5) / 4.
Camera front() {
  CameraSpec spec;
  spec.width = spec.height = kPixels;
  spec.projection = Projection::orthographic;
  spec.orbit.azimuth_deg = 0;
  spec.orbit.elevation_deg = 0;
  spec.orbit.distance = 200;
  spec.ortho_height = double(kN);
  return Camera(spec, Extent{kN, kN, kN}, Spacing{});
}

struct BallFile {
  test::TempDir dir;
  std::unique_ptr<mixture::EncodedLabels> labels;
  BallFile() : labels(encoded(ball(), dir, "ball.strata", true)) {}
};

LabelRenderOptions lit(LabelLighting lighting) {
  LabelRenderOptions o;
  o.shading = true;
  o.lighting = lighting;
  o.specular = 0;  // diffuse only: the analytic profile below
  o.background = {0, 0, 0, 1};
  return o;
}

// Luminance (0..255) of the image row through the ball's centre.
std::vector<double> centre_row(const Image& image) {
  const int row = int(kPixels - kCentre * kPixels / kN);
  std::vector<double> out;
  for (int x = 0; x < kPixels; ++x) {
    const Rgba8 p = image.at(x, row);
    out.push_back((double(p.r) + p.g + p.b) / 3);
  }
  return out;
}

}  // namespace

TEST(RenderLabelLighting, NormalsShadeABallSmoothlyWhereGradientsShowTheVoxels) {
  BallFile file;
  LabelScene scene(*file.labels, LabelColorMap::uniform({1, 1, 1, 1}));
  LabelShading shading(file.labels->open_normals());
  const Image normals = render_labels(scene, front(), lit(LabelLighting::normals), nullptr, &shading);
  // Gradients of the trilinear coverage (smooth boundaries off) show the voxels; those of the
  // B-spline coverage (the default) are lit by level 1's gradient and stay smooth too.
  LabelRenderOptions trilinear = lit(LabelLighting::gradient);
  trilinear.smooth = false;
  const Image gradient = render_labels(scene, front(), trilinear);
  const Image smooth = render_labels(scene, front(), lit(LabelLighting::gradient));
  const std::vector<double> n = centre_row(normals), g = centre_row(gradient), sm = centre_row(smooth);
  // Inside the silhouette, away from its rim (3 voxels) where the surface turns away.
  const double ambient = LabelRenderOptions{}.ambient;
  double worst_step_n = 0, worst_step_g = 0, worst_step_smooth = 0, error = 0;
  int count = 0;
  for (int px = 0; px + 1 < kPixels; ++px) {
    const double x = (px + 0.5) * kN / kPixels - kCentre;
    if (std::abs(x) > kRadius - 3) continue;
    worst_step_n = std::max(worst_step_n, std::abs(n[std::size_t(px + 1)] - n[std::size_t(px)]));
    worst_step_g = std::max(worst_step_g, std::abs(g[std::size_t(px + 1)] - g[std::size_t(px)]));
    worst_step_smooth = std::max(worst_step_smooth, std::abs(sm[std::size_t(px + 1)] - sm[std::size_t(px)]));
    // A ball lit by a headlight: |n·l| = sqrt(1 − (x/R)²) on the centre row.
    const double expected = 255 * (ambient + (1 - ambient) * std::sqrt(1 - (x / kRadius) * (x / kRadius)));
    error += (n[std::size_t(px)] - expected) * (n[std::size_t(px)] - expected);
    ++count;
  }
  // The true profile changes by at most (1 − ambient)·255·|d/dx sqrt(1 − x²/R²)| per pixel, 4
  // pixels per voxel: under 4 levels at |x| = R − 3. Allow the same again for the codebook's
  // ~5° steps, smoothed by the pre-filtering.
  const double x_max = kRadius - 3;
  const double slope = (1 - ambient) * 255 * (x_max / (kRadius * kRadius)) / std::sqrt(1 - x_max * x_max / (kRadius * kRadius)) / 4;
  EXPECT_LT(worst_step_n, 2 * slope + 2) << "normals: a step edge along the scanline";
  EXPECT_GT(worst_step_g, 2 * slope + 2) << "gradients were expected to show voxel steps (the test would be moot)";
  EXPECT_LT(worst_step_smooth, 2 * slope + 2) << "smooth boundaries: a step edge along the scanline";
  EXPECT_LT(std::sqrt(error / count), 8.0) << "normals: the profile of a lit ball (measured 3.7)";
}

TEST(RenderLabelLighting, NormalsLightingNeedsTheGraph) {
  test::TempDir dir;
  const auto labels = encoded(ball(), dir, "plain.strata", false);
  LabelScene scene(*labels, LabelColorMap::uniform({1, 1, 1, 1}));
  EXPECT_EQ(test::parameter_of([&] { render_labels(scene, front(), lit(LabelLighting::normals)); }),
            "LabelRenderOptions::lighting");
}

namespace {

// A floor (z < 8) with, on the half y < 24, walls up to z = 28 on both sides of a trench
// x in [22, 26): seen from above, the trench floor and the open floor face the same way.
Volume trench() {
  Volume v(Extent{48, 48, 40}, DType::u8);
  auto s = v.view<std::uint8_t>();
  for (std::int64_t z = 0; z < 40; ++z)
    for (std::int64_t y = 0; y < 48; ++y)
      for (std::int64_t x = 0; x < 48; ++x) {
        const bool wall = y < 24 && (x < 22 || x >= 26) && z < 28;
        s(x, y, z) = z < 8 || wall ? 5 : 0;
      }
  return v;
}

// The grey level of the pixel whose ray starts nearest world (x, y) (orthographic, from above).
double grey_at(const Image& image, const Camera& camera, double x, double y) {
  int best_x = 0, best_y = 0;
  double best = 1e300;
  for (int py = 0; py < image.height(); ++py)
    for (int px = 0; px < image.width(); ++px) {
      const Ray r = camera.ray(px, py);
      const double d = (r.origin.x - x) * (r.origin.x - x) + (r.origin.y - y) * (r.origin.y - y);
      if (d < best) best = d, best_x = px, best_y = py;
    }
  const Rgba8 p = image.at(best_x, best_y);
  return (double(p.r) + p.g + p.b) / 3;
}

}  // namespace

// Local ambient occlusion darkens a floor between walls and leaves an open floor alone.
TEST(RenderLabelLighting, OcclusionDarkensCreasesOnly) {
  test::TempDir dir;
  const auto labels = encoded(trench(), dir, "trench.strata", false);
  LabelScene scene(*labels, LabelColorMap::uniform({1, 1, 1, 1}));
  CameraSpec spec;
  spec.width = spec.height = 96;
  spec.projection = Projection::orthographic;
  spec.orbit.elevation_deg = 90;
  spec.orbit.distance = 200;
  spec.ortho_height = 48;
  const Camera camera(spec, Extent{48, 48, 40}, Spacing{});
  LabelRenderOptions plain = lit(LabelLighting::gradient), occluded = plain;
  occluded.occlusion = true;
  const Image a = render_labels(scene, camera, plain), b = render_labels(scene, camera, occluded);
  const double open_plain = grey_at(a, camera, 24, 36), trench_plain = grey_at(a, camera, 24, 12);
  const double open_occluded = grey_at(b, camera, 24, 36), trench_occluded = grey_at(b, camera, 24, 12);
  EXPECT_NEAR(open_plain, trench_plain, 2) << "without occlusion both floors face the light alike";
  EXPECT_NEAR(open_occluded, open_plain, 0.1 * open_plain) << "open floor: the rays escape";
  EXPECT_LT(trench_occluded, 0.85 * open_occluded) << "the trench's walls block part of the light";
}

}  // namespace strata::render
