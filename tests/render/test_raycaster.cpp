// The ray caster against closed-form images, and bricked / compressed renders against the
// single-block render of the uncompressed volume.
#include <gtest/gtest.h>

#include <bit>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <cstdio>
#include <utility>
#include <nlohmann/json.hpp>

#include "render/occupancy.hpp"
#include "render/shading.hpp"
#include "strata/core/isa.hpp"
#include "strata/core/error.hpp"
#include "strata/gen/generators.hpp"
#include "strata/render/raycaster.hpp"
#include "strata/ta/ta_volume.hpp"
#include "support/isa_test.hpp"
#include "support/test_support.hpp"
#include "ta/ta_test_util.hpp"

using namespace strata;
using namespace strata::render;

namespace {

struct Diff {
  int max = 0;  // largest per-channel difference, in 8-bit levels
  int x = 0, y = 0;
};

Diff max_diff(const Image& a, const Image& b) {
  Diff d;
  for (int y = 0; y < a.height(); ++y)
    for (int x = 0; x < a.width(); ++x) {
      const Rgba8 p = a.at(x, y), q = b.at(x, y);
      const int m = std::max({std::abs(p.r - q.r), std::abs(p.g - q.g), std::abs(p.b - q.b), std::abs(p.a - q.a)});
      if (m > d.max) d = {m, x, y};
    }
  return d;
}

// Sphere of radius R (voxels) centred in a 64^3 volume; the generator puts the centre at voxel
// coordinate 31.5, i.e. world 32 (voxel i covers [i, i + 1)).
constexpr int kDim = 64;
constexpr double kRadius = 20;

Volume sphere_volume() {
  gen::Params p;
  p.kind = gen::Kind::sphere;
  p.dims = {kDim, kDim, kDim};
  p.count = std::int64_t(kRadius);
  return gen::generate(p);
}

// Orthographic, one pixel per voxel, looking along +y (x right, z up).
Camera sphere_camera() {
  CameraSpec s;
  s.width = s.height = kDim;
  s.projection = Projection::orthographic;
  s.ortho_height = kDim;
  s.orbit.azimuth_deg = 0;
  s.orbit.elevation_deg = 0;
  return Camera(s, {kDim, kDim, kDim}, {});
}

constexpr float kAlpha = 0.05f;
constexpr float kColour[3] = {1.0f, 0.8f, 0.6f};

// Opacity kAlpha per voxel where the value is >= 0.5 (inside the sphere's surface), else clear.
TransferFunction step_tf() {
  const std::array<float, 4> clear{kColour[0], kColour[1], kColour[2], 0}, solid{kColour[0], kColour[1], kColour[2], kAlpha};
  return TransferFunction({{0, clear}, {0.5, clear}, {0.5, solid}, {1, solid}});
}

RenderOptions options(double step, bool preintegrated, bool shading) {
  RenderOptions o;
  o.step = step;
  o.preintegrated = preintegrated;
  o.shading = shading;
  o.threads = 2;
  return o;
}

// A frame over all level-0 bricks of an in-memory volume.
struct BrickedVolume {
  ta::OctreeGeometry geometry;
  lod::FrameBricks bricks;
  BrickedVolume(const Volume& v, int brick, int overlap)
      : geometry(v.dims(), {brick, overlap}), bricks(bricks_from_volume(v, geometry)) {}
  FrameInput frame(const Volume& v, double lo, double hi) const { return {&bricks, &geometry, v.spacing(), lo, hi, nullptr}; }
};

void check_sphere_image(const Image& img, double step, const char* label) {
  // Along a ray at distance rho from the centre the TF is opaque over the chord
  // c = 2 sqrt(R^2 - rho^2), so the pixel is colour * (1 - (1 - a)^c) over black.
  // Chord uncertainty: sample placement costs at most one step at each end (post-
  // classification; pre-integration does better), and the iso-0.5 surface of the trilinear
  // interpolant of clamp(R - d + 0.5, 0, 1) sits within dR = 0.25 voxel of R (curvature:
  // 3 / (8R) = 0.02; clamped corners within the 0.87-voxel reach of the trilinear stencil:
  // the rest), which moves the chord by 2 dR R / sqrt(R^2 - rho^2). One more level for
  // rounding. Pixels within 1.5 voxels of the silhouette (where that bound diverges and a
  // pixel straddles the rim) are left out; pixels beyond it must be exact background.
  const double tau = -std::log(1.0 - kAlpha);
  int checked = 0, lit = 0;
  for (int py = 0; py < img.height(); ++py)
    for (int px = 0; px < img.width(); ++px) {
      const double u = px + 0.5 - kDim / 2.0, v = py + 0.5 - kDim / 2.0;
      const double rho = std::sqrt(u * u + v * v);
      const Rgba8 p = img.at(px, py);
      if (p.r > 0) ++lit;
      ASSERT_EQ(p.a, 255);
      if (std::abs(rho - kRadius) < 1.5) continue;
      ++checked;
      if (rho > kRadius) {
        ASSERT_EQ(p, (Rgba8{0, 0, 0, 255})) << label << " at " << px << "," << py;
        continue;
      }
      const double s = std::sqrt(kRadius * kRadius - rho * rho);
      const double chord = 2 * s;
      const double opacity = 1 - std::exp(-tau * chord);
      const double dchord = 2 * step + 2 * 0.25 * kRadius / s;
      const double dopacity = tau * std::exp(-tau * chord) * dchord;
      const std::uint8_t got[3] = {p.r, p.g, p.b};
      for (int c = 0; c < 3; ++c) {
        const double expected = 255.0 * kColour[c] * opacity;
        const double tol = 255.0 * kColour[c] * dopacity + 1.0;
        ASSERT_NEAR(got[c], expected, tol) << label << " channel " << c << " at " << px << "," << py << " rho " << rho;
      }
    }
  EXPECT_GT(checked, kDim * kDim * 3 / 4);
  // Silhouette radius from the lit area: pi r^2 = lit, within the 1.5-voxel band above.
  const double r = std::sqrt(lit / std::acos(-1.0));
  EXPECT_NEAR(r, kRadius, 1.5) << label;
}

}  // namespace

TEST(RenderRayCaster, AnalyticSphereMatchesTheClosedFormImage) {
  const Volume v = sphere_volume();
  const BrickedVolume bricked(v, 16, 2);
  const Camera cam = sphere_camera();
  const double step = 0.25;
  for (bool preint : {true, false}) {
    RayCaster rc(step_tf(), options(step, preint, false));
    const Image single = rc.render(cam, v, 0.0, 1.0);
    check_sphere_image(single, step, preint ? "single block, pre-integrated" : "single block, lookup table");
    RenderStats stats;
    const Image bricks = rc.render(cam, bricked.frame(v, 0, 1), &stats);
    check_sphere_image(bricks, step, preint ? "bricks, pre-integrated" : "bricks, lookup table");
    // Bricks outside the sphere are all zero and skipped; the image does not change.
    EXPECT_GT(stats.bricks_culled, 0u);
    EXPECT_LE(max_diff(single, bricks).max, 1);
    // Centre pixel: the full diameter.
    const double centre = 1 - std::pow(1 - kAlpha, 2 * std::sqrt(kRadius * kRadius - 0.5));
    EXPECT_NEAR(single.at(31, 31).r, 255 * centre, 2.0);
  }
}

TEST(RenderRayCaster, SphereRadiusFollowsTheThresholdAndBackgroundShowsThrough) {
  // A higher threshold (0.9) shrinks the opaque disc to R - 0.4; a transparent background
  // leaves alpha = 0 outside and straight colour inside.
  const Volume v = sphere_volume();
  const std::array<float, 4> clear{0, 1, 0, 0}, solid{0, 1, 0, 1};
  RenderOptions o = options(0.25, true, false);
  o.background = {0, 0, 0, 0};
  RayCaster rc(TransferFunction({{0, clear}, {0.9, clear}, {0.9, solid}, {1, solid}}), o);
  const Image img = rc.render(sphere_camera(), v, 0, 1);
  for (int py = 0; py < kDim; ++py)
    for (int px = 0; px < kDim; ++px) {
      const double u = px + 0.5 - kDim / 2.0, w = py + 0.5 - kDim / 2.0, rho = std::sqrt(u * u + w * w);
      const Rgba8 p = img.at(px, py);
      if (rho < kRadius - 0.4 - 1.5) {
        EXPECT_EQ(p, (Rgba8{0, 255, 0, 255})) << px << "," << py;
      }
      if (rho > kRadius - 0.4 + 1.5) {
        EXPECT_EQ(p.a, 0) << px << "," << py;
      }
    }
}

namespace {

struct CompressedCase {
  test::TempDir dir;
  Volume raw;
  std::unique_ptr<ta::TaVolume> ta;
  CompressedCase(const Volume& v, int brick, int overlap) : raw(v) {
    // Full rank (R = B) and float coefficients: reconstruction is exact up to float rounding.
    ta::testing::compress(v, dir / "v.strata", ta::testing::params(brick, overlap, brick, "f32"));
    ta = std::make_unique<ta::TaVolume>(dir / "v.strata");
  }
};

Volume prisms_volume() {
  gen::Params p;
  p.kind = gen::Kind::prisms;
  p.dims = {56, 48, 40};
  p.seed = 3;
  return gen::generate(p);
}

Camera perspective_camera(const Extent& dims, double az, double el, int w = 128, int h = 96) {
  CameraSpec s;
  s.width = w;
  s.height = h;
  s.orbit.azimuth_deg = az;
  s.orbit.elevation_deg = el;
  return Camera(s, dims, {});
}

}  // namespace

TEST(RenderRayCaster, FullRankF32FileMatchesTheUncompressedVolumeWithoutSeams) {
  CompressedCase c(prisms_volume(), 16, 2);
  const double lo = c.ta->value_min(), hi = c.ta->value_max();
  const lod::FrameBricks decoded = level_bricks(*c.ta, 0, c.ta->rank());
  const lod::FrameBricks cut = bricks_from_volume(c.raw, c.ta->geometry());
  const FrameInput from_file{&decoded, &c.ta->geometry(), c.raw.spacing(), lo, hi, &c.ta->container()};
  const FrameInput from_raw{&cut, &c.ta->geometry(), c.raw.spacing(), lo, hi, nullptr};
  for (const char* tf_name : {"ct", "mri", "grayscale"})
    for (bool shading : {true, false})
      for (double az : {30.0, 117.0}) {
        RayCaster rc(TransferFunction::preset(tf_name), options(0.5, true, shading));
        const Camera cam = perspective_camera(c.raw.dims(), az, 25);
        // The single-block render has no brick borders at all: the reference.
        const Image reference = rc.render(cam, c.raw, lo, hi);
        const Image raw_bricks = rc.render(cam, from_raw);
        const Image file_bricks = rc.render(cam, from_file);
        const Diff seams = max_diff(reference, raw_bricks), codec = max_diff(reference, file_bricks);
        SCOPED_TRACE(std::string(tf_name) + (shading ? " shaded" : " unshaded") + " az " + std::to_string(az));
        // Bricking alone changes only float rounding (the overlap holds the neighbours' voxels).
        EXPECT_LE(seams.max, 1) << "at " << seams.x << "," << seams.y;
        EXPECT_LE(codec.max, 2) << "at " << codec.x << "," << codec.y;
      }
}

TEST(RenderRayCaster, MixedLevelsLeaveNoCracks) {
  // A linear ramp along x is its own 2x2x2 average (level-1 voxel centres sit at the mean of
  // their children's centres) and trilinear interpolation reproduces it exactly, so any frame
  // mixing levels 0 and 1 must render like level 0 alone: no crack may lose opacity. What
  // remains is the segment crossing a level change, whose pre-integrated colour is opacity
  // corrected to its true length as if its value were constant: with this TF's steepest
  // opacity slope (0.04 per 0.4 of the range) and a segment of at most 1.5 voxels over which
  // the ramp moves 1.5/64 of the range, that is <= 0.0035 of opacity per crossing, and a ray
  // crosses at most 5 level changes here: <= 0.018, i.e. 4 levels of 255 (3 observed).
  // The TF is clear near both x faces, where edge clamping differs between levels.
  const Extent dims{64, 48, 40};
  Volume v(dims, DType::f32);
  for (std::int64_t z = 0; z < dims.z; ++z)
    for (std::int64_t y = 0; y < dims.y; ++y)
      for (std::int64_t x = 0; x < dims.x; ++x) v.set_value(x, y, z, double(x) + 0.5);
  CompressedCase c(v, 16, 2);
  const double lo = 0, hi = 64;
  const TransferFunction tf({{0, {1, 0.6f, 0.2f, 0}},
                             {0.1, {1, 0.6f, 0.2f, 0}},
                             {0.5, {0.2f, 0.6f, 1, 0.04f}},
                             {0.9, {1, 1, 1, 0}},
                             {1, {1, 1, 1, 0}}});
  const lod::FrameBricks level0 = level_bricks(*c.ta, 0, c.ta->rank());
  const lod::FrameBricks level1 = level_bricks(*c.ta, 1, c.ta->rank());
  // Level-1 bricks everywhere, level-0 bricks in every other column of level-0 cells: most
  // coarse bricks share their cells with finer ones and are walked cell by cell.
  lod::FrameBricks mixed = level1;
  for (const auto& b : level0.bricks)
    if (b.key.x % 2 == 1) mixed.bricks.push_back(b);
  for (double az : {0.0, 40.0, 90.0}) {
    RayCaster rc(tf, options(0.5, true, false));
    const Camera cam = perspective_camera(dims, az, 20);
    const Image fine = rc.render(cam, FrameInput{&level0, &c.ta->geometry(), {}, lo, hi, nullptr});
    const Image coarse = rc.render(cam, FrameInput{&level1, &c.ta->geometry(), {}, lo, hi, nullptr});
    const Image both = rc.render(cam, FrameInput{&mixed, &c.ta->geometry(), {}, lo, hi, nullptr});
    SCOPED_TRACE("az " + std::to_string(az));
    const Diff d1 = max_diff(fine, coarse), d2 = max_diff(fine, both);
    EXPECT_LE(d1.max, 4) << d1.x << "," << d1.y;
    EXPECT_LE(d2.max, 4) << d2.x << "," << d2.y;
  }
}

TEST(RenderRayCaster, EmptyFrameAndMissingCellsShowTheBackground) {
  const Extent dims{32, 32, 32};
  const ta::OctreeGeometry g(dims, {16, 2});
  lod::FrameBricks none;
  RenderOptions o = options(0.5, true, true);
  o.background = {0.2f, 0.4f, 0.6f, 1};
  RayCaster rc(TransferFunction::preset("grayscale"), o);
  RenderStats stats;
  const Image img = rc.render(perspective_camera(dims, 10, 10, 32, 24), FrameInput{&none, &g, {}, 0, 1, nullptr}, &stats);
  for (const Rgba8& p : img.pixels()) EXPECT_EQ(p, (Rgba8{51, 102, 153, 255}));
  EXPECT_GT(stats.rays, 0u);
  EXPECT_EQ(stats.samples, 0u);
  const nlohmann::json j = stats_json(stats, &none.stats);
  EXPECT_TRUE(j.contains("render") && j.contains("load"));
}

TEST(RenderRayCaster, RejectsBadOptionsNamingTheField) {
  RenderOptions o;
  o.step = 0;
  EXPECT_EQ(test::error_of([&] { RayCaster(TransferFunction::preset("grayscale"), o); }),
            "RenderOptions::step: must be positive, got 0");
  o = {};
  o.background[1] = 2;
  EXPECT_EQ(test::parameter_of([&] { RayCaster(TransferFunction::preset("grayscale"), o); }), "RenderOptions::background");
}

TEST(RenderRayCaster, RejectsBricksOutsideTheGeometry) {
  const ta::OctreeGeometry g({32, 32, 32}, {16, 2});
  lod::FrameBricks f;
  f.bricks.push_back({{0, 5, 0, 0}, 1, nullptr, 0});
  RayCaster rc(TransferFunction::preset("grayscale"));
  EXPECT_THROW(rc.render(perspective_camera({32, 32, 32}, 0, 0, 8, 8), FrameInput{&f, &g, {}, 0, 1, nullptr}), Error);
  f.bricks[0] = {{0, 0, 0, 0}, 1, std::make_shared<std::vector<float>>(10), 0};
  EXPECT_THROW(rc.render(perspective_camera({32, 32, 32}, 0, 0, 8, 8), FrameInput{&f, &g, {}, 0, 1, nullptr}), Error);
}

TEST(RenderRayCaster, ThreadCountDoesNotChangeTheImage) {
  const Volume v = prisms_volume();
  const BrickedVolume b(v, 16, 2);
  RenderOptions one = options(0.5, true, true), two = one;
  one.threads = 1;
  const Camera cam = perspective_camera(v.dims(), 33, 21, 70, 50);
  const Image a = RayCaster(TransferFunction::preset("ct"), one).render(cam, b.frame(v, 0, 65535));
  const Image c = RayCaster(TransferFunction::preset("ct"), two).render(cam, b.frame(v, 0, 65535));
  EXPECT_EQ(a.pixels(), c.pixels());
}

// NaN and infinite voxels (masked cells, outside a field of view) are empty space, whole or in
// bricks, in the scalar and the 8-lane march: an all-NaN volume draws only the background, and
// prisms with NaN in their lower half (and an infinity here and there) draw something, less
// than the whole, the same in both marches.
TEST(RenderRayCaster, NanAndInfiniteVoxelsAreEmptySpace) {
  const Volume whole = prisms_volume().converted(DType::f32);
  Volume cut = whole, none = whole;
  const Extent d = whole.dims();
  for (std::int64_t z = 0; z < d.z; ++z)
    for (std::int64_t y = 0; y < d.y; ++y)
      for (std::int64_t x = 0; x < d.x; ++x) {
        none.set_value(x, y, z, std::numeric_limits<double>::quiet_NaN());
        if (y < d.y / 2) cut.set_value(x, y, z, std::numeric_limits<double>::quiet_NaN());
        else if ((x + y + z) % 97 == 0) cut.set_value(x, y, z, std::numeric_limits<double>::infinity());
      }
  const Camera cam = perspective_camera(d, 33, 21, 70, 50);
  auto brightness = [](const Image& img) {
    std::uint64_t sum = 0;
    for (const Rgba8& p : img.pixels()) sum += std::uint64_t(p.r) + p.g + p.b;
    return sum;
  };
  for (const bool bricked : {false, true}) {
    std::vector<Rgba8> scalar_pixels;
    for (const bool vector_march : {false, true}) {
      std::optional<ScopedIsaLimit> limit;
      if (!vector_march) limit.emplace(Isa::generic);
      RayCaster rc(TransferFunction::preset("ct"), options(0.5, true, true));
      auto draw = [&](const Volume& v) {
        if (!bricked) return rc.render(cam, v, 0, 65535);
        const BrickedVolume b(v, 16, 2);
        return rc.render(cam, b.frame(v, 0, 65535));
      };
      const std::string label = std::string(bricked ? "bricked" : "whole") + (vector_march ? ", 8 lanes" : ", scalar");
      EXPECT_EQ(brightness(draw(none)), 0u) << label;
      const Image cut_image = draw(cut);
      const std::uint64_t all = brightness(draw(whole)), part = brightness(cut_image);
      EXPECT_GT(part, 0u) << label;
      EXPECT_LT(part, all) << label;
      // The 8-lane march shades the NaN region's surface (one-sided gradients) as the scalar one.
      if (!vector_march) scalar_pixels = cut_image.pixels();
      else EXPECT_EQ(cut_image.pixels(), scalar_pixels) << label;
    }
  }
}

// ---- Empty-space skipping inside bricks ------------------------------------------------------


TEST(RenderRayCaster, CellRangesHoldEveryDilatedFootprint) {
  // Brute force: cell c's range must hold every voxel within [kCell c - d, kCell (c + 1) + d].
  const std::array<int, 3> n{13, 7, 9};
  std::vector<float> v(std::size_t(n[0] * n[1] * n[2]));
  std::uint32_t h = 12345;
  for (float& x : v) x = float((h = h * 1664525u + 1013904223u) >> 20);
  for (int d : {1, 2}) {
    const detail::CellRanges r = detail::compute_cell_ranges(v.data(), n, d);
    for (int k = 0; k < 3; ++k)  // positions [0, n - 1] in cells of kCell
      ASSERT_EQ(r.cells[std::size_t(k)], (n[std::size_t(k)] - 1 + detail::kCell - 1) / detail::kCell);
    for (int cz = 0; cz < r.cells[2]; ++cz)
      for (int cy = 0; cy < r.cells[1]; ++cy)
        for (int cx = 0; cx < r.cells[0]; ++cx) {
          float lo = 1e30f, hi = -1e30f;
          const std::array<int, 3> c{cx, cy, cz};
          std::array<int, 3> a{}, b{};
          for (int k = 0; k < 3; ++k) {
            a[k] = std::max(0, detail::kCell * c[k] - d);
            b[k] = std::min(n[k] - 1, detail::kCell * (c[k] + 1) + d);
          }
          for (int z = a[2]; z <= b[2]; ++z)
            for (int y = a[1]; y <= b[1]; ++y)
              for (int x = a[0]; x <= b[0]; ++x) {
                lo = std::min(lo, v[std::size_t((z * n[1] + y) * n[0] + x)]);
                hi = std::max(hi, v[std::size_t((z * n[1] + y) * n[0] + x)]);
              }
          const std::size_t i = std::size_t((cz * r.cells[1] + cy) * r.cells[0] + cx);
          EXPECT_EQ(r.lo[i], lo);
          EXPECT_EQ(r.hi[i], hi);
        }
  }
}

TEST(RenderRayCaster, SkippingEmptyCellsDoesNotChangeTheImage) {
  // Skipped segments are exactly those whose value range the TF maps to zero, and the front
  // value of a resumed run is re-sampled at the same lattice point, so the image may differ
  // only by float rounding of that position (one level), while far fewer samples are taken.
  // Anisotropic spacing: the local step along an axis is step * min spacing / spacing <= step,
  // which the cells' dilation covers.
  Volume v = prisms_volume();
  v.set_spacing({1.0, 1.5, 0.8});
  const BrickedVolume b(v, 16, 2);
  for (const char* tf_name : {"ct", "mri"})
    for (bool shading : {true, false})
      for (double step : {0.5, 1.0, 1.5}) {
        RenderOptions on = options(step, true, shading), off = on;
        off.skip_cells = false;
        const Camera cam = perspective_camera(v.dims(), 40, 30);
        RayCaster a(TransferFunction::preset(tf_name), on), c(TransferFunction::preset(tf_name), off);
        RenderStats sa, sc, va, vc;
        const Image bricks_on = a.render(cam, b.frame(v, 0, 65535), &sa);
        const Image bricks_off = c.render(cam, b.frame(v, 0, 65535), &sc);
        const Image single_on = a.render(cam, v, 0, 65535, &va);
        const Image single_off = c.render(cam, v, 0, 65535, &vc);
        SCOPED_TRACE(std::string(tf_name) + (shading ? " shaded" : " unshaded") + " step " + std::to_string(step));
        const Diff d1 = max_diff(bricks_on, bricks_off), d2 = max_diff(single_on, single_off);
        EXPECT_LE(d1.max, 1) << d1.x << "," << d1.y;
        EXPECT_LE(d2.max, 1) << d2.x << "," << d2.y;
        EXPECT_GT(sa.cells_empty, 0u);
        EXPECT_LT(sa.samples, sc.samples);
        EXPECT_LT(va.samples, vc.samples);
        // The second frame reuses the memoised ranges.
        RenderStats again;
        const Image repeat = a.render(cam, b.frame(v, 0, 65535), &again);
        EXPECT_EQ(again.cell_ranges_built, 0u);
        EXPECT_EQ(repeat.pixels(), bricks_on.pixels());
      }
}

// Root-mean-square difference of the colour channels, in 8-bit levels.
double rms_diff(const Image& a, const Image& b) {
  double sum = 0;
  for (int y = 0; y < a.height(); ++y)
    for (int x = 0; x < a.width(); ++x) {
      const Rgba8 p = a.at(x, y), q = b.at(x, y);
      sum += double(p.r - q.r) * (p.r - q.r) + double(p.g - q.g) * (p.g - q.g) + double(p.b - q.b) * (p.b - q.b);
    }
  return std::sqrt(sum / (3.0 * a.width() * a.height()));
}

TEST(RenderRayCaster, MidpointsAndShadingKeepTheStepErrorSmall) {
  // Errors against the same renderer at 1/16 voxel (RMS over the colour channels) on this
  // volume and these two views, at steps 0.5 and 1, measured:
  //  - unshaded: 0.34-0.37 and 0.91-0.96 with each segment classified through its midpoint
  //    value (split_pair); 0.89-0.94 and 2.78-2.81 with one linear segment between samples,
  //    whose chord cuts the prisms' edges short;
  //  - shaded: 0.93-0.97 and 2.61-2.63 with segments lit by the gradient at their midpoint and
  //    a shading threshold corrected to the step; lit by the back sample's gradient with a fixed
  //    threshold, the step-0.5 error was about 3 (3.0-3.4x the single-segment unshaded error).
  const Volume v = prisms_volume();
  const BrickedVolume b(v, 16, 2);
  for (double az : {30.0, 120.0}) {
    const Camera cam = perspective_camera(v.dims(), az, 20, 192, 144);
    auto error = [&](bool shading, double step) {
      RayCaster fine(TransferFunction::preset("ct"), options(1.0 / 16, true, shading));
      RayCaster coarse(TransferFunction::preset("ct"), options(step, true, shading));
      return rms_diff(fine.render(cam, b.frame(v, 0, 65535)), coarse.render(cam, b.frame(v, 0, 65535)));
    };
    SCOPED_TRACE("azimuth " + std::to_string(az));
    const double unshaded_half = error(false, 0.5), unshaded_one = error(false, 1.0);
    EXPECT_GT(unshaded_half, 0.1);  // the step matters at all
    EXPECT_LT(unshaded_half, 0.5);
    EXPECT_LT(unshaded_one, 1.5);
    EXPECT_LT(error(true, 0.5), 1.25);
    EXPECT_LT(error(true, 1.0), 3.0);
  }
}

TEST(RenderRayCaster, FaintMaterialIsLitAtEveryStep) {
  // A linear ramp along x under a transfer function of constant colour and opacity 0.01 per
  // voxel: every segment has the same gradient, so the image hardly depends on the step. Its
  // segments are 0.0006 opaque at step 1/16 and 0.005 at step 1/2, on either side of a fixed
  // 1/1024 threshold; corrected to the step, the threshold lights both alike.
  const Extent d{24, 24, 24};
  Volume v(d, DType::f32, {});
  auto samples = v.samples<float>();
  for (std::int64_t z = 0; z < d.z; ++z)
    for (std::int64_t y = 0; y < d.y; ++y)
      for (std::int64_t x = 0; x < d.x; ++x) samples[std::size_t((z * d.y + y) * d.x + x)] = float(x);
  const std::array<float, 4> faint{1, 1, 1, 0.01f};
  const TransferFunction tf({{0, faint}, {1, faint}});
  const Camera cam = perspective_camera(d, 30, 20, 64, 48);
  const Image fine = RayCaster(tf, options(1.0 / 16, true, true)).render(cam, v, 0, float(d.x - 1));
  const Image coarse = RayCaster(tf, options(0.5, true, true)).render(cam, v, 0, float(d.x - 1));
  const Image unlit = RayCaster(tf, options(1.0 / 16, true, false)).render(cam, v, 0, float(d.x - 1));
  EXPECT_LE(max_diff(fine, coarse).max, 2);
  EXPECT_GT(max_diff(fine, unlit).max, 8);  // lighting changes this image at all
}

// The 8-lane march, per instruction-set level it is compiled for.
class RenderRayMarchPerIsa : public test::IsaTest {};

TEST_P(RenderRayMarchPerIsa, MatchesTheScalarMarch) {
  // The AVX2 inner loop and its AVX-512 build repeat the scalar per-sample arithmetic operation
  // for operation (no FMA), but composite each 8-sample chunk at once: the transmittance in
  // front of each sample is a prefix product taken in another order, and the colours are summed
  // before they meet the accumulated opacity. That reassociation moves a pixel by a few float
  // ulps, so images agree within one level (as does a front re-sampled after skipped cells).
  // The two SIMD builds run the same operations: their images are identical.
  const Volume v = prisms_volume();
  const BrickedVolume b(v, 16, 2);
  const Camera cam = perspective_camera(v.dims(), 57, 12);
  auto render_with = [&](Isa isa, const RenderOptions& o, const char* tf_name, bool bricked) {
    const ScopedIsaLimit limit(isa);
    RayCaster rc(TransferFunction::preset(tf_name), o);
    return bricked ? rc.render(cam, b.frame(v, 0, 65535)) : rc.render(cam, v, 0, 65535);
  };
  for (const char* tf_name : {"ct", "mri", "grayscale"})
    for (bool shading : {true, false})
      for (bool skip : {true, false})
        for (bool bricked : {true, false}) {
          RenderOptions o = options(0.5, true, shading);
          o.skip_cells = skip;
          SCOPED_TRACE(std::string(tf_name) + (shading ? " shaded" : " unshaded") + (skip ? " skip" : "") +
                       (bricked ? " bricks" : " single"));
          const Image vec = render_with(isa(), o, tf_name, bricked);
          const Diff d = max_diff(vec, render_with(Isa::generic, o, tf_name, bricked));
          EXPECT_LE(d.max, 1) << d.x << "," << d.y;
          if (isa() > Isa::avx2) {  // the two SIMD builds
            EXPECT_EQ(vec.pixels(), render_with(Isa::avx2, o, tf_name, bricked).pixels());
          }
        }
}

TEST_P(RenderRayMarchPerIsa, MatchesTheScalarMarchForAnyExponent) {
  // The 8-lane march unrolls the default exponent (24) and loops over others; both must agree
  // with the scalar march (within the one level of chunked compositing, see above), and
  // shininess must matter.
  const Volume v = prisms_volume();
  const BrickedVolume b(v, 16, 2);
  const Camera cam = perspective_camera(v.dims(), 57, 12);
  Image first;
  for (int shininess : {24, 13, 1}) {
    RenderOptions o = options(0.5, true, true);
    o.skip_cells = false;
    o.light.shininess = shininess;
    SCOPED_TRACE(shininess);
    auto render_with = [&](Isa isa) {
      const ScopedIsaLimit limit(isa);
      return RayCaster(TransferFunction::preset("ct"), o).render(cam, b.frame(v, 0, 65535));
    };
    const Image a = render_with(isa());
    const Diff d = max_diff(a, render_with(Isa::generic));
    EXPECT_LE(d.max, 1) << d.x << "," << d.y;
    if (shininess == 24) first = a;
    else EXPECT_GT(max_diff(a, first).max, 1) << "shininess " << shininess << " looks like 24";
  }
}

STRATA_INSTANTIATE_PER_ISA(RenderRayMarchPerIsa, Isa::avx2, Isa::avx512);

TEST(RenderRayCaster, FixedSpecularExponentEqualsTheGenericLoop) {
  // The unrolled power takes the generic loop's products in the same order: same bits.
  std::uint32_t h = 777;
  for (int i = 0; i < 100000; ++i) {
    h = h * 1664525u + 1013904223u;
    const float x = i < 1000 ? float(i) / 999.0f : float(h >> 8) / float(1u << 24) * 1.5f;
    ASSERT_EQ(std::bit_cast<std::uint32_t>(detail::power_fixed<24>(x)),
              std::bit_cast<std::uint32_t>(detail::power(x, 24))) << x;
    ASSERT_EQ(std::bit_cast<std::uint32_t>(detail::specular_power(x, 24)),
              std::bit_cast<std::uint32_t>(detail::power(x, 24))) << x;
    ASSERT_EQ(detail::power_fixed<0>(x), 1.0f);
    ASSERT_EQ(std::bit_cast<std::uint32_t>(detail::power_fixed<1>(x)), std::bit_cast<std::uint32_t>(detail::power(x, 1)));
    ASSERT_EQ(std::bit_cast<std::uint32_t>(detail::power_fixed<13>(x)), std::bit_cast<std::uint32_t>(detail::power(x, 13)));
    ASSERT_EQ(std::bit_cast<std::uint32_t>(detail::power_fixed<64>(x)), std::bit_cast<std::uint32_t>(detail::power(x, 64)));
    ASSERT_EQ(std::bit_cast<std::uint32_t>(detail::specular_power(x, 13)), std::bit_cast<std::uint32_t>(detail::power(x, 13)));
  }
}

TEST(RenderRayCaster, RealignedChunksSkipOnlyTransparentSegments) {
  // Chunks of the 8-lane march restart at their first non-empty cell; with skipping on and off
  // the images agree within one level (re-sampled fronts) for several step sizes and views.
  const Volume v = prisms_volume();
  const BrickedVolume b(v, 16, 2);
  for (double step : {0.25, 0.5, 1.0})
    for (double az : {10.0, 57.0, 133.0}) {
      RenderOptions on = options(step, true, true), off = on;
      off.skip_cells = false;
      const Camera cam = perspective_camera(v.dims(), az, 25);
      SCOPED_TRACE(std::to_string(step) + " " + std::to_string(az));
      RenderStats sa, sc;
      const Image a = RayCaster(TransferFunction::preset("ct"), on).render(cam, b.frame(v, 0, 65535), &sa);
      const Image c = RayCaster(TransferFunction::preset("ct"), off).render(cam, b.frame(v, 0, 65535), &sc);
      const Diff d = max_diff(a, c);
      EXPECT_LE(d.max, 1) << d.x << "," << d.y;
      EXPECT_LT(sa.samples, sc.samples);
    }
}

TEST(RenderRayCaster, PreparedVolumeReusesItsCellsPerRayCaster) {
  // A prepared volume renders exactly as the one-off path, builds its empty-space cells once
  // per ray caster, and rebuilds them when another caster (another transfer function) uses it.
  const Volume v = prisms_volume();
  const Camera cam = perspective_camera(v.dims(), 40, 20);
  RayCaster ct(TransferFunction::preset("ct"), options(0.5, true, true));
  RayCaster mri(TransferFunction::preset("mri"), options(0.5, true, true));
  PreparedVolume prepared(v, 0, 65535);
  RenderStats first, second, other, back;
  const Image a = ct.render(cam, prepared, &first);
  const Image b = ct.render(cam, prepared, &second);
  const Image c = mri.render(cam, prepared, &other);
  const Image d = ct.render(cam, prepared, &back);
  EXPECT_EQ(first.cell_ranges_built, 1u);
  EXPECT_EQ(second.cell_ranges_built, 0u);
  EXPECT_EQ(other.cell_ranges_built, 1u);
  EXPECT_EQ(back.cell_ranges_built, 1u);
  EXPECT_GT(second.cells_empty, 0u);
  EXPECT_EQ(second.cells_empty, first.cells_empty);
  EXPECT_NE(other.cells_empty, first.cells_empty);  // another TF empties other cells
  const Image one_off = ct.render(cam, v, 0, 65535);
  EXPECT_EQ(a.pixels(), one_off.pixels());
  EXPECT_EQ(b.pixels(), one_off.pixels());
  EXPECT_EQ(d.pixels(), one_off.pixels());
  EXPECT_EQ(c.pixels(), mri.render(cam, v, 0, 65535).pixels());
  EXPECT_GT(max_diff(a, c).max, 10);
}
