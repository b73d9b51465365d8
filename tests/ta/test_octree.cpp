// OctreeGeometry: level extents, brick grids, sample/core boxes and layout validation
// (paper 1 §3: bricks of width B = core + 2 * overlap, levels halved until one brick covers all).
#include <gtest/gtest.h>

#include "strata/core/error.hpp"
#include "strata/ta/octree.hpp"
#include "support/test_support.hpp"

using namespace strata;
using namespace strata::ta;

TEST(TaOctree, HalfExtentRoundsUp) {
  EXPECT_EQ(half_extent({100, 60, 30}), (Extent{50, 30, 15}));
  EXPECT_EQ(half_extent({45, 37, 1}), (Extent{23, 19, 1}));
  EXPECT_EQ(half_extent({1, 2, 3}), (Extent{1, 1, 2}));
}

TEST(TaOctree, LevelsOf100x60x30AtBrick32Overlap2) {
  const OctreeGeometry g({100, 60, 30}, {32, 2});
  EXPECT_EQ(g.layout().core(), 28);
  // 100x60x30 -> 50x30x15 -> 25x15x8; the last fits one 28^3 core, so it is the root.
  ASSERT_EQ(g.level_count(), 3);
  EXPECT_EQ(g.level(0).dims, (Extent{100, 60, 30}));
  EXPECT_EQ(g.level(0).bricks, (Extent{4, 3, 2}));  // ceil(100/28), ceil(60/28), ceil(30/28)
  EXPECT_EQ(g.level(1).dims, (Extent{50, 30, 15}));
  EXPECT_EQ(g.level(1).bricks, (Extent{2, 2, 1}));
  EXPECT_EQ(g.level(2).dims, (Extent{25, 15, 8}));
  EXPECT_EQ(g.level(2).bricks, (Extent{1, 1, 1}));
  EXPECT_EQ(g.total_bricks(), 24 + 4 + 1);
  EXPECT_THROW(g.level(3), std::out_of_range);
}

TEST(TaOctree, LevelCountStopsExactlyWhenOneCoreCoversTheLevel) {
  EXPECT_EQ(OctreeGeometry({28, 28, 28}, {32, 2}).level_count(), 1);
  EXPECT_EQ(OctreeGeometry({1, 1, 1}, {32, 2}).level_count(), 1);
  EXPECT_EQ(OctreeGeometry({29, 1, 1}, {32, 2}).level_count(), 2);  // 29 -> 15
  EXPECT_EQ(OctreeGeometry({56, 56, 56}, {32, 2}).level_count(), 2);
  EXPECT_EQ(OctreeGeometry({57, 3, 3}, {32, 2}).level_count(), 3);  // 57 -> 29 -> 15
  // No overlap: core == brick.
  const OctreeGeometry g({64, 64, 64}, {16, 0});
  EXPECT_EQ(g.level_count(), 3);  // 64 -> 32 -> 16
  EXPECT_EQ(g.level(0).bricks, (Extent{4, 4, 4}));
  EXPECT_EQ(g.level(2).bricks, (Extent{1, 1, 1}));
}

TEST(TaOctree, SampleBoxIsCoreShiftedByOverlapAndBrickWide) {
  const OctreeGeometry g({100, 60, 30}, {32, 2});
  // Brick (0,0,0) starts 2 voxels before the volume (clamped samples).
  EXPECT_EQ(g.brick_sample_box(0, 0, 0, 0), (Box{{-2, -2, -2}, {30, 30, 30}}));
  EXPECT_EQ(g.brick_sample_box(0, 1, 2, 1), (Box{{26, 54, 26}, {58, 86, 58}}));
  // The last brick of a row may extend past the level's edge: not clipped.
  EXPECT_EQ(g.brick_sample_box(0, 3, 0, 0), (Box{{82, -2, -2}, {114, 30, 30}}));
  EXPECT_EQ(g.brick_sample_box(1, 1, 1, 0), (Box{{26, 26, -2}, {58, 58, 30}}));
}

TEST(TaOctree, CoreBoxIsClippedToTheLevel) {
  const OctreeGeometry g({100, 60, 30}, {32, 2});
  EXPECT_EQ(g.brick_core_box(0, 0, 0, 0), (Box{{0, 0, 0}, {28, 28, 28}}));
  EXPECT_EQ(g.brick_core_box(0, 1, 1, 0), (Box{{28, 28, 0}, {56, 56, 28}}));
  EXPECT_EQ(g.brick_core_box(0, 3, 2, 1), (Box{{84, 56, 28}, {100, 60, 30}}));
  EXPECT_EQ(g.brick_core_box(1, 1, 1, 0), (Box{{28, 28, 0}, {50, 30, 15}}));
  EXPECT_EQ(g.brick_core_box(2, 0, 0, 0), (Box{{0, 0, 0}, {25, 15, 8}}));
}

TEST(TaOctree, CoreBoxesTileEveryLevelExactly) {
  const OctreeGeometry g({45, 37, 30}, {16, 2});
  for (int l = 0; l < g.level_count(); ++l) {
    const LevelGeometry& lg = g.level(l);
    std::int64_t covered = 0;
    for (std::int64_t bz = 0; bz < lg.bricks.z; ++bz)
      for (std::int64_t by = 0; by < lg.bricks.y; ++by)
        for (std::int64_t bx = 0; bx < lg.bricks.x; ++bx) {
          const Box core = g.brick_core_box(l, bx, by, bz);
          ASSERT_FALSE(core.empty()) << "level " << l << " brick " << bx << "," << by << "," << bz;
          EXPECT_TRUE(Box::whole(lg.dims).contains(core));
          // The sample box holds the core plus `overlap` voxels on every side.
          const Box sample = g.brick_sample_box(l, bx, by, bz);
          EXPECT_EQ(sample.size(), (Extent{16, 16, 16}));
          EXPECT_EQ(sample.lo, (Extent{core.lo.x - 2, core.lo.y - 2, core.lo.z - 2}));
          covered += core.voxel_count();
        }
    // Cores are disjoint by construction (a regular grid), so equal counts mean an exact tiling.
    EXPECT_EQ(covered, lg.dims.voxel_count()) << "level " << l;
  }
}

TEST(TaOctree, ValidationRejectsBadLayoutsAndEmptyVolumes) {
  EXPECT_NO_THROW((BrickLayout{32, 2}.validate()));
  EXPECT_NO_THROW((BrickLayout{2, 0}.validate()));
  EXPECT_NO_THROW((BrickLayout{3, 1}.validate()));   // core 1
  EXPECT_THROW((BrickLayout{4, 2}.validate()), Error);   // core 0
  EXPECT_THROW((BrickLayout{32, -1}.validate()), Error);
  EXPECT_THROW((BrickLayout{1, 0}.validate()), Error);
  EXPECT_THROW((BrickLayout{257, 2}.validate()), Error);
  try {
    BrickLayout{8, 4}.validate();
    FAIL() << "no error";
  } catch (const ParameterError& e) {
    EXPECT_EQ(e.parameter(), "BrickLayout::overlap");
    EXPECT_EQ(std::string(e.what()).rfind("BrickLayout::overlap: ", 0), 0u) << e.what();
    EXPECT_NE(e.problem().find("width 8"), std::string::npos) << e.what();
    EXPECT_NE(e.problem().find("got 4"), std::string::npos) << e.what();
  }
  EXPECT_EQ(test::error_of([] { BrickLayout{257, 2}.validate(); }), "BrickLayout::brick: must be in 2..256, got 257");
  EXPECT_EQ(test::parameter_of([] { BrickLayout{1, 0}.validate(); }), "BrickLayout::brick");
  EXPECT_EQ(test::parameter_of([] { BrickLayout{32, -1}.validate(); }), "BrickLayout::overlap");
  EXPECT_EQ(test::parameter_of([] { BrickLayout{4, 2}.validate(); }), "BrickLayout::overlap");
  EXPECT_THROW(OctreeGeometry({0, 10, 10}, {32, 2}), Error);
  EXPECT_THROW(OctreeGeometry({10, 10, -1}, {32, 2}), Error);
  // Two negative extents make a positive voxel count: each extent must be checked on its own.
  EXPECT_THROW(OctreeGeometry({-10, -10, 10}, {32, 2}), Error);
  EXPECT_THROW(OctreeGeometry({10, 10, 10}, {4, 2}), Error);
}
