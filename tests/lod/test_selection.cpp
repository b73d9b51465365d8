// The per-frame LOD cut: view-dependent refinement, frustum and transfer-function culling, and
// the brick and memory budgets.
#include <gtest/gtest.h>

#include <numeric>

#include "lod/lod_test_util.hpp"
#include "strata/lod/histogram_bins.hpp"
#include "strata/lod/selection.hpp"

using namespace strata;
using namespace strata::lod;
using namespace strata::lod::testing;

namespace {

double mean_level(const Selection& s) {
  double sum = 0, n = 0;
  for (std::size_t l = 0; l < s.per_level.size(); ++l) {
    sum += double(l) * double(s.per_level[l]);
    n += double(s.per_level[l]);
  }
  return sum / n;
}

std::int64_t total(const Selection& s) { return std::accumulate(s.per_level.begin(), s.per_level.end(), std::int64_t(0)); }

// Every brick of the cut is consistent with the counts it reports.
void expect_consistent(const Selection& s, int brick) {
  std::vector<std::int64_t> counts(s.per_level.size(), 0);
  std::uint64_t bytes = 0;
  for (const CutBrick& b : s.bricks) {
    ++counts.at(b.key.level);
    bytes += reconstructed_bytes(*b.entry, brick);
  }
  EXPECT_EQ(counts, s.per_level);
  EXPECT_EQ(bytes, s.bytes);
}

// Voxels of level 0 covered by the cut (bricks are disjoint, so this also checks that no two
// cut bricks overlap when it equals the sum of their sizes).
std::int64_t covered_voxels(const ta::TaVolume& t, const Selection& s) {
  std::int64_t n = 0;
  for (const CutBrick& b : s.bricks) {
    const WorldBox w = brick_world_box(t.geometry(), t.source_info().spacing, b.key);
    n += std::int64_t((w.hi.x - w.lo.x) * (w.hi.y - w.lo.y) * (w.hi.z - w.lo.z));
  }
  return n;
}

}  // namespace

TEST(LodSelection, ZoomingOutSelectsCoarserLevels) {
  const ta::TaVolume& t = Prisms64::volume();
  std::vector<Selection> cuts;
  for (double d : {120.0, 250.0, 270.0, 300.0, 600.0, 1500.0, 6000.0}) cuts.push_back(select_cut(t, view_from(t, d), kAllBins));
  for (std::size_t i = 0; i < cuts.size(); ++i) {
    expect_consistent(cuts[i], 16);
    EXPECT_FALSE(cuts[i].budget_hit());
    // The whole volume is in view and visible: the cut tiles it exactly.
    EXPECT_EQ(covered_voxels(t, cuts[i]), 64 * 64 * 64) << "cut " << i;
  }
  for (std::size_t i = 1; i < cuts.size(); ++i) {
    EXPECT_LE(total(cuts[i]), total(cuts[i - 1])) << "distance step " << i;
    EXPECT_GE(mean_level(cuts[i]), mean_level(cuts[i - 1])) << "distance step " << i;
    EXPECT_LE(cuts[i].per_level[0], cuts[i - 1].per_level[0]) << "distance step " << i;
  }
  // Close up: all at full resolution; in between: mixed levels; far away: the root alone.
  EXPECT_EQ(cuts.front().per_level, (std::vector<std::int64_t>{216, 0, 0, 0}));
  EXPECT_EQ(cuts[1].per_level, (std::vector<std::int64_t>{144, 9, 0, 0}));  // the near two thirds fine
  EXPECT_EQ(cuts[2].per_level, (std::vector<std::int64_t>{72, 18, 0, 0}));
  EXPECT_EQ(cuts.back().per_level, (std::vector<std::int64_t>{0, 0, 0, 1}));
  EXPECT_LT(total(cuts.back()), total(cuts.front()));
}

TEST(LodSelection, LodThresholdTradesDetailForBricks) {
  const ta::TaVolume& t = Prisms64::volume();
  const View v = view_from(t, 150);
  SelectionOptions fine, coarse;
  fine.lod = 0.25;
  coarse.lod = 4;
  const Selection a = select_cut(t, v, kAllBins, fine), b = select_cut(t, v, kAllBins, coarse);
  EXPECT_GT(total(a), total(b));
  EXPECT_LT(mean_level(a), mean_level(b));
}

TEST(LodSelection, RefinementIsNearestFirst) {
  const ta::TaVolume& t = Prisms64::volume();
  const View v = view_from(t, 120);
  SelectionOptions o;
  o.max_bricks = 120;  // room for some of the 27 level-1 bricks to split, not all
  const Selection s = select_cut(t, v, kAllBins, o);
  ASSERT_TRUE(s.brick_budget_hit);
  ASSERT_GT(s.per_level[0], 0);
  ASSERT_GT(s.per_level[1], 0);
  // The level-1 bricks that were split are nearer than every level-1 brick left whole.
  double split_far = 0, kept_near = 1e300;
  for (const CutBrick& b : s.bricks) {
    if (b.key.level == 1) kept_near = std::min(kept_near, b.depth);
    if (b.key.level != 0) continue;
    const store::BrickKey parent{1, b.key.x / 2, b.key.y / 2, b.key.z / 2};
    split_far = std::max(split_far, view_depth(v, brick_world_box(t.geometry(), t.source_info().spacing, parent)));
  }
  EXPECT_LE(split_far, kept_near);
}

TEST(LodSelection, MemoryBudgetIsNeverExceeded) {
  const ta::TaVolume& t = Prisms64::volume();
  const View v = view_from(t, 120);
  const std::uint64_t brick_bytes = 16 * 16 * 16 * 4;
  const Selection unbounded = select_cut(t, v, kAllBins);
  ASSERT_GT(unbounded.bytes, 8 * brick_bytes);
  for (std::uint64_t n : {1, 2, 7, 8, 9, 30, 100}) {
    SelectionOptions o;
    o.memory_budget = n * brick_bytes;
    const Selection s = select_cut(t, v, kAllBins, o);
    expect_consistent(s, 16);
    EXPECT_LE(s.bytes, o.memory_budget) << n << " bricks";
    EXPECT_TRUE(s.memory_budget_hit) << n << " bricks";
    EXPECT_FALSE(s.brick_budget_hit);
    // Stopping early keeps coarser bricks: the volume is still covered.
    EXPECT_EQ(covered_voxels(t, s), 64 * 64 * 64) << n << " bricks";
  }
  SelectionOptions roomy;
  roomy.memory_budget = unbounded.bytes;
  EXPECT_FALSE(select_cut(t, v, kAllBins, roomy).memory_budget_hit);
}

TEST(LodSelection, BrickBudgetIsNeverExceeded) {
  const ta::TaVolume& t = Prisms64::volume();
  const View v = view_from(t, 120);
  for (std::int64_t n : {1, 5, 8, 15, 64}) {
    SelectionOptions o;
    o.max_bricks = n;
    const Selection s = select_cut(t, v, kAllBins, o);
    EXPECT_LE(std::int64_t(s.bricks.size()), n);
    EXPECT_TRUE(s.brick_budget_hit);
    EXPECT_EQ(covered_voxels(t, s), 64 * 64 * 64);
  }
}

TEST(LodSelection, InvalidOptionsAndViewsAreRejected) {
  const ta::TaVolume& t = Prisms64::volume();
  SelectionOptions o;
  o.memory_budget = 100;  // below one 16^3 brick
  EXPECT_THROW(select_cut(t, view_from(t, 100), kAllBins, o), Error);
  View v = view_from(t, 100);
  v.pixel_angle = 0;
  EXPECT_THROW(select_cut(t, v, kAllBins), Error);
}

TEST(LodSelection, TransparentTransferFunctionSelectsNothing) {
  const ta::TaVolume& t = Prisms64::volume();
  const Selection s = select_cut(t, view_from(t, 120), 0);
  EXPECT_TRUE(s.bricks.empty());
  EXPECT_EQ(s.bytes, 0u);
  EXPECT_EQ(total(s), 0);
}

TEST(LodSelection, BricksEmptyUnderTheTransferFunctionAreDropped) {
  const ta::TaVolume& t = Prisms64::volume();
  const View v = view_from(t, 120);
  const std::uint64_t high = ~std::uint64_t(0) << 40;  // only the top 24 bins are opaque
  const Selection all = select_cut(t, v, kAllBins), some = select_cut(t, v, high);
  EXPECT_GT(some.culled_empty, 0);
  EXPECT_EQ(all.culled_empty, 0);
  EXPECT_LT(covered_voxels(t, some), covered_voxels(t, all));
  for (const CutBrick& b : some.bricks) EXPECT_NE(b.entry->histogram & high, 0u);
}

TEST(LodSelection, FrustumCullingDropsBricksBehindTheCamera) {
  const ta::TaVolume& t = Prisms64::volume();
  // Inside the volume, looking along +x: everything with x < 32 is behind the eye.
  const View v = perspective_view({32, 32, 32}, {100, 32, 32}, 64, 60, 0.5);
  const Selection s = select_cut(t, v, kAllBins);
  ASSERT_FALSE(s.bricks.empty());
  EXPECT_GT(s.culled_frustum, 0);
  for (const CutBrick& b : s.bricks) {
    const WorldBox w = brick_world_box(t.geometry(), t.source_info().spacing, b.key);
    EXPECT_GT(w.hi.x, 32.0) << "level " << int(b.key.level) << " brick x " << b.key.x;
  }
  EXPECT_LT(covered_voxels(t, s), 64 * 64 * 64);
  // Looking away from the volume: nothing at all.
  const Selection away = select_cut(t, perspective_view({-10, 32, 32}, {-100, 32, 32}), kAllBins);
  EXPECT_TRUE(away.bricks.empty());
  EXPECT_EQ(away.culled_frustum, 1);  // the root
}

TEST(LodSelection, ConstantBricksAreTestedByTheirValue) {
  test::TempDir dir;
  Volume v = ta::testing::prisms({40, 40, 40}, 5);
  auto s = v.view<std::uint16_t>();
  for (std::int64_t z = 20; z < 40; ++z)
    for (std::int64_t y = 0; y < 40; ++y)
      for (std::int64_t x = 0; x < 40; ++x) s(x, y, z) = 0;
  ta::testing::compress(v, dir / "half.strata", ta::testing::params(16, 2, 8, "u16,b8log+"));
  const ta::TaVolume t(dir / "half.strata");
  const View view = view_from(t, 30);
  auto constants = [](const Selection& c) {
    return std::count_if(c.bricks.begin(), c.bricks.end(),
                         [](const CutBrick& b) { return b.entry->kind == store::PayloadKind::constant; });
  };
  const Selection with_zero = select_cut(t, view, kAllBins);
  ASSERT_GT(constants(with_zero), 0);
  EXPECT_EQ(histogram_bin(0.0, t.value_min(), t.value_max()), 0);
  const Selection without_zero = select_cut(t, view, kAllBins & ~std::uint64_t(1));
  EXPECT_EQ(constants(without_zero), 0);
  EXPECT_GT(without_zero.culled_empty, 0);
}

TEST(LodHistogramBins, VisibleBinsFollowTheTransferFunction) {
  // Opaque above 0.75 of the range: the top quarter of the bins.
  const std::uint64_t mask = visible_bins_where(0, 1, [](double, double hi) { return hi > 0.75; });
  EXPECT_EQ(mask, ~std::uint64_t(0) << 48);
  EXPECT_EQ(histogram_bin(1.0, 0, 1), 63);
  EXPECT_EQ(histogram_bin(-3.0, 0, 1), 0);
  EXPECT_EQ(histogram_bin(0.5, 0, 1), 32);
  EXPECT_EQ(histogram_bin(7.0, 7, 7), 0);
}

TEST(LodSelection, OrthographicViewsRefineByLevelAlone) {
  const ta::TaVolume& t = Prisms64::volume();
  View v;  // no frustum planes: nothing is culled
  v.eye = {32, 32, 500};
  v.forward = {0, 0, -1};
  v.perspective = false;
  v.pixel_world = 2.5;  // a level-1 voxel spans 0.8 pixels, a level-2 one 1.6
  EXPECT_EQ(select_cut(t, v, kAllBins).per_level, (std::vector<std::int64_t>{0, 27, 0, 0}));
  v.pixel_world = 1.5;  // level 1: 1.33 pixels, so down to level 0
  EXPECT_EQ(select_cut(t, v, kAllBins).per_level, (std::vector<std::int64_t>{216, 0, 0, 0}));
}
