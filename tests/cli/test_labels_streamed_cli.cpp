// `strata labels encode` on a label volume from a file and `strata labels decode` back: streamed
// in slabs, never held whole, and --memory-limit refused by name when it cannot hold the coarser
// mip levels.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "cli/cli_test_util.hpp"

using strata::test::PeakRun;
using strata::test::run_command;
using strata::test::run_measuring_peak;
using strata::test::strata_cmd;
using strata::test::TempDir;

// A tall u32 segmentation of 128 MiB: holding it (as the encoder once did) and its source ids
// would take twice that. Streamed, the input slabs and level 0's ids never are whole, so the
// peak stays under the size of the input itself.
TEST(CliLabelsStreamed, EncodesAVolumeWithoutHoldingIt) {
  TempDir dir;
  const std::string in = (dir / "tall.nrrd").string();
  std::string out;
  ASSERT_EQ(run_command(strata_cmd("generate fibres --size 128,128,2048 --count 300 -o " + in), &out), 0) << out;
  const std::uint64_t input_bytes = 128ull * 128 * 2048 * 4;
  const PeakRun run = run_measuring_peak({"--threads", "2", "labels", "encode", in, "-o", (dir / "tall.strata").string(),
                                          "--memory-limit", "96M", "--no-error"});
  ASSERT_EQ(run.exit_code, 0);
  EXPECT_LT(run.peak_rss_bytes, input_bytes) << "peak RSS " << (run.peak_rss_bytes >> 20) << " MiB";
  // Decoded slab by slab as well: level 0 back to the original labels, never held whole.
  const std::string l0 = (dir / "l0.raw").string();
  const PeakRun decode = run_measuring_peak({"labels", "decode", (dir / "tall.strata").string(), "--level", "0", "-o", l0});
  ASSERT_EQ(decode.exit_code, 0);
  EXPECT_LT(decode.peak_rss_bytes, input_bytes) << "decode peak RSS " << (decode.peak_rss_bytes >> 20) << " MiB";
  ASSERT_EQ(run_command(strata_cmd("compare --json " + in + " " + l0), &out), 0) << out;
  EXPECT_NE(out.find("\"max_abs_error\": 0.0"), std::string::npos) << out;
}

TEST(CliLabelsStreamed, ALimitTooSmallIsRefusedNamingTheFlag) {
  TempDir dir;
  const std::string in = (dir / "v.nrrd").string();
  std::string out;
  ASSERT_EQ(run_command(strata_cmd("generate voronoi --size 64 --count 20 -o " + in), &out), 0) << out;
  const std::string enc = (dir / "v.strata").string();
  EXPECT_EQ(run_command(strata_cmd("labels encode " + in + " -o " + enc + " --memory-limit 1M"), &out), 1) << out;
  EXPECT_NE(out.find("--memory-limit"), std::string::npos) << out;
  EXPECT_NE(out.find("coarser mip levels"), std::string::npos) << out;
  EXPECT_FALSE(std::filesystem::exists(enc));
  EXPECT_EQ(run_command(strata_cmd("labels encode " + in + " -o " + enc + " --memory-limit lots"), &out), 2) << out;
  EXPECT_NE(out.find("--memory-limit"), std::string::npos) << out;
}
