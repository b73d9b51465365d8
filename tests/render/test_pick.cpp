// Picking (strata/render/pick.hpp, RenderSession::pick): the grid walk visits every voxel a ray
// crosses once, front to back, with its length inside; a pick stops at the first visible label
// (hidden labels are passed through) or where the accumulated opacity reaches one half.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <vector>

#include "strata/core/error.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/mixture/encoded_labels.hpp"
#include "strata/render/pick.hpp"
#include "strata/render/render_session.hpp"
#include "support/test_support.hpp"

namespace strata::render {
namespace {

struct Visit {
  Extent voxel;
  double length;
};

std::vector<Visit> walk_all(const Ray& ray, const Extent& dims, const Spacing& spacing) {
  std::vector<Visit> visits;
  const auto hit = walk_voxels(ray, dims, spacing, [&](const Extent& v, double length) {
    visits.push_back({v, length});
    return false;
  });
  EXPECT_FALSE(hit.has_value());
  return visits;
}

TEST(RenderPick, WalksAnAxisRayVoxelByVoxel) {
  // Along +x through the middle of a 5x4x3 grid of 2x1x1 voxels: five voxels, 2 world units each.
  const Ray ray{{-3, 2.5, 1.5}, {1, 0, 0}};
  const std::vector<Visit> visits = walk_all(ray, {5, 4, 3}, {2, 1, 1});
  ASSERT_EQ(visits.size(), 5u);
  for (std::size_t i = 0; i < visits.size(); ++i) {
    EXPECT_EQ(visits[i].voxel, (Extent{std::int64_t(i), 2, 1}));
    EXPECT_NEAR(visits[i].length, 2.0, 1e-12);
  }
}

TEST(RenderPick, WalksADiagonalRayThroughFaceNeighboursCoveringTheChord) {
  // Each next voxel is a face neighbour (no voxel skipped, none twice), and the lengths add up
  // to the chord of the ray inside the box.
  const Extent dims{7, 5, 6};
  const Spacing spacing{1.0, 1.5, 0.75};
  const Vec3 from{-1.3, -0.7, -0.4}, to{7.2, 7.9, 4.9};
  const Ray ray{from, normalized(to - from)};
  const std::vector<Visit> visits = walk_all(ray, dims, spacing);
  ASSERT_GT(visits.size(), 10u);
  double total = 0;
  for (std::size_t i = 0; i < visits.size(); ++i) {
    total += visits[i].length;
    if (i == 0) continue;
    const Extent a = visits[i - 1].voxel, b = visits[i].voxel;
    EXPECT_EQ(std::abs(a.x - b.x) + std::abs(a.y - b.y) + std::abs(a.z - b.z), 1) << i;
  }
  // The chord by the slab test, independently.
  double t0 = 0, t1 = 1e300;
  const double size[3] = {7 * 1.0, 5 * 1.5, 6 * 0.75};
  for (int a = 0; a < 3; ++a) {
    double lo = -ray.origin[a] / ray.direction[a], hi = (size[a] - ray.origin[a]) / ray.direction[a];
    if (lo > hi) std::swap(lo, hi);
    t0 = std::max(t0, lo);
    t1 = std::min(t1, hi);
  }
  EXPECT_NEAR(total, t1 - t0, 1e-9);
}

TEST(RenderPick, ARayThatMissesTheVolumeHitsNothing) {
  const Ray ray{{-1, -1, 5}, {1, 0, 0}};  // above the box
  bool called = false;
  EXPECT_FALSE(walk_voxels(ray, {4, 4, 4}, {1, 1, 1}, [&](const Extent&, double) { return called = true; }));
  EXPECT_FALSE(called);
}

// A 24^3 volume with two slabs across x: x in [6, 10) holds 5 (value 100), x in [14, 18) holds 3
// (value 200); seen from +x (azimuth 90, elevation 0), the centre pixel's ray runs along -x.
class RenderPickSession : public ::testing::Test {
 protected:
  void SetUp() override {
    Volume v(Extent{24, 24, 24}, DType::u8);
    auto s = v.view<std::uint8_t>();
    for (std::int64_t z = 0; z < 24; ++z)
      for (std::int64_t y = 0; y < 24; ++y)
        for (std::int64_t x = 0; x < 24; ++x) s(x, y, z) = x >= 6 && x < 10 ? 5 : x >= 14 && x < 18 ? 3 : 0;
    mixture::EncodeOptions o;
    o.measure_error = false;
    mixture::encode_labels(v, labels_path(), o);
    for (std::int64_t z = 0; z < 24; ++z)
      for (std::int64_t y = 0; y < 24; ++y)
        for (std::int64_t x = 0; x < 24; ++x) s(x, y, z) = std::uint8_t(s(x, y, z) == 5 ? 100 : s(x, y, z) == 3 ? 200 : 0);
    io::write_volume(plain_path(), v);
  }
  std::filesystem::path labels_path() const { return dir_.path() / "slabs.strata"; }
  std::filesystem::path plain_path() const { return dir_.path() / "slabs.nrrd"; }
  static CameraSpec along_minus_x() {
    CameraSpec c;
    c.width = 64;
    c.height = 48;
    c.orbit.azimuth_deg = 90;
    c.orbit.elevation_deg = 0;
    return c;
  }
  test::TempDir dir_;
};

TEST_F(RenderPickSession, LabelsStopAtTheFirstVisibleLabelAndPassHiddenOnes) {
  RenderSession session(labels_path());
  const TransferFunction unused = TransferFunction::preset("grayscale");
  auto pick = session.pick(along_minus_x(), 31.5, 23.5, unused);
  ASSERT_TRUE(pick);
  EXPECT_EQ(pick->label, 3);
  EXPECT_EQ(pick->hit.voxel.x, 17);  // the near face of the nearer slab
  EXPECT_FALSE(pick->value);
  LabelColorMap hide_three;
  hide_three.set(3, {1, 0, 0, 0});
  session.set_label_colors(hide_three);
  pick = session.pick(along_minus_x(), 31.5, 23.5, unused);
  ASSERT_TRUE(pick);
  EXPECT_EQ(pick->label, 5);
  EXPECT_EQ(pick->hit.voxel.x, 9);
  // A pixel in the corner looks past the volume.
  EXPECT_FALSE(session.pick(along_minus_x(), 0, 0, unused));
}

TEST_F(RenderPickSession, ScalarPicksStopWhereHalfTheOpacityHasAccumulated) {
  RenderSession session(plain_path());
  // Opaque above 150 (value 200 only): the near face of the slab of 200s.
  const TransferFunction opaque({{0, {1, 1, 1, 0}}, {0.7, {1, 1, 1, 0}}, {0.75, {1, 1, 1, 0.9f}}, {1, {1, 1, 1, 0.9f}}});
  auto pick = session.pick(along_minus_x(), 31.5, 23.5, opaque);
  ASSERT_TRUE(pick);
  EXPECT_EQ(pick->hit.voxel.x, 17);
  EXPECT_EQ(pick->value, 200.0);
  // 0.2 per voxel: 1 - 0.8^n first reaches 1/2 at the fourth voxel (0.59; three give 0.49).
  const TransferFunction faint({{0, {1, 1, 1, 0}}, {0.3, {1, 1, 1, 0}}, {0.35, {1, 1, 1, 0.2f}}, {1, {1, 1, 1, 0.2f}}});
  pick = session.pick(along_minus_x(), 31.5, 23.5, faint);
  ASSERT_TRUE(pick);
  EXPECT_EQ(pick->hit.voxel.x, 14);
  // Transparent everywhere: nothing to pick.
  const TransferFunction clear({{0, {1, 1, 1, 0}}, {1, {1, 1, 1, 0}}});
  EXPECT_FALSE(session.pick(along_minus_x(), 31.5, 23.5, clear));
  // A plain volume has no rank to choose.
  EXPECT_THROW(session.pick(along_minus_x(), 31.5, 23.5, opaque, 3), ParameterError);
}

}  // namespace
}  // namespace strata::render
