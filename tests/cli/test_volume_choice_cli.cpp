// Files of several 3D volumes (a NIfTI time series) through the `strata` program: `info`
// describes volume 0 and counts them, --volume T picks one for every command that reads a
// volume, and a command without a choice is told how to make one. `compress` and `labels
// encode` store every volume with --all-volumes, as one .strata volume set that the same
// --volume T opens.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <string>

#include "cli/cli_test_util.hpp"
#include "io/io_test_util.hpp"
#include "strata/io/volume_io.hpp"
#include "support/test_support.hpp"

namespace strata {
namespace {

namespace fs = std::filesystem;
using test::run_command;
using test::shell_quoted;
using test::strata_cmd;

// Two 6 x 5 x 4 u16 volumes in one NIfTI-1 file: our writer's header for the first, with
// dim[0] = 4 and dim[4] = 2, followed by both volumes.
Volume ramp(std::uint16_t start) {
  Volume v(Extent{6, 5, 4}, DType::u16);
  auto s = v.samples<std::uint16_t>();
  for (std::size_t i = 0; i < s.size(); ++i) s[i] = std::uint16_t(start + 3 * i);
  return v;
}

void write_time_series(const fs::path& path, const Volume& first, const Volume& second) {
  io::write_volume(path, first);
  auto bytes = test::io::read_bytes(path);
  const std::int16_t rank = 4, count = 2;
  std::memcpy(bytes.data() + 40, &rank, 2);   // dim[0]
  std::memcpy(bytes.data() + 48, &count, 2);  // dim[4]
  const auto* extra = static_cast<const std::byte*>(second.bytes());
  bytes.insert(bytes.end(), extra, extra + second.byte_size());
  test::io::write_bytes(path, bytes);
}

TEST(CliVolumeChoice, InfoConvertAndCompressTakeTheChosenVolume) {
  test::TempDir dir;
  const fs::path series = dir / "series.nii";
  const Volume first = ramp(100), second = ramp(5000);
  write_time_series(series, first, second);
  const auto q = [&](const std::string& name) { return shell_quoted(dir / name); };

  std::string out;
  ASSERT_EQ(run_command(strata_cmd("info " + q("series.nii")), &out), 0) << out;
  EXPECT_NE(out.find("volumes:     2 of these dims; the statistics below are of volume 0"), std::string::npos) << out;
  EXPECT_NE(out.find("range:       [100, 457]"), std::string::npos) << out;  // 100 + 3 * 119
  // Every volume gets a line: T, min, max, mean (the ramp's midpoint), stddev, non-finite.
  EXPECT_NE(out.find("      1         5000         5357       5178.5"), std::string::npos) << out;
  ASSERT_EQ(run_command(strata_cmd("info " + q("series.nii") + " --volume 1 --json"), &out), 0) << out;
  EXPECT_NE(out.find("\"min\": 5000.0"), std::string::npos) << out;

  ASSERT_EQ(run_command(strata_cmd("convert " + q("series.nii") + " " + q("second.nrrd") + " --volume 1"), &out), 0) << out;
  EXPECT_EQ(io::read_volume(dir / "second.nrrd"), second);

  // Without a choice, commands other than info say how to make one; a volume past the last
  // one, or a negative one, is refused by name.
  EXPECT_EQ(run_command(strata_cmd("compress " + q("series.nii") + " -o " + q("s.strata") + " --psnr 40"), &out), 1);
  EXPECT_NE(out.find("holds 2 volumes"), std::string::npos) << out;
  EXPECT_NE(out.find("--volume T (0..1)"), std::string::npos) << out;
  EXPECT_EQ(run_command(strata_cmd("info " + q("series.nii") + " --volume 2"), &out), 1);
  EXPECT_NE(out.find("error: --volume: "), std::string::npos) << out;
  EXPECT_EQ(run_command(strata_cmd("info " + q("series.nii") + " --volume -1"), &out), 2);
  EXPECT_NE(out.find("non-negative integer"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir / "s.strata"));

  // The chosen volume compresses, and decompresses to itself within the target.
  ASSERT_EQ(run_command(strata_cmd("compress " + q("series.nii") + " -o " + q("s.strata") + " --volume 1 --max-error 1"),
                        &out),
            0)
      << out;
  ASSERT_EQ(run_command(strata_cmd("decompress " + q("s.strata") + " -o " + q("back.nrrd")), &out), 0) << out;
  const Volume back = io::read_volume(dir / "back.nrrd");
  ASSERT_EQ(back.dims(), second.dims());
  const Volume back_u16 = back.dtype() == DType::u16 ? back : back.converted(DType::u16);
  const auto a = back_u16.samples<std::uint16_t>(), b = second.samples<std::uint16_t>();
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_LE(std::abs(int(a[i]) - int(b[i])), 1) << i;
}

void expect_within(const Volume& decoded, const Volume& original, int bound) {
  ASSERT_EQ(decoded.dims(), original.dims());
  const Volume as_u16 = decoded.dtype() == DType::u16 ? decoded : decoded.converted(DType::u16);
  const auto a = as_u16.samples<std::uint16_t>(), b = original.samples<std::uint16_t>();
  for (std::size_t i = 0; i < a.size(); ++i) ASSERT_LE(std::abs(int(a[i]) - int(b[i])), bound) << i;
}

TEST(CliVolumeChoice, AllVolumesMakeOneSetThatVolumeOpens) {
  test::TempDir dir;
  const Volume first = ramp(100), second = ramp(5000);
  write_time_series(dir / "series.nii", first, second);
  const auto q = [&](const std::string& name) { return shell_quoted(dir / name); };
  std::string out;
  ASSERT_EQ(run_command(strata_cmd("compress " + q("series.nii") + " -o " + q("set.strata") + " --all-volumes --max-error 1"),
                        &out),
            0)
      << out;
  EXPECT_NE(out.find("set.strata (volume 1): "), std::string::npos) << out;
  EXPECT_NE(out.find("a volume set of 2 volumes"), std::string::npos) << out;
  for (const auto& e : fs::directory_iterator(dir.path()))  // the members' temporaries are gone
    EXPECT_EQ(e.path().extension(), e.path().filename() == "series.nii" ? ".nii" : ".strata") << e.path();

  ASSERT_EQ(run_command(strata_cmd("info " + q("set.strata")), &out), 0) << out;
  EXPECT_NE(out.find(".strata volume set of 2 volumes"), std::string::npos) << out;
  EXPECT_NE(out.find("(volume 1)"), std::string::npos) << out;
  EXPECT_NE(out.find("value range [5000.0,5357.0]"), std::string::npos) << out;  // 5000 + 3 * 119
  ASSERT_EQ(run_command(strata_cmd("info " + q("set.strata") + " --volume 0 --json"), &out), 0) << out;
  EXPECT_NE(out.find("\"value_range\": [\n      100.0,\n      457.0"), std::string::npos) << out;

  for (int t : {0, 1}) {
    const std::string back = "back" + std::to_string(t) + ".nrrd";
    ASSERT_EQ(run_command(strata_cmd("decompress " + q("set.strata") + " --volume " + std::to_string(t) + " -o " + q(back)),
                          &out),
              0)
        << out;
    expect_within(io::read_volume(dir / back), t == 0 ? first : second, 1);
  }
  ASSERT_EQ(run_command(strata_cmd("eval " + q("series.nii") + " " + q("set.strata") + " --volume 1 --json"), &out), 0) << out;
  EXPECT_NE(out.find("\"max_abs_error\""), std::string::npos) << out;
  ASSERT_EQ(run_command(strata_cmd("render " + q("set.strata") + " --volume 1 --size 32x24 -o " + q("v1.png")), &out), 0)
      << out;
  EXPECT_TRUE(fs::exists(dir / "v1.png"));

  // Without a choice, or past the last volume, commands say what to do.
  EXPECT_EQ(run_command(strata_cmd("decompress " + q("set.strata") + " -o " + q("x.nrrd")), &out), 1);
  EXPECT_NE(out.find("holds 2 volumes; choose one with --volume T (0..1)"), std::string::npos) << out;
  EXPECT_EQ(run_command(strata_cmd("render " + q("set.strata") + " --volume 2 --size 32x24 -o " + q("x.png")), &out), 1);
  EXPECT_NE(out.find("error: --volume: "), std::string::npos) << out;
  EXPECT_NE(out.find("volume 2 does not exist"), std::string::npos) << out;
  EXPECT_EQ(run_command(strata_cmd("compress " + q("series.nii") + " -o " + q("y.strata") + " --all-volumes --volume 1"),
                        &out),
            2);
  EXPECT_FALSE(fs::exists(dir / "y.strata"));
}

TEST(CliVolumeChoice, LabelSeriesEncodeIntoOneSetDecodedExactly) {
  test::TempDir dir;
  Volume first(Extent{6, 5, 4}, DType::u16), second(Extent{6, 5, 4}, DType::u16);
  auto a = first.samples<std::uint16_t>(), b = second.samples<std::uint16_t>();
  for (std::size_t i = 0; i < a.size(); ++i) {
    a[i] = std::uint16_t(i % 7 < 3 ? 1 : 2);
    b[i] = std::uint16_t(10 + i / 40);
  }
  write_time_series(dir / "labels.nii", first, second);
  const auto q = [&](const std::string& name) { return shell_quoted(dir / name); };
  std::string out;
  ASSERT_EQ(run_command(strata_cmd("labels encode " + q("labels.nii") + " -o " + q("l.strata") + " --all-volumes"), &out), 0)
      << out;
  for (int t : {0, 1}) {
    const std::string back = "l" + std::to_string(t) + ".nrrd";
    ASSERT_EQ(run_command(strata_cmd("labels decode " + q("l.strata") + " --volume " + std::to_string(t) + " --level 0 -o " +
                                     q(back)),
                          &out),
              0)
        << out;
    EXPECT_EQ(io::read_volume(dir / back), t == 0 ? first : second);
  }
  // A volume that cannot be encoded leaves no set and no temporaries behind.
  const Volume real(Extent{6, 5, 4}, DType::f32);
  write_time_series(dir / "real.nii", real, real);
  ASSERT_EQ(run_command(strata_cmd("labels encode " + q("real.nii") + " -o " + q("r.strata") + " --all-volumes"), &out), 1);
  EXPECT_NE(out.find("a label volume needs integer samples"), std::string::npos) << out;
  for (const auto& e : fs::directory_iterator(dir.path()))
    EXPECT_EQ(e.path().filename().string().find(".part"), std::string::npos) << e.path();
  EXPECT_FALSE(fs::exists(dir / "r.strata"));
}

}  // namespace
}  // namespace strata
