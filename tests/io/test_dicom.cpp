// DICOM series from hand-built explicit-VR little-endian files: slices sorted by position
// along the normal whatever their names, spacing and LPS geometry from the plane tags,
// rescaled samples, multi-frame files, several series in a folder, and the tags whose absence
// or disagreement is refused naming the file and the tag.
#include <gdcmImageChangeTransferSyntax.h>
#include <gdcmImageReader.h>
#include <gdcmImageWriter.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "io/dicom_data.hpp"
#include "io/io_test_util.hpp"
#include "strata/io/formats.hpp"
#include "strata/io/volume_io.hpp"
#include "support/test_support.hpp"

namespace strata::io {
namespace {

namespace fs = std::filesystem;
using test::TempDir;
using test::io::expect_error;

using test::io::DicomData;

constexpr std::uint16_t kRows = 3, kColumns = 4;
// An oblique plane: rows along (cos 30°, sin 30°, 0), columns along z.
const double kC = std::cos(M_PI / 6), kS = std::sin(M_PI / 6);
const std::array<double, 3> kRow{kC, kS, 0}, kColumn{0, 0, 1}, kNormal{kS, -kC, 0};  // row × column

std::string ds_list(std::initializer_list<double> values) {
  std::string out;
  for (double v : values) out += (out.empty() ? "" : "\\") + fmt::format("{:.10g}", v);
  return out;
}

// Slice `k` of a 12-bit signed CT series: sample (x, y) stores 100 k + 10 y + x - 2000.
DicomData ct_slice(int k, double gap = 2.5, const std::string& series = "1.2.826.0.1.1") {
  std::vector<std::int16_t> samples;
  for (int y = 0; y < kRows; ++y)
    for (int x = 0; x < kColumns; ++x) samples.push_back(std::int16_t(100 * k + 10 * y + x - 2000));
  const double p = gap * k;
  DicomData d;
  d.text(0x0008, 0x103E, "LO", "axial " + series)
      .text(0x0020, 0x000E, "UI", series)
      .text(0x0020, 0x0032, "DS", ds_list({10 + p * kNormal[0], -5 + p * kNormal[1], 7}))
      .text(0x0020, 0x0037, "DS", ds_list({kRow[0], kRow[1], kRow[2], kColumn[0], kColumn[1], kColumn[2]}))
      .us(0x0028, 0x0002, 1)
      .text(0x0028, 0x0004, "CS", "MONOCHROME2")
      .us(0x0028, 0x0010, kRows)
      .us(0x0028, 0x0011, kColumns)
      .text(0x0028, 0x0030, "DS", "0.5\\0.75")
      .us(0x0028, 0x0100, 16)
      .us(0x0028, 0x0101, 12)
      .us(0x0028, 0x0102, 11)
      .us(0x0028, 0x0103, 1)
      .text(0x0028, 0x1052, "DS", "-1024")
      .text(0x0028, 0x1053, "DS", "1")
      .pixels(samples);
  return d;
}

// Writes slices 0..count-1 under names that sort against their positions.
void write_series(const fs::path& dir, int count, double gap = 2.5) {
  for (int k = 0; k < count; ++k) ct_slice(k, gap).write(dir / fmt::format("IM{}.dcm", (k * 7 + 3) % count));
}

TEST(IoDicom, ReadsAnObliqueSeriesSortedAlongTheNormal) {
  TempDir dir;
  write_series(dir.path(), 5);
  EXPECT_EQ(detect_format(dir.path()).name, "dicom");
  auto source = open_volume(dir.path());
  const VolumeInfo& info = source->info();
  EXPECT_EQ(info.dims, (Extent{kColumns, kRows, 5}));
  EXPECT_EQ(info.dtype, DType::i16);  // 12-bit signed values + (-1024) fit in int16
  EXPECT_DOUBLE_EQ(info.spacing.x, 0.75);  // PixelSpacing is (row spacing, column spacing)
  EXPECT_DOUBLE_EQ(info.spacing.y, 0.5);
  EXPECT_NEAR(info.spacing.z, 2.5, 1e-6);
  EXPECT_EQ(info.geometry.space, WorldSpace::lps);
  EXPECT_EQ(info.geometry.unit, "mm");
  EXPECT_NEAR(info.geometry.origin[0], 10, 1e-6);
  EXPECT_NEAR(info.geometry.origin[1], -5, 1e-6);
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_NEAR(info.geometry.direction[k][0], kRow[k], 1e-6);
    EXPECT_NEAR(info.geometry.direction[k][1], kColumn[k], 1e-6);
    EXPECT_NEAR(info.geometry.direction[k][2], kNormal[k], 1e-6);
  }
  const Volume box = source->read_box({{1, 1, 1}, {4, 3, 4}});
  auto v = box.view<std::int16_t>();
  for (std::int64_t z = 0; z < 3; ++z)
    for (std::int64_t y = 0; y < 2; ++y)
      for (std::int64_t x = 0; x < 3; ++x)
        EXPECT_EQ(v(x, y, z), 100 * (z + 1) + 10 * (y + 1) + (x + 1) - 2000 - 1024) << x << " " << y << " " << z;
}

// `in` rewritten by GDCM's writer with its pixel data compressed in `syntax`.
void transcode(const fs::path& in, const fs::path& out, gdcm::TransferSyntax::TSType syntax) {
  gdcm::ImageReader reader;
  reader.SetFileName(in.c_str());
  ASSERT_TRUE(reader.Read());
  gdcm::ImageChangeTransferSyntax change;
  change.SetTransferSyntax(syntax);
  change.SetInput(reader.GetImage());
  ASSERT_TRUE(change.Change());
  gdcm::ImageWriter writer;
  writer.SetFileName(out.c_str());
  writer.SetFile(reader.GetFile());
  writer.SetImage(change.GetOutput());
  ASSERT_TRUE(writer.Write());
}

class IoDicomCompressed : public testing::TestWithParam<gdcm::TransferSyntax::TSType> {};

TEST_P(IoDicomCompressed, ReadsWhatGdcmCompressesAsTheNativeSeries) {
  TempDir dir;
  fs::create_directories(dir / "native");
  fs::create_directories(dir / "compressed");
  write_series(dir / "native", 3);
  for (const auto& entry : fs::directory_iterator(dir / "native"))
    transcode(entry.path(), dir / "compressed" / entry.path().filename(), GetParam());
  auto source = open_volume(dir / "compressed");
  const Volume native = read_volume(dir / "native");
  const Volume compressed = source->read_all();
  ASSERT_EQ(compressed.dtype(), native.dtype());
  EXPECT_EQ(std::memcmp(compressed.bytes(), native.bytes(), native.byte_size()), 0);
  const Volume box = source->read_box({{1, 1, 1}, {3, 3, 2}});
  EXPECT_EQ(box.view<std::int16_t>()(1, 0, 0), native.view<std::int16_t>()(2, 1, 1));
}

INSTANTIATE_TEST_SUITE_P(Lossless, IoDicomCompressed,
                         testing::Values(gdcm::TransferSyntax::RLELossless, gdcm::TransferSyntax::JPEGLosslessProcess14_1,
                                         gdcm::TransferSyntax::JPEGLSLossless));
// (JPEG 2000 is decoded by the same region reader; GDCM's encoder, OpenJPEG, crashes on these
// 4 x 3 slices, so no file of it is made here.)

TEST(IoDicom, UndecodableTransferSyntaxIsNamed) {
  TempDir dir;
  ct_slice(0).write(dir / "video.dcm", "1.2.840.10008.1.2.4.100");  // MPEG2 Main Profile
  expect_error([&] { open_volume(dir / "video.dcm"); }, {"video.dcm", "TransferSyntaxUID (0002,0010)", "1.2.840.10008.1.2.4.100"});
}

TEST(IoDicom, SlopeOtherThanOneGivesFloat) {
  TempDir dir;
  for (int k = 0; k < 2; ++k) ct_slice(k).text(0x0028, 0x1053, "DS", "0.5").write(dir / fmt::format("{}.dcm", k));
  const Volume v = read_volume(dir.path());
  ASSERT_EQ(v.dtype(), DType::f32);
  EXPECT_FLOAT_EQ(v.view<float>()(3, 2, 1), float((100 + 20 + 3 - 2000) * 0.5 - 1024));
}

TEST(IoDicom, HighBitsAboveBitsStoredAreIgnored) {
  TempDir dir;
  std::vector<std::int16_t> samples(kRows * kColumns, std::int16_t(0x7005));  // bit 12 up: garbage; low 12: 5
  ct_slice(0).pixels(samples).text(0x0028, 0x1052, "DS", "0").write(dir / "a.dcm");
  EXPECT_EQ(read_volume(dir / "a.dcm").view<std::int16_t>()(0, 0, 0), 5);
}

TEST(IoDicom, SingleFileIsOneSliceWithItsSpacingBetweenSlices) {
  TempDir dir;
  ct_slice(0).text(0x0018, 0x0088, "DS", "3.5").text(0x0018, 0x0050, "DS", "1").write(dir / "slice");
  EXPECT_EQ(detect_format(dir / "slice").name, "dicom");  // no extension: by the signature
  const auto source = open_volume(dir / "slice");
  EXPECT_EQ(source->info().dims, (Extent{kColumns, kRows, 1}));
  EXPECT_DOUBLE_EQ(source->info().spacing.z, 3.5);
}

TEST(IoDicom, EnhancedMultiFrameFramesSortedByTheirPlanePositions) {
  TempDir dir;
  DicomData shared, orientation, measures;
  orientation.text(0x0020, 0x0037, "DS", "1\\0\\0\\0\\1\\0");
  measures.text(0x0028, 0x0030, "DS", "0.25\\0.5");
  shared.sequence(0x0020, 0x9116, {orientation}).sequence(0x0028, 0x9110, {measures});
  std::vector<DicomData> frames;
  std::vector<std::int16_t> samples;
  for (int f = 0; f < 3; ++f) {  // stored top-down: frame f lies at z = -2 f
    DicomData position, frame;
    position.text(0x0020, 0x0032, "DS", ds_list({0, 0, -2.0 * f}));
    frames.push_back(frame.sequence(0x0020, 0x9113, {position}));
    for (int i = 0; i < kRows * kColumns; ++i) samples.push_back(std::int16_t(f));
  }
  DicomData file = ct_slice(0).erase(0x0020, 0x0032).erase(0x0020, 0x0037).erase(0x0028, 0x0030);
  file.text(0x0028, 0x1052, "DS", "0").text(0x0028, 0x0008, "IS", "3").sequence(0x5200, 0x9229, {shared});
  file.sequence(0x5200, 0x9230, frames).pixels(samples).write(dir / "enhanced.dcm");
  const Volume v = read_volume(dir / "enhanced.dcm");
  ASSERT_EQ(v.dims(), (Extent{kColumns, kRows, 3}));
  EXPECT_EQ(v.view<std::int16_t>()(0, 0, 0), 2);  // the lowest frame first
  EXPECT_EQ(v.view<std::int16_t>()(0, 0, 2), 0);
  EXPECT_DOUBLE_EQ(v.spacing().x, 0.5);
  EXPECT_DOUBLE_EQ(v.spacing().z, 2.0);
  EXPECT_DOUBLE_EQ(open_volume(dir / "enhanced.dcm")->info().geometry.origin[2], -4.0);
}

TEST(IoDicom, MissingOrDisagreeingTagsAreNamed) {
  const auto refused = [](DicomData second, const std::vector<std::string>& parts) {
    TempDir dir;
    ct_slice(0).write(dir / "a.dcm");
    second.write(dir / "b.dcm");
    expect_error([&] { open_volume(dir.path()); }, parts);
  };
  refused(ct_slice(1).erase(0x0020, 0x0032), {"b.dcm", "ImagePositionPatient (0020,0032)", "missing"});
  refused(ct_slice(1).erase(0x0028, 0x0030), {"b.dcm", "PixelSpacing (0028,0030)", "missing"});
  refused(ct_slice(1).erase(0x7FE0, 0x0010), {"b.dcm", "PixelData (7FE0,0010)", "missing"});
  refused(ct_slice(1).us(0x0028, 0x0010, 2).pixels(std::vector<std::int16_t>(8)), {"b.dcm", "Rows (0028,0010)", "a.dcm"});
  refused(ct_slice(1).text(0x0020, 0x0032, "DS", "1\\2"), {"b.dcm", "ImagePositionPatient", "expected 3"});
  refused(ct_slice(1).pixels(std::vector<std::int16_t>(5)), {"b.dcm", "PixelData (7FE0,0010)", "holds 10 bytes"});
  refused(ct_slice(1).erase(0x0028, 0x0102), {"b.dcm", "HighBit (0028,0102)", "missing"});
  refused(ct_slice(0), {"ImagePositionPatient", "duplicate"});
}

TEST(IoDicom, UnevenGapsAreRefusedNamingTheFiles) {
  TempDir dir;
  for (int k : {0, 1, 3}) ct_slice(k).write(dir / fmt::format("s{}.dcm", k));
  expect_error([&] { open_volume(dir.path()); }, {"s3.dcm", "lies 5 mm after", "s1.dcm", "2.5 mm apart", "uneven gaps"});
}

TEST(IoDicom, SeveralSeriesAreListedAndOneIsChosenByItsUid) {
  TempDir dir;
  for (int k = 0; k < 3; ++k) ct_slice(k, 2.5, "1.2.3.1").write(dir / fmt::format("a{}.dcm", k));
  for (int k = 0; k < 2; ++k) ct_slice(k, 4.0, "1.2.3.2").write(dir / fmt::format("b{}.dcm", k));
  expect_error([&] { open_volume(dir.path()); },
               {"2 series", "1.2.3.1 \"axial 1.2.3.1\" (3 slices)", "1.2.3.2 \"axial 1.2.3.2\" (2 slices)"});
  ReadOptions options;
  options.dataset = "1.2.3.2";
  EXPECT_EQ(open_volume(dir.path(), options)->info().dims.z, 2);
  EXPECT_NEAR(open_volume(dir.path().string() + ":1.2.3.1")->info().spacing.z, 2.5, 1e-6);
  options.dataset = "9.9";
  expect_error([&] { open_volume(dir.path(), options); }, {"no series 9.9"});
}

TEST(IoDicom, BoxesReadOnlyTheSlicesTheyTouch) {
  TempDir dir;
  for (int k = 0; k < 4; ++k) ct_slice(k).write(dir / fmt::format("s{}.dcm", k));
  auto source = open_volume(dir.path());
  // Slice 3 changes after opening: boxes above it still read, a box over it is refused.
  ct_slice(3).us(0x0028, 0x0010, 2).pixels(std::vector<std::int16_t>(8)).write(dir / "s3.dcm");
  EXPECT_EQ(source->read_box({{0, 0, 0}, {kColumns, kRows, 3}}).dims().z, 3);
  expect_error([&] { source->read_box({{0, 0, 2}, {1, 1, 4}}); }, {"s3.dcm", "differ from when the series was opened"});
}

TEST(IoDicom, FrameCountBeyondThePixelDataIsRefusedBeforeAllocating) {
  TempDir dir;
  ct_slice(0).text(0x0028, 0x0008, "IS", "2000000000").write(dir / "frames.dcm");
  expect_error([&] { open_volume(dir / "frames.dcm"); },
               {"frames.dcm", "NumberOfFrames (0028,0008)", "room for 1 frame(s) of 24 bytes"});
}

TEST(IoDicom, TruncatedFilesAreRefusedBeforeGdcmParsesThem) {
  TempDir dir;
  ct_slice(0).write(dir / "whole.dcm");
  const auto size = fs::file_size(dir / "whole.dcm");
  for (std::uintmax_t cut : {size - 30, std::uintmax_t(250), std::uintmax_t(140)}) {
    fs::copy_file(dir / "whole.dcm", dir / "cut.dcm", fs::copy_options::overwrite_existing);
    fs::resize_file(dir / "cut.dcm", cut);
    expect_error([&] { open_volume(dir / "cut.dcm"); }, {"cut.dcm"});
  }
  DicomData().write(dir / "meta_only.dcm");
  expect_error([&] { open_volume(dir / "meta_only.dcm"); }, {"meta_only.dcm", "no data set"});
}

TEST(IoDicom, JunkWithTheSignatureIsAFormatError) {
  TempDir dir;
  std::ofstream(dir / "junk.dcm", std::ios::binary) << std::string(128, '\0') << "DICM" << std::string(40, '\xff');
  EXPECT_THROW(open_volume(dir / "junk.dcm"), Error);
}

}  // namespace
}  // namespace strata::io
