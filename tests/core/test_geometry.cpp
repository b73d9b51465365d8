// Geometry: the index-to-world affine, its split back into spacing and directions, RAS/LPS, and
// where levels and boxes of a volume lie.
#include <gtest/gtest.h>

#include <cmath>

#include "strata/core/error.hpp"
#include "strata/core/geometry.hpp"
#include "strata/core/volume.hpp"

namespace strata {
namespace {

// An oblique placement: a rotation of 30 degrees about z, origin off zero.
Geometry oblique() {
  Geometry g;
  const double c = std::cos(M_PI / 6), s = std::sin(M_PI / 6);
  g.direction = {{{c, -s, 0}, {s, c, 0}, {0, 0, 1}}};
  g.origin = {10, -20, 5};
  g.space = WorldSpace::ras;
  g.unit = "mm";
  return g;
}

Vector3 world_of(const Matrix4& m, double i, double j, double k) {
  return {m[0][0] * i + m[0][1] * j + m[0][2] * k + m[0][3], m[1][0] * i + m[1][1] * j + m[1][2] * k + m[1][3],
          m[2][0] * i + m[2][1] * j + m[2][2] * k + m[2][3]};
}

TEST(CoreGeometry, TheAffineScalesEachDirectionByItsSpacing) {
  const Matrix4 m = index_to_world(oblique(), {0.5, 2.0, 3.0});
  const Vector3 w = world_of(m, 2, 0, 0);  // two voxels of 0.5 along i = 1 unit along direction 0
  EXPECT_NEAR(w[0], 10 + std::cos(M_PI / 6), 1e-12);
  EXPECT_NEAR(w[1], -20 + std::sin(M_PI / 6), 1e-12);
  EXPECT_DOUBLE_EQ(world_of(m, 0, 0, 1)[2], 8.0);
}

TEST(CoreGeometry, AnAffineSplitsBackIntoSpacingAndDirections) {
  const Spacing spacing{0.5, 2.0, 3.0};
  Spacing back;
  const Geometry g = geometry_from_affine(index_to_world(oblique(), spacing), back, WorldSpace::ras, "test");
  EXPECT_NEAR(back.x, 0.5, 1e-12);
  EXPECT_NEAR(back.y, 2.0, 1e-12);
  EXPECT_NEAR(back.z, 3.0, 1e-12);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(g.direction[r][c], oblique().direction[r][c], 1e-12);
  EXPECT_EQ(g.origin, oblique().origin);
  Matrix4 degenerate = index_to_world(oblique(), spacing);
  for (int r = 0; r < 3; ++r) degenerate[r][1] = 0;
  EXPECT_THROW(geometry_from_affine(degenerate, back, WorldSpace::ras, "test"), Error);
}

TEST(CoreGeometry, RasAndLpsDifferByTheSignsOfXAndY) {
  const Geometry lps = in_world_space(oblique(), WorldSpace::lps);
  EXPECT_EQ(lps.space, WorldSpace::lps);
  EXPECT_EQ(lps.origin, (Vector3{-10, 20, 5}));
  EXPECT_DOUBLE_EQ(lps.direction[0][0], -oblique().direction[0][0]);
  EXPECT_DOUBLE_EQ(lps.direction[2][2], 1.0);
  EXPECT_EQ(in_world_space(lps, WorldSpace::ras), oblique());
  Geometry plain;  // no anatomy: nothing to convert
  EXPECT_EQ(in_world_space(plain, WorldSpace::lps), plain);
}

TEST(CoreGeometry, ALevelCentresOnItsFirstBlockAndABoxOnItsFirstVoxel) {
  Geometry g = oblique();
  g.format_fields["nifti.qform_code"] = "1";
  const Spacing s{1.0, 1.0, 2.0};
  EXPECT_EQ(level_geometry(g, s, 0), g);
  const Geometry l2 = level_geometry(g, s, 2);  // a level-2 voxel covers level-0 voxels 0..3
  const Vector3 centre = world_of(index_to_world(g, s), 1.5, 1.5, 1.5);
  for (int r = 0; r < 3; ++r) EXPECT_NEAR(l2.origin[r], centre[r], 1e-12);
  EXPECT_TRUE(l2.format_fields.empty());  // the header fields describe level 0 only
  const Geometry box = box_geometry(g, s, {3, 0, 2});
  const Vector3 first = world_of(index_to_world(g, s), 3, 0, 2);
  for (int r = 0; r < 3; ++r) EXPECT_NEAR(box.origin[r], first[r], 1e-12);
  EXPECT_EQ(box_geometry(g, s, {0, 0, 0}), g);
}

TEST(CoreGeometry, UnitsHaveOneSpellingAndAScale) {
  EXPECT_EQ(canonical_length_unit("micron"), "um");
  EXPECT_EQ(canonical_length_unit("Millimeter"), "mm");
  EXPECT_EQ(canonical_length_unit("furlong"), "");
  EXPECT_DOUBLE_EQ(metres_per_unit("nm") / metres_per_unit("angstrom"), 10.0);
  EXPECT_EQ(metres_per_unit(""), 0.0);
  EXPECT_EQ(parse_world_space("lps", "t"), WorldSpace::lps);
  EXPECT_THROW(parse_world_space("xyz", "t"), Error);
}

}  // namespace
}  // namespace strata
