// Drives the built `strata` program: exit codes, error messages and the acceptance figures of
// `strata info` on the real sample data.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "cli/cli_test_util.hpp"
#include "support/test_support.hpp"

using strata::test::run_command;
using strata::test::strata_cmd;
using strata::test::TempDir;

namespace {

nlohmann::json info_json(const std::string& file) {
  std::string out;
  int code = run_command(strata_cmd("info --json '" + file + "'"), &out);
  EXPECT_EQ(code, 0) << out;
  return nlohmann::json::parse(out);
}

}  // namespace

TEST(CliProgram, UsageErrorsExitWithTwo) {
  std::string out;
  EXPECT_EQ(run_command(strata_cmd(""), &out), 2);
  EXPECT_EQ(run_command(strata_cmd("frobnicate"), &out), 2);
  EXPECT_EQ(run_command(strata_cmd("generate prisms --size 8 --count -3 -o x.nrrd"), &out), 2);
  EXPECT_EQ(run_command(strata_cmd("info --help"), &out), 0);
}

TEST(CliProgram, RuntimeErrorsExitWithOneAndNameTheFile) {
  TempDir dir;
  std::string out;
  EXPECT_EQ(run_command(strata_cmd("info '" + (dir / "missing.nrrd").string() + "'"), &out), 1);
  EXPECT_NE(out.find("error: "), std::string::npos) << out;
  EXPECT_NE(out.find("missing.nrrd"), std::string::npos) << out;

  std::ofstream(dir / "bad.nrrd") << "NRRD0004\ntype: quaternion\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\n12345678";
  EXPECT_EQ(run_command(strata_cmd("info '" + (dir / "bad.nrrd").string() + "'"), &out), 1);
  EXPECT_NE(out.find("bad.nrrd"), std::string::npos) << out;
  EXPECT_NE(out.find("type"), std::string::npos) << out;

  EXPECT_EQ(run_command(strata_cmd("generate nonsense --size 8 -o '" + (dir / "x.nrrd").string() + "'"), &out), 1);
  EXPECT_NE(out.find("prisms"), std::string::npos) << out;  // lists the valid kinds
}

// A raw file without a sidecar: the library names ReadOptions::raw_dims / raw_dtype, the CLI
// the flags that set them.
TEST(CliProgram, RawInputWithoutDimsOrDtypeNamesTheFlag) {
  TempDir dir;
  const std::string raw = strata::test::shell_quoted(dir / "lonely.raw");
  std::ofstream(dir / "lonely.raw") << std::string(64, 'x');
  std::string out;
  EXPECT_EQ(run_command(strata_cmd("info " + raw), &out), 1);
  EXPECT_NE(out.find("error: --dims: "), std::string::npos) << out;
  EXPECT_NE(out.find("lonely.raw.json"), std::string::npos) << out;
  EXPECT_EQ(run_command(strata_cmd("info " + raw + " --dims 4,4,4"), &out), 1);
  EXPECT_NE(out.find("error: --dtype: "), std::string::npos) << out;
  EXPECT_EQ(out.find("ReadOptions"), std::string::npos) << out;
  EXPECT_EQ(run_command(strata_cmd("info " + raw + " --dims 4,4,4 --dtype u8"), &out), 0) << out;
}

TEST(CliProgram, GenerateConvertCompareRoundTrip) {
  TempDir dir;
  const std::string nrrd = (dir / "p.nrrd").string(), nii = (dir / "p.nii.gz").string(),
                    tif = (dir / "p.tif").string(), raw = (dir / "p.raw").string();
  std::string out;
  ASSERT_EQ(run_command(strata_cmd("generate prisms --size 40,32,24 --seed 3 -o " + nrrd), &out), 0) << out;
  ASSERT_EQ(run_command(strata_cmd("convert " + nrrd + " " + nii), &out), 0) << out;
  ASSERT_EQ(run_command(strata_cmd("convert " + nii + " " + tif), &out), 0) << out;
  ASSERT_EQ(run_command(strata_cmd("convert " + tif + " " + raw), &out), 0) << out;
  auto info = info_json(raw);
  EXPECT_EQ(info["dims"], nlohmann::json({40, 32, 24}));
  EXPECT_EQ(info["dtype"], "u16");
  ASSERT_EQ(run_command(strata_cmd("compare --json " + nrrd + " " + raw), &out), 0) << out;
  auto m = nlohmann::json::parse(out);
  EXPECT_EQ(m["snr_db"], "inf");
  EXPECT_EQ(m["max_abs_error"], 0.0);
  EXPECT_EQ(m["voxels"], 40 * 32 * 24);

  // A different seed gives a finite SNR: compare really looks at the samples.
  const std::string other = (dir / "q.nrrd").string();
  ASSERT_EQ(run_command(strata_cmd("generate prisms --size 40,32,24 --seed 4 -o " + other), &out), 0) << out;
  ASSERT_EQ(run_command(strata_cmd("compare --json " + nrrd + " " + other), &out), 0) << out;
  auto m2 = nlohmann::json::parse(out);
  ASSERT_TRUE(m2["snr_db"].is_number());
  EXPECT_GT(m2["max_abs_error"].get<double>(), 0.0);
}

TEST(CliProgram, InfoOnSampleLabelVolumes) {
  if (auto gt = strata::test::shared_data("fibsem_medulla_250_gt.nrrd")) {
    auto j = info_json(gt->string());
    EXPECT_EQ(j["dims"], nlohmann::json({250, 250, 250}));
    EXPECT_EQ(j["dtype"], "u32");
    EXPECT_EQ(j["distinct_values"], 526);
  }
  if (auto frog = strata::test::shared_data("vtk_frog_tissue.nrrd")) {
    auto j = info_json(frog->string());
    EXPECT_EQ(j["dims"], nlohmann::json({500, 470, 136}));
    EXPECT_EQ(j["dtype"], "u8");
    EXPECT_EQ(j["distinct_values"], 26);
    EXPECT_NEAR(j["background_fraction"].get<double>(), 0.9638, 1e-4);
  }
}

TEST(CliProgram, InfoOnMricronData) {
  if (auto ch2 = strata::test::mricron_data("ch2better.nii.gz")) {
    auto j = info_json(ch2->string());
    EXPECT_EQ(j["dims"], nlohmann::json({301, 370, 316}));
    EXPECT_EQ(j["dtype"], "u8");
  }
  if (auto aal = strata::test::mricron_data("aal.nii.gz")) {
    auto j = info_json(aal->string());
    EXPECT_EQ(j["dims"], nlohmann::json({181, 217, 181}));
    EXPECT_EQ(j["distinct_values"], 117);
    EXPECT_GT(j["background_fraction"].get<double>(), 0.0);  // 0 is among the values
  }
}

TEST(CliProgram, DemoWritesReport) {
  TempDir dir;
  std::string out;
  ASSERT_EQ(run_command(strata_cmd("demo --size 32 -o '" + (dir / "demo").string() + "'"), &out), 0) << out;
  std::ifstream in(dir / "demo" / "report.json");
  ASSERT_TRUE(in.good());
  auto report = nlohmann::json::parse(in);
  EXPECT_TRUE(report["round_trip_bit_exact"].get<bool>());
  EXPECT_GT(report["metrics"][0]["snr_db"].get<double>(), 20.0);  // 8-bit requantization of a u16 volume
  EXPECT_FALSE(std::filesystem::exists(dir / "demo" / "report.json.tmp"));
}
