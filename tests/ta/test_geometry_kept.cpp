// A compressed file keeps where its volume lies: the source geometry is stored in the metadata
// and every level and box of it is placed where it was.
#include <gtest/gtest.h>

#include <cmath>

#include "strata/ta/ta_volume.hpp"
#include "support/test_support.hpp"
#include "ta/ta_test_util.hpp"

using namespace strata;
using namespace strata::ta;
using namespace strata::ta::testing;

namespace {

TEST(TaGeometry, TheSourcePlacementIsStoredAndEveryLevelIsPlacedUnderIt) {
  test::TempDir dir;
  Volume v = prisms({40, 36, 20});
  v.set_spacing({0.5, 0.5, 1.5});
  Geometry g;
  g.origin = {-90.25, 126.0, -72.0};
  g.direction = {{{-1, 0, 0}, {0, -1, 0}, {0, 0, 1}}};
  g.space = WorldSpace::lps;
  g.unit = "mm";
  g.format_fields["nifti.sform_code"] = "1";
  v.set_geometry(g);
  compress(v, dir / "g.strata", params(16, 2, 8, "u16,b8log+"));
  TaVolume t(dir / "g.strata");
  EXPECT_EQ(t.source_info().geometry, g);  // exactly: JSON keeps every double
  const Box whole = Box::whole(t.geometry().level(0).dims);
  EXPECT_EQ(t.level_geometry(0, whole), g);
  const Geometry l1 = t.level_geometry(1, Box::whole(t.geometry().level(1).dims));
  // Level 1's first voxel averages level-0 voxels 0..1: its centre is half a voxel further.
  EXPECT_DOUBLE_EQ(l1.origin[0], -90.25 - 0.25);
  EXPECT_DOUBLE_EQ(l1.origin[1], 126.0 - 0.25);
  EXPECT_DOUBLE_EQ(l1.origin[2], -72.0 + 0.75);
  EXPECT_TRUE(l1.format_fields.empty());
  const Geometry box = t.level_geometry(0, {{4, 0, 2}, {8, 8, 6}});
  EXPECT_DOUBLE_EQ(box.origin[0], -90.25 - 4 * 0.5);
  EXPECT_DOUBLE_EQ(box.origin[2], -72.0 + 2 * 1.5);
}

TEST(TaGeometry, AVolumeWithoutPlacementWritesNone) {
  test::TempDir dir;
  compress(prisms({16, 16, 16}), dir / "p.strata", params(16, 2, 8, "u16,b8log+"));
  TaVolume t(dir / "p.strata");
  EXPECT_TRUE(t.source_info().geometry.is_default());
  EXPECT_FALSE(t.container().metadata()["source"].contains("geometry"));
}

}  // namespace
