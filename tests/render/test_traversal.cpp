// The traversal the scalar and the label ray casters share (src/render/traversal.hpp): tiles
// that cover every pixel once on any number of threads, the slab test and box exits under
// either caster's parameter rule, and both casters casting exactly the rays that meet the
// volume's box and sampling exactly the bricks those rays meet.
#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include "render/traversal.hpp"
#include "strata/core/vec3.hpp"
#include "strata/mixture/encoded_labels.hpp"
#include "strata/render/camera.hpp"
#include "strata/render/label_raycaster.hpp"
#include "strata/render/label_scene.hpp"
#include "strata/render/raycaster.hpp"
#include "strata/render/transfer_function.hpp"
#include "strata/ta/octree.hpp"
#include "support/test_support.hpp"

namespace strata::render {
namespace {

using detail::box_exit;
using detail::clip_to_box;
using detail::DividedByDirection;
using detail::for_each_pixel;
using detail::TileGrid;
using detail::TimesInverse;

constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(RenderTraversal, TheLastTileColumnAndRowAreCutToTheImage) {
  const TileGrid grid{37, 20, 16};
  EXPECT_EQ(grid.columns(), 3);
  EXPECT_EQ(grid.rows(), 2);
  EXPECT_EQ(grid.count(), 6);
  const TileGrid::Rect first = grid.at(0), corner = grid.at(5), cut = grid.at(2);
  EXPECT_EQ((std::array{first.x0, first.y0, first.x1, first.y1}), (std::array{0, 0, 16, 16}));
  EXPECT_EQ((std::array{cut.x0, cut.y0, cut.x1, cut.y1}), (std::array{32, 0, 37, 16}));
  EXPECT_EQ((std::array{corner.x0, corner.y0, corner.x1, corner.y1}), (std::array{32, 16, 37, 20}));
  EXPECT_EQ((TileGrid{5, 5, 100}).count(), 1);
}

// Each thread's worker counts its pixels; every pixel is cast once, every worker merged once.
TEST(RenderTraversal, EveryPixelIsCastOnceOnAnyNumberOfThreads) {
  struct Counter {
    std::vector<std::atomic<int>>* visits;
    int width;
    std::int64_t pixels = 0;
    int last_x = -1, last_y = -1;
    bool row_by_row = true;  // inside a tile: x increases along a row, rows go down
    void operator()(int px, int py) {
      ++(*visits)[std::size_t(py) * std::size_t(width) + std::size_t(px)];
      if (py == last_y && px <= last_x) row_by_row = false;
      last_x = px, last_y = py;
      ++pixels;
    }
  };
  for (const auto [width, height, tile] : {std::array{1, 1, 16}, std::array{37, 20, 16}, std::array{64, 48, 16},
                                           std::array{5, 9, 1}, std::array{10, 10, 100}, std::array{17, 3, 4}})
    for (int threads : {1, 3}) {
      std::vector<std::atomic<int>> visits(std::size_t(width) * std::size_t(height));
      std::atomic<int> made{0};
      int merged = 0;
      std::int64_t total = 0;
      bool ordered = true;
      for_each_pixel(
          TileGrid{width, height, tile}, threads,
          [&] {
            ++made;
            return Counter{&visits, width};
          },
          [&](const Counter& c) {
            ++merged;
            total += c.pixels;
            ordered = ordered && c.row_by_row;
          });
      EXPECT_EQ(merged, made.load()) << width << "x" << height << " tile " << tile << ", " << threads << " threads";
      EXPECT_EQ(total, std::int64_t(width) * height);
      EXPECT_TRUE(ordered);
      for (std::size_t i = 0; i < visits.size(); ++i) ASSERT_EQ(visits[i].load(), 1) << "pixel " << i;
    }
}

// The slab test under both parameter rules: directions of 0 and +-1 and 0.5 keep every
// product and quotient exact, so both rules give the same intervals.
TEST(RenderTraversal, ClippingIsTheSlabTestUnderEitherRule) {
  const std::array<double, 3> hi{4, 3, 2};
  auto both = [&](std::array<double, 3> o, std::array<double, 3> d) {
    std::array<double, 3> inv{};
    for (int a = 0; a < 3; ++a) inv[std::size_t(a)] = d[std::size_t(a)] != 0 ? 1.0 / d[std::size_t(a)] : 0.0;
    const auto times = clip_to_box(o, d, hi, TimesInverse{inv});
    const Vec3 ov{o[0], o[1], o[2]}, dv{d[0], d[1], d[2]}, hv{hi[0], hi[1], hi[2]};
    const auto divided = clip_to_box(ov, dv, hv, DividedByDirection<Vec3>{dv});
    EXPECT_EQ(times, divided);
    return times;
  };
  EXPECT_EQ(both({-1, 1, 1}, {1, 0, 0}), (std::pair{1.0, 5.0}));     // enters at x = 0, leaves at x = 4
  EXPECT_EQ(both({2, 1, 1}, {0, 1, 0}), (std::pair{0.0, 2.0}));      // starts inside
  EXPECT_EQ(both({-2, -1, 1}, {1, 0.5, 0}), (std::pair{2.0, 6.0}));  // y enters at t = 2, x leaves at t = 6
  const auto parallel_outside = both({-1, 5, 1}, {1, 0, 0});
  EXPECT_GE(parallel_outside.first, parallel_outside.second);
  const auto away = both({-1, 1, 1}, {-1, 0, 0});
  EXPECT_GE(away.first, away.second);
  const auto past = both({-1, 1, 5}, {1, 0, -0.5});  // meets z = 2 only after x left the box
  EXPECT_GE(past.first, past.second);
}

TEST(RenderTraversal, ABoxIsLeftThroughTheFirstFaceAhead) {
  const std::array<double, 3> lo{0, 0, 0}, hi{4, 3, 2};
  const std::array<double, 3> o{1, 1, 1};
  auto exit = [&](std::array<double, 3> d) {
    std::array<double, 3> inv{};
    for (int a = 0; a < 3; ++a) inv[std::size_t(a)] = d[std::size_t(a)] != 0 ? 1.0 / d[std::size_t(a)] : 0.0;
    const double times = box_exit(o, d, lo, hi, TimesInverse{inv});
    EXPECT_EQ(times, box_exit(o, d, lo, hi, DividedByDirection<std::array<double, 3>>{d}));
    return times;
  };
  EXPECT_EQ(exit({1, 0, 0}), 3.0);
  EXPECT_EQ(exit({0, -1, 0}), 1.0);
  EXPECT_EQ(exit({1, 1, 0.5}), 2.0);  // y reaches 3 first
  EXPECT_EQ(exit({0, 0, 0}), kInf);
}

// 32^3 voxels seen from -y by an orthographic camera of 64 x 64 pixels over 64 x 64 world
// units: pixel (px, py) looks at x = px - 15.5, z = 47.5 - py, so exactly the rays of pixels
// 16..47 in both directions meet the box: 1024.
Camera box_camera() {
  CameraSpec spec;
  spec.width = spec.height = 64;
  spec.projection = Projection::orthographic;
  spec.orbit.azimuth_deg = 0;
  spec.orbit.elevation_deg = 0;
  spec.orbit.distance = 100;
  spec.ortho_height = 64;
  return Camera(spec, Extent{32, 32, 32}, Spacing{});
}

// Value 1 where x < 8, else 0.
Volume slab_volume() {
  Volume v(Extent{32, 32, 32}, DType::u8);
  auto s = v.view<std::uint8_t>();
  for (std::int64_t z = 0; z < 32; ++z)
    for (std::int64_t y = 0; y < 32; ++y)
      for (std::int64_t x = 0; x < 32; ++x) s(x, y, z) = x < 8 ? 1 : 0;
  return v;
}

TEST(RenderTraversal, TheScalarCasterCastsTheRaysAndSamplesTheBricksTheyMeet) {
  const Volume v = slab_volume();
  // Faint, so no ray terminates before the far side: up to 0.5 transparent (bricks of zeros are
  // culled), 1 barely visible.
  RayCaster caster(TransferFunction::from_points_text("0:1:1:1:0;0.5:1:1:1:0;1:1:1:1:0.02"));
  RenderStats stats;
  caster.render(box_camera(), v, 0, 1, &stats);
  EXPECT_EQ(stats.rays, 1024u);

  // 16-wide bricks (core 12): 3 x 3 x 3 of them; only those of x index 0 hold the slab (their
  // overlap reaches x = 14, the others start at x = 10 and hold zeros only).
  const ta::OctreeGeometry geometry(v.dims(), {16, 2});
  const lod::FrameBricks bricks = bricks_from_volume(v, geometry);
  FrameInput input;
  input.bricks = &bricks;
  input.geometry = &geometry;
  input.spacing = v.spacing();
  input.value_min = 0;
  input.value_max = 1;
  caster.render(box_camera(), input, &stats);
  EXPECT_EQ(stats.rays, 1024u);
  EXPECT_EQ(stats.bricks_in_frame, 27u);
  EXPECT_EQ(stats.bricks_culled, 18u);
  EXPECT_EQ(stats.bricks_sampled, 9u) << "every visible brick lies on some ray, no culled one is sampled";
}

TEST(RenderTraversal, TheLabelCasterCastsTheRaysThatMeetTheBox) {
  test::TempDir dir;
  mixture::EncodeOptions o;
  o.measure_error = false;
  mixture::encode_labels(slab_volume(), dir / "slab.strata", o);
  const mixture::EncodedLabels labels(dir / "slab.strata");
  LabelScene scene(labels, LabelColorMap::uniform({1, 1, 1, 0.02f}));
  LabelRenderStats stats;
  render_labels(scene, box_camera(), {}, &stats);
  EXPECT_EQ(stats.rays, 1024u);
  EXPECT_EQ(stats.terminated_rays, 0u);
  EXPECT_GT(stats.skipped_cubes, 0u) << "the empty side is skipped";
}

}  // namespace
}  // namespace strata::render
