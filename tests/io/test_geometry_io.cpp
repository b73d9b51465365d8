// Where a volume lies survives every format that can say it: NIfTI (qform/sform, codes, units),
// NRRD (space, space directions, space origin, space units) and MRC (origin).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <vector>

#include "io/io_test_util.hpp"
#include "strata/io/convert.hpp"
#include "strata/io/volume_io.hpp"
#include "support/test_support.hpp"

namespace strata::io {
namespace {

Geometry oblique(WorldSpace space) {
  Geometry g;
  const double c = std::cos(0.3), s = std::sin(0.3);
  g.direction = {{{c, 0, s}, {0, 1, 0}, {-s, 0, c}}};  // a rotation about y
  g.origin = {-75.25, 12.5, 30.0};
  g.space = space;
  g.unit = "mm";
  return g;
}

Volume placed_volume(const Geometry& g, DType type = DType::i16) {
  Volume v = test::io::random_bytes_volume({5, 4, 3}, type, 3);
  v.set_spacing({0.75, 1.25, 2.0});
  v.set_geometry(g);
  return v;
}

// Equal to float precision: NIfTI-1 stores its transforms as float32.
void expect_placed_like(const Geometry& got, const Geometry& want, double tolerance) {
  EXPECT_EQ(got.space, want.space);
  EXPECT_EQ(got.unit, want.unit);
  for (int r = 0; r < 3; ++r) {
    EXPECT_NEAR(got.origin[r], want.origin[r], tolerance * 100) << "origin " << r;
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(got.direction[r][c], want.direction[r][c], tolerance) << r << "," << c;
  }
}

std::vector<char> bytes_of(const std::filesystem::path& p, std::size_t from, std::size_t to) {
  std::ifstream in(p, std::ios::binary);
  std::vector<char> all((std::istreambuf_iterator<char>(in)), {});
  return {all.begin() + std::ptrdiff_t(from), all.begin() + std::ptrdiff_t(to)};
}

TEST(IoGeometry, NiftiKeepsAnObliquePlacementAndItsHeaderFieldsBitForBit) {
  test::TempDir dir;
  const Volume v = placed_volume(oblique(WorldSpace::ras));
  write_volume(dir / "a.nii", v);
  const VolumeInfo first = open_volume(dir / "a.nii")->info();
  expect_placed_like(first.geometry, v.info().geometry, 1e-6);
  EXPECT_EQ(first.spacing, v.spacing());
  EXPECT_EQ(first.geometry.format_fields.at("nifti.sform_code"), "1");
  EXPECT_EQ(first.geometry.format_fields.at("nifti.qform_code"), "1");
  // Written again from what was read: the orientation fields (xyzt_units at 123, qform/sform
  // from 252 to the magic at 344) are the same bytes, not a float round trip of them.
  Volume again = open_volume(dir / "a.nii")->read_all();
  again.set_geometry(first.geometry);
  write_volume(dir / "b.nii", again);
  EXPECT_EQ(bytes_of(dir / "a.nii", 252, 344), bytes_of(dir / "b.nii", 252, 344));
  EXPECT_EQ(bytes_of(dir / "a.nii", 123, 124), bytes_of(dir / "b.nii", 123, 124));
}

TEST(IoGeometry, NiftiWritesAnLpsPlacementInRas) {
  test::TempDir dir;
  write_volume(dir / "lps.nii.gz", placed_volume(oblique(WorldSpace::lps)));
  const Geometry back = open_volume(dir / "lps.nii.gz")->info().geometry;
  EXPECT_EQ(back.space, WorldSpace::ras);
  expect_placed_like(in_world_space(back, WorldSpace::lps), oblique(WorldSpace::lps), 1e-6);
}

TEST(IoGeometry, NiftiWithoutPlacementStaysWithout) {
  test::TempDir dir;
  write_volume(dir / "plain.nii", test::io::random_bytes_volume({3, 3, 3}, DType::u8, 1));
  const Geometry g = open_volume(dir / "plain.nii")->info().geometry;
  EXPECT_EQ(g.format_fields.at("nifti.qform_code"), "0");
  EXPECT_EQ(g.format_fields.at("nifti.sform_code"), "0");
  EXPECT_EQ(g.origin, (Vector3{0, 0, 0}));
  EXPECT_EQ(g.direction, kIdentity3);
}

TEST(IoGeometry, NiftiKeptFieldsGiveWayWhenThePlacementChanged) {
  test::TempDir dir;
  write_volume(dir / "a.nii", placed_volume(oblique(WorldSpace::ras)));
  VolumeInfo info = open_volume(dir / "a.nii")->info();
  Volume moved = open_volume(dir / "a.nii")->read_all();
  Geometry g = info.geometry;
  g.origin[0] += 10;  // format_fields still hold the old sform
  moved.set_geometry(g);
  write_volume(dir / "moved.nii", moved);
  EXPECT_NEAR(open_volume(dir / "moved.nii")->info().geometry.origin[0], g.origin[0], 1e-4);
}

TEST(IoGeometry, NrrdKeepsSpaceDirectionsOriginAndUnits) {
  test::TempDir dir;
  for (const WorldSpace space : {WorldSpace::lps, WorldSpace::ras, WorldSpace::unspecified}) {
    SCOPED_TRACE(std::string(world_space_name(space)));
    const Volume v = placed_volume(oblique(space), DType::u64);
    write_volume(dir / "a.nrrd", v);
    const VolumeInfo back = open_volume(dir / "a.nrrd")->info();
    expect_placed_like(back.geometry, v.info().geometry, 1e-12);
    EXPECT_NEAR(back.spacing.x, 0.75, 1e-12);
    EXPECT_NEAR(back.spacing.z, 2.0, 1e-12);
    EXPECT_TRUE(open_volume(dir / "a.nrrd")->read_all() == v);
  }
}

TEST(IoGeometry, NrrdReadsAHandWrittenLeftAnteriorSuperiorHeaderAsRas) {
  test::TempDir dir;
  std::ofstream(dir / "las.nhdr") << "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 1 1\nencoding: raw\n"
                                     "space: left-anterior-superior\nspace directions: (2,0,0) (0,3,0) (0,0,4)\n"
                                     "space origin: (10,20,30)\nspace units: \"mm\" \"mm\" \"mm\"\ndata file: las.raw\n";
  std::ofstream(dir / "las.raw") << "ab";
  const VolumeInfo info = open_volume(dir / "las.nhdr")->info();
  EXPECT_EQ(info.geometry.space, WorldSpace::ras);
  EXPECT_EQ(info.geometry.origin, (Vector3{-10, 20, 30}));
  EXPECT_EQ(info.geometry.direction[0][0], -1.0);
  EXPECT_EQ(info.spacing, (Spacing{2, 3, 4}));
  EXPECT_EQ(info.geometry.unit, "mm");
}

TEST(IoGeometry, MrcKeepsTheOriginInAngstrom) {
  test::TempDir dir;
  Geometry g;
  g.origin = {120.5, -8.0, 64.0};
  g.unit = "angstrom";
  write_volume(dir / "a.mrc", placed_volume(g, DType::f32));
  const VolumeInfo back = open_volume(dir / "a.mrc")->info();
  EXPECT_EQ(back.geometry.origin, g.origin);
  EXPECT_EQ(back.geometry.unit, "angstrom");
  // A volume in nanometres is written in Å: ten times the numbers.
  g.unit = "nm";
  write_volume(dir / "nm.mrc", placed_volume(g, DType::f32));
  const VolumeInfo nm = open_volume(dir / "nm.mrc")->info();
  EXPECT_NEAR(nm.geometry.origin[0], 1205.0, 1e-3);
  EXPECT_NEAR(nm.spacing.x, 7.5, 1e-5);
}

TEST(IoGeometry, ConvertCarriesThePlacementAcrossFormats) {
  test::TempDir dir;
  write_volume(dir / "a.nrrd", placed_volume(oblique(WorldSpace::lps)));
  convert_volume(dir / "a.nrrd", dir / "b.nii.gz", {}, {}, silent_progress());
  convert_volume(dir / "b.nii.gz", dir / "c.nrrd", {}, {}, silent_progress());
  const Geometry b = open_volume(dir / "b.nii.gz")->info().geometry;
  EXPECT_EQ(b.space, WorldSpace::ras);
  expect_placed_like(in_world_space(b, WorldSpace::lps), oblique(WorldSpace::lps), 1e-6);
  expect_placed_like(in_world_space(open_volume(dir / "c.nrrd")->info().geometry, WorldSpace::lps),
                     oblique(WorldSpace::lps), 1e-6);
}

}  // namespace
}  // namespace strata::io
