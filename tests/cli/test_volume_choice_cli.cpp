// Files of several 3D volumes (a NIfTI time series) through the `strata` program: `info`
// describes volume 0 and counts them, --volume T picks one for every command that reads a
// volume, and a command without a choice is told how to make one.
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

}  // namespace
}  // namespace strata
