// Label-volume rendering from the Mixture Graph palette: colour maps (JSON, hash), the
// LabelScene's id cache and palette rebuilds, and the ray caster's colours, LOD choice and
// empty-space skipping on a small synthetic segmentation.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "strata/core/error.hpp"
#include "strata/mixture/encoded_labels.hpp"
#include "strata/render/label_color_map.hpp"
#include "strata/render/label_raycaster.hpp"
#include "strata/render/label_scene.hpp"
#include "support/label_volumes.hpp"
#include "support/test_support.hpp"

namespace strata::render {
namespace {

constexpr std::int64_t kA = 17, kB = 42, kC = 99;  // label values (0 = background)
constexpr LabelRgba kColorA{0.9f, 0.1f, 0.1f, 1.0f};
constexpr LabelRgba kColorB{0.1f, 0.8f, 0.2f, 1.0f};
constexpr LabelRgba kColorC{0.2f, 0.3f, 0.95f, 1.0f};
constexpr LabelRgba kBackground{0.1f, 0.15f, 0.2f, 1.0f};

// 32^3: box A at x in [2, 12), box B at x in [20, 30) (both y, z in [2, 30)), and a cube C
// [13, 19)^3 in the middle between them.
Volume make_boxes() {
  Volume v(Extent{32, 32, 32}, DType::u16);
  auto s = v.view<std::uint16_t>();
  for (std::int64_t z = 0; z < 32; ++z)
    for (std::int64_t y = 0; y < 32; ++y)
      for (std::int64_t x = 0; x < 32; ++x) {
        const bool yz = y >= 2 && y < 30 && z >= 2 && z < 30;
        const bool mid = x >= 13 && x < 19 && y >= 13 && y < 19 && z >= 13 && z < 19;
        s(x, y, z) = yz && x >= 2 && x < 12 ? kA : yz && x >= 20 && x < 30 ? kB : mid ? kC : 0;
      }
  return v;
}

LabelColorMap box_colors() {
  LabelColorMap m = LabelColorMap::uniform({1, 1, 1, 1});
  m.set(kA, kColorA);
  m.set(kB, kColorB);
  m.set(kC, kColorC);
  return m;
}

// Looks along +y: image x = world x, image row 0 = top (world z = 32). 64 x 64 pixels over
// 32 x 32 world units, so pixel (px, py) sees world x = (px + 0.5) / 2, z = 32 - (py + 0.5) / 2.
Camera front_camera(Projection projection = Projection::orthographic) {
  CameraSpec spec;
  spec.width = spec.height = 64;
  spec.projection = projection;
  spec.orbit.azimuth_deg = 0;
  spec.orbit.elevation_deg = 0;
  spec.orbit.distance = projection == Projection::orthographic ? 100 : 0;
  spec.ortho_height = 32;
  return Camera(spec, Extent{32, 32, 32}, Spacing{});
}

int px_of(double world_x) { return int(world_x * 2); }
int py_of(double world_z) { return int((32 - world_z) * 2); }

struct Encoded {
  test::TempDir dir;
  std::unique_ptr<mixture::EncodedLabels> labels;
  Encoded() {
    mixture::EncodeOptions o;
    o.measure_error = false;
    mixture::encode_labels(make_boxes(), dir / "boxes.strata", o);
    labels = std::make_unique<mixture::EncodedLabels>(dir / "boxes.strata");
  }
};

LabelRenderOptions options() {
  LabelRenderOptions o;
  o.background = kBackground;
  return o;
}

// Largest per-channel difference in 1/255 units.
int difference(const Rgba8& p, const LabelRgba& c) {
  const auto d = [](std::uint8_t v, float f) { return std::abs(int(v) - int(std::lround(f * 255))); };
  return std::max({d(p.r, c.r), d(p.g, c.g), d(p.b, c.b), d(p.a, c.a)});
}

std::array<double, 3> mean_color(const Image& image) {
  std::array<double, 3> m{0, 0, 0};
  for (const Rgba8& p : image.pixels()) m[0] += p.r, m[1] += p.g, m[2] += p.b;
  for (double& v : m) v /= double(image.pixels().size()) * 255.0;
  return m;
}

using strata::test::error_of;

// Early termination at 0.99 leaves 1% of the background behind an opaque object.
constexpr int kOpaqueTolerance = 4;

TEST(RenderLabelRender, OrthographicPixelsShowTheirLabelColour) {
  Encoded e;
  LabelScene scene(*e.labels, box_colors());
  LabelRenderStats stats;
  // Trilinear, so every object ends where its voxels do (smooth boundaries reach a voxel out).
  LabelRenderOptions o = options();
  o.smooth = false;
  const Image image = render_labels(scene, front_camera(), o, &stats);
  ASSERT_EQ(image.width(), 64);
  EXPECT_EQ(stats.finest_level, 0);  // half a voxel per pixel: the finest level
  EXPECT_LE(difference(image.at(px_of(7), py_of(16)), kColorA), kOpaqueTolerance);
  EXPECT_LE(difference(image.at(px_of(25), py_of(10)), kColorB), kOpaqueTolerance);
  EXPECT_LE(difference(image.at(px_of(16), py_of(16)), kColorC), kOpaqueTolerance);
  // Outside every object: exactly the background.
  for (auto [x, z] : {std::pair{0.2, 31.8}, {16.0, 28.0}, {16.0, 4.0}, {31.8, 0.2}, {7.0, 31.0}})
    EXPECT_LE(difference(image.at(px_of(x), py_of(z)), kBackground), 0) << x << "," << z;
  EXPECT_GT(stats.samples, 0u);
  EXPECT_GT(stats.terminated_rays, 0u);
  EXPECT_EQ(stats.rays, 64u * 64u);  // the orthographic frame is exactly the volume's face
}

TEST(RenderLabelRender, ColourMapChangeRebuildsPaletteWithoutReadingIds) {
  Encoded e;
  LabelScene scene(*e.labels, box_colors());
  LabelRenderStats first, second;
  const Image before = render_labels(scene, front_camera(), options(), &first);
  const std::uint64_t decoded = scene.id_voxels_decoded();
  EXPECT_EQ(first.ids_decoded, decoded);
  EXPECT_GT(decoded, 32u * 32u * 32u);  // level 0 and the coarser levels for skipping

  LabelColorMap recoloured = box_colors();
  const LabelRgba yellow{0.95f, 0.9f, 0.1f, 1.0f};
  recoloured.set(kA, yellow);
  scene.set_color_map(recoloured);
  const Image after = render_labels(scene, front_camera(), options(), &second);

  EXPECT_EQ(second.ids_decoded, 0u);
  EXPECT_EQ(scene.id_voxels_decoded(), decoded);
  EXPECT_EQ(scene.palette_builds(), 2u);
  EXPECT_FALSE(before.pixels() == after.pixels());
  EXPECT_LE(difference(after.at(px_of(7), py_of(16)), yellow), kOpaqueTolerance);
  EXPECT_EQ(after.at(px_of(16), py_of(16)), before.at(px_of(16), py_of(16)));  // C unchanged

  // An unchanged colour map rebuilds nothing.
  LabelRenderStats third;
  render_labels(scene, front_camera(), options(), &third);
  EXPECT_EQ(third.palette_ms, 0.0);
  EXPECT_EQ(scene.palette_builds(), 2u);
}

TEST(RenderLabelRender, AllTransparentRendersBackgroundAndSkipsEverything) {
  Encoded e;
  LabelScene scene(*e.labels, LabelColorMap::uniform({1, 0, 0, 0}));
  LabelRenderStats stats;
  const Image image = render_labels(scene, front_camera(), options(), &stats);
  for (const Rgba8& p : image.pixels()) ASSERT_LE(difference(p, kBackground), 0);
  EXPECT_FALSE(scene.anything_visible());
  EXPECT_EQ(stats.samples, 0u);
  EXPECT_EQ(stats.rays, 64u * 64u);
  EXPECT_EQ(stats.skipped_cubes, stats.rays);  // one jump over the root cube per ray
}

TEST(RenderLabelRender, SkippingEmptySpaceKeepsTheImage) {
  Encoded e;
  LabelScene scene(*e.labels, box_colors());
  LabelRenderOptions with = options(), without = options();
  without.skip_empty = false;
  LabelRenderStats s_with, s_without;
  // Without skipping no skip grid is built (rendered first, on a fresh scene).
  const Image b = render_labels(scene, front_camera(Projection::perspective), without, &s_without);
  for (int l = LabelScene::kFinestSkipLevel; l < scene.level_count(); ++l) EXPECT_TRUE(scene.occupied(l).empty()) << l;
  const Image a = render_labels(scene, front_camera(Projection::perspective), with, &s_with);
  EXPECT_FALSE(scene.occupied(scene.level_count() - 1).empty());
  EXPECT_GT(s_with.skipped_cubes, 0u);
  EXPECT_EQ(s_without.skipped_cubes, 0u);
  // --stats carries the counters under "render".
  const nlohmann::json j = stats_json(s_with);
  EXPECT_EQ(j["render"]["skipped_cubes"].get<std::uint64_t>(), s_with.skipped_cubes);
  EXPECT_EQ(j["render"]["samples"].get<std::uint64_t>(), s_with.samples);
  EXPECT_EQ(j["render"]["levels"], nlohmann::json({s_with.finest_level, s_with.coarsest_level}));
  EXPECT_LT(s_with.samples, s_without.samples);
  int worst = 0;
  for (std::size_t i = 0; i < a.pixels().size(); ++i) {
    const Rgba8 p = a.pixels()[i], q = b.pixels()[i];
    worst = std::max({worst, std::abs(p.r - q.r), std::abs(p.g - q.g), std::abs(p.b - q.b)});
  }
  EXPECT_LE(worst, 3);  // only where step positions restart after a skipped cube
}

TEST(RenderLabelRender, CoarserLodBiasKeepsObjectsAndAverageColour) {
  Encoded fine_file, coarse_file;
  LabelScene fine(*fine_file.labels, box_colors()), coarse(*coarse_file.labels, box_colors());
  LabelRenderOptions biased = options();
  biased.lod_bias = 3;  // level 0 -> level 2 (lod -1 + 3)
  LabelRenderStats s_fine, s_coarse;
  const Image a = render_labels(fine, front_camera(), options(), &s_fine);
  const Image b = render_labels(coarse, front_camera(), biased, &s_coarse);
  EXPECT_EQ(s_coarse.finest_level, 2);
  // Only levels 2.. were decoded: no level-0 or level-1 payload.
  std::uint64_t expected = 0;
  for (int l = 2; l < coarse.level_count(); ++l) expected += std::uint64_t(coarse.level_dims(l).voxel_count());
  EXPECT_EQ(s_coarse.ids_decoded, expected);
  EXPECT_LT(s_coarse.samples, s_fine.samples);
  // The boxes are 10 voxels thick along x: their centres stay their colour.
  EXPECT_LE(difference(b.at(px_of(7), py_of(16)), kColorA), kOpaqueTolerance);
  EXPECT_LE(difference(b.at(px_of(25), py_of(16)), kColorB), kOpaqueTolerance);
  EXPECT_FALSE(a.pixels() == b.pixels());

  // Pre-filtered palette colours: with faint labels compositing is close to linear, so the
  // blurred picture keeps the fine picture's mean colour (opaque objects instead grow by
  // the blur, since any partial coverage saturates along a long ray).
  LabelColorMap faint;
  faint.set_default({0, 0, 0, 0});
  faint.set(kA, {1, 0, 0, 0.02f});
  faint.set(kB, {0, 1, 0, 0.02f});
  faint.set(kC, {0, 0, 1, 0.05f});
  fine.set_color_map(faint);
  coarse.set_color_map(faint);
  LabelRenderOptions black = options(), black_biased = biased;
  black.background = black_biased.background = {0, 0, 0, 1};
  const auto ma = mean_color(render_labels(fine, front_camera(), black));
  const auto mb = mean_color(render_labels(coarse, front_camera(), black_biased));
  for (int c = 0; c < 3; ++c) {
    EXPECT_GT(ma[std::size_t(c)], 0.005) << "channel " << c;
    EXPECT_NEAR(ma[std::size_t(c)], mb[std::size_t(c)], 0.1 * ma[std::size_t(c)]) << "channel " << c;
  }
}

TEST(RenderLabelRender, BlendingLevelsAndPerspectiveRender) {
  Encoded e;
  LabelScene scene(*e.labels, box_colors());
  LabelRenderOptions o = options();
  o.blend_levels = true;
  o.lod_bias = 1.5;
  LabelRenderStats stats;
  const Image image = render_labels(scene, front_camera(Projection::perspective), o, &stats);
  EXPECT_GT(stats.samples, 0u);
  // The volume is centred: the image centre looks through the middle cube.
  EXPECT_LE(difference(image.at(32, 32), kColorC), 12);
  EXPECT_LE(difference(image.at(0, 0), kBackground), 0);
}

TEST(RenderLabelRender, SemiTransparentLabelFollowsOpacityCorrection) {
  Encoded e;
  LabelColorMap m = box_colors();
  m.set(kC, {1, 1, 1, 0.1f});
  m.set(kA, {0, 0, 0, 0});
  m.set(kB, {0, 0, 0, 0});
  LabelScene scene(*e.labels, m);
  LabelRenderOptions o = options();
  o.background = {0, 0, 0, 1};
  const Image image = render_labels(scene, front_camera(), o);
  // 6 voxels of alpha 0.1 each, white over black: 1 - 0.9^6, minus the softened faces
  // (trilinear samples within half a voxel of the faces see part background).
  const double expected = 1 - std::pow(0.9, 6);
  const double got = image.at(px_of(16), py_of(16)).r / 255.0;
  EXPECT_NEAR(got, expected, 0.06);
}

TEST(RenderLabelRender, HeadlightShadingDarkensOnlyObliqueSurfaces) {
  Encoded e;
  LabelScene scene(*e.labels, box_colors());
  LabelRenderOptions o = options();
  o.shading = true;
  // Looking straight at the box faces: their normals face the viewer, so full brightness.
  const Image straight = render_labels(scene, front_camera(), o);
  EXPECT_LE(difference(straight.at(px_of(7), py_of(16)), kColorA), kOpaqueTolerance);
  EXPECT_LE(difference(straight.at(0, 0), kBackground), 0);
  // From 45 degrees the same faces are oblique: darker, never brighter, hue kept.
  CameraSpec spec = front_camera().spec();
  spec.orbit.azimuth_deg = 45;
  const Camera oblique(spec, Extent{32, 32, 32}, Spacing{});
  LabelRenderOptions flat = o;
  flat.shading = false;
  const Image lit = render_labels(scene, oblique, o), unlit = render_labels(scene, oblique, flat);
  int darker = 0;
  for (std::size_t i = 0; i < lit.pixels().size(); ++i) {
    EXPECT_LE(lit.pixels()[i].r, unlit.pixels()[i].r + 1);
    darker += lit.pixels()[i].r + 8 < unlit.pixels()[i].r;
  }
  EXPECT_GT(darker, 100);
}

TEST(RenderLabelColorMap, HashColoursAreDeterministicAndBackgroundIsTransparent) {
  const LabelColorMap m;
  EXPECT_EQ(m.color_of(0).a, 0.0f);
  EXPECT_EQ(m.color_of(5), hash_label_color(5));
  EXPECT_EQ(m.color_of(5).a, 1.0f);
  EXPECT_FALSE(m.color_of(5) == m.color_of(6));
  const LabelRgba c = hash_label_color(123456789);
  EXPECT_GE(std::max({c.r, c.g, c.b}), 0.75f - 1e-6f);  // never near-black
  const mixture::LabelMap labels(DType::u16, {0, 5, 9});
  const std::vector<float> rows = m.premultiplied_sources(labels);
  ASSERT_EQ(rows.size(), 12u);
  EXPECT_EQ(rows[3], 0.0f);
  EXPECT_FLOAT_EQ(rows[4], m.color_of(5).r);
}

TEST(RenderLabelColorMap, JsonColoursByOriginalLabelValue) {
  const auto j = nlohmann::json::parse(R"({"default": [0.5, 0.5, 0.5, 0.25],
      "labels": {"17": [1, 0, 0], "-3": [0, 1, 0, 0.5], "0": [0, 0, 1, 1]}})");
  const LabelColorMap m = LabelColorMap::from_json(j, "map.json");
  EXPECT_EQ(m.color_of(17), (LabelRgba{1, 0, 0, 1}));
  EXPECT_EQ(m.color_of(-3), (LabelRgba{0, 1, 0, 0.5f}));
  EXPECT_EQ(m.color_of(0), (LabelRgba{0, 0, 1, 1}));
  EXPECT_EQ(m.color_of(4), (LabelRgba{0.5f, 0.5f, 0.5f, 0.25f}));
  const LabelColorMap hashed =
      LabelColorMap::from_json(nlohmann::json::parse(R"({"default": "hash", "hash_opacity": 0.5})"), "h.json");
  EXPECT_EQ(hashed.color_of(4), hash_label_color(4, 0.5f));
  EXPECT_EQ(hashed.color_of(0).a, 0.0f);
}

TEST(RenderLabelColorMap, JsonErrorsNameFileAndField) {
  const auto parse = [](const char* text) {
    return error_of([&] { LabelColorMap::from_json(nlohmann::json::parse(text), "cmap.json"); });
  };
  EXPECT_NE(parse(R"({"labels": {"17": [1, 0, 2]}})").find("cmap.json: labels.17[2]"), std::string::npos);
  EXPECT_NE(parse(R"({"labels": {"17": [1, 0]}})").find("cmap.json: labels.17"), std::string::npos);
  EXPECT_NE(parse(R"({"labels": {"x7": [1, 0, 0]}})").find("cmap.json: labels.x7"), std::string::npos);
  EXPECT_NE(parse(R"({"labels": [1]})").find("cmap.json: labels"), std::string::npos);
  EXPECT_NE(parse(R"({"default": "rainbow"})").find("cmap.json: default"), std::string::npos);
  EXPECT_NE(parse(R"({"hash_opacity": 3})").find("cmap.json: hash_opacity"), std::string::npos);
  EXPECT_NE(parse(R"({"colours": {}})").find("cmap.json: colours: unknown field"), std::string::npos);
  EXPECT_NE(parse("[1, 2]").find("cmap.json"), std::string::npos);

  test::TempDir dir;
  const auto bad = dir / "broken.json";
  std::ofstream(bad) << "{\"labels\": ";
  EXPECT_NE(error_of([&] { LabelColorMap::load(bad); }).find("broken.json: JSON"), std::string::npos);
  EXPECT_NE(error_of([&] { LabelColorMap::load(dir / "missing.json"); }).find("missing.json"), std::string::npos);
  const auto good = dir / "good.json";
  std::ofstream(good) << R"({"labels": {"17": [0.2, 0.4, 0.6, 0.8]}})";
  EXPECT_EQ(LabelColorMap::load(good).color_of(17), (LabelRgba{0.2f, 0.4f, 0.6f, 0.8f}));
}

// The row-by-row position of a ball's silhouette, zoomed in to 8 pixels per voxel on its upper
// left flank (45 degrees, where a voxelised sphere's boundary steps one voxel in x for every
// voxel in z), and its largest second difference across rows: the size of the kinks.
int silhouette_kink(bool smooth) {
  test::TempDir dir;
  mixture::EncodeOptions o;
  o.measure_error = false;
  mixture::encode_labels(test::label_ball(32, 10, 16, 7), dir / "ball.strata", o);
  const mixture::EncodedLabels labels(dir / "ball.strata");
  LabelScene scene(labels, LabelColorMap::uniform({1, 1, 1, 1}));
  CameraSpec spec;
  spec.width = spec.height = 64;
  spec.projection = Projection::orthographic;
  spec.orbit.azimuth_deg = 0;  // looking along +y: image x = world x, rows down world z
  spec.orbit.elevation_deg = 0;
  spec.orbit.distance = 100;
  spec.orbit.target = {16 - 7.07, 16, 16 + 7.07};
  spec.orbit.target_set = true;
  spec.ortho_height = 8;
  LabelRenderOptions opt;
  opt.background = {0, 0, 0, 1};
  opt.smooth = smooth;
  const Image image = render_labels(scene, Camera(spec, Extent{32, 32, 32}, Spacing{}), opt);
  std::vector<int> edge;  // first column at least half white, per row
  for (int y = 0; y < 64; ++y) {
    int x = 0;
    while (x < 64 && image.at(x, y).r < 128) ++x;
    edge.push_back(x);
  }
  int kink = 0;
  for (int y = 1; y + 1 < 64; ++y) kink = std::max(kink, std::abs(edge[std::size_t(y + 1)] - 2 * edge[std::size_t(y)] + edge[std::size_t(y - 1)]));
  return kink;
}

TEST(RenderLabelRender, SmoothBoundariesHaveNoVoxelStaircaseWhenZoomed) {
  // Trilinear coverage draws the voxelised sphere's steps: the silhouette holds its column for
  // a voxel's rows (8), then jumps. The B-spline's boundary is C2-smooth: on this 45-degree
  // flank the edge moves about a pixel per row, its curvature adds under 0.1 pixel per row,
  // and finding it to whole pixels errs by under one in each of the three rows of a second
  // difference (weights 1, 2, 1): below 4. Measured: 2 smooth, 10 trilinear.
  EXPECT_LE(silhouette_kink(true), 3);
  EXPECT_GE(silhouette_kink(false), 6);  // the view does show the staircase without smoothing
}

TEST(RenderLabelRender, RejectsBadOptions) {
  Encoded e;
  LabelScene scene(*e.labels);
  LabelRenderOptions o;
  o.step = 0;
  EXPECT_NE(error_of([&] { render_labels(scene, front_camera(), o); }).find("step"), std::string::npos);
  o = {};
  o.finest_level = 99;
  EXPECT_NE(error_of([&] { render_labels(scene, front_camera(), o); }).find("finest_level"), std::string::npos);
}

}  // namespace
}  // namespace strata::render
