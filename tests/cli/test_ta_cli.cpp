// `strata compress`, `decompress` and `eval` end to end on a generated volume: outputs, their
// types and sizes, the eval report's figures, exit codes and error messages.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>

#include "strata/core/metrics.hpp"
#include "strata/io/volume_io.hpp"
#include "cli/cli_test_util.hpp"
#include "support/test_support.hpp"

using strata::test::PeakRun;
using strata::test::run_command;
using strata::test::run_measuring_peak;
using strata::test::strata_cmd;
using strata::test::TempDir;
namespace fs = std::filesystem;

namespace {

std::string q(const fs::path& p) { return strata::test::shell_quoted(p); }
bool has(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

// One generated volume and its compression, shared by the tests of this file:
// 40x36x30 u16 prisms, brick 16, overlap 2 (core 12), rank 8, u16,b8log+.
// Levels: 40x36x30 (4x3x3 bricks), 20x18x15 (2x2x2), 10x9x8 (1).
class CliTa : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new TempDir;
    std::string out;
    ASSERT_EQ(run_command(strata_cmd("generate prisms --size 40,36,30 --seed 5 -o " + q(original())), &out), 0) << out;
    ASSERT_EQ(run_command(strata_cmd("compress " + q(original()) + " -o " + q(compressed()) + " --brick 16 --rank 8"), &out), 0)
        << out;
    compress_output_ = new std::string(out);
  }
  static void TearDownTestSuite() {
    delete compress_output_;
    delete dir_;
  }
  static fs::path original() { return *dir_ / "p.nrrd"; }
  static fs::path compressed() { return *dir_ / "p.strata"; }
  static fs::path file(const std::string& name) { return *dir_ / name; }

  static nlohmann::json eval_json(const std::string& extra = "") {
    std::string out;
    const int code = run_command(strata_cmd("eval " + q(original()) + " " + q(compressed()) + " --json " + extra), &out);
    EXPECT_EQ(code, 0) << out;
    return nlohmann::json::parse(out);
  }

  static inline TempDir* dir_ = nullptr;
  static inline std::string* compress_output_ = nullptr;
};

}  // namespace

TEST_F(CliTa, CompressReportsBricksLevelsAndRate) {
  EXPECT_TRUE(fs::exists(compressed()));
  EXPECT_FALSE(fs::exists(file("p.strata.tmp")));
  // 36 + 8 + 1 bricks in 3 levels.
  EXPECT_TRUE(has(*compress_output_, "45 bricks in 3 levels")) << *compress_output_;
  EXPECT_TRUE(has(*compress_output_, "bits/voxel")) << *compress_output_;
}

TEST_F(CliTa, DecompressLevel0ReturnsTheSourceTypeCloseToTheOriginal) {
  std::string out;
  ASSERT_EQ(run_command(strata_cmd("decompress " + q(compressed()) + " -o " + q(file("d.nrrd"))), &out), 0) << out;
  const strata::Volume source = strata::io::read_volume(original());
  const strata::Volume d = strata::io::read_volume(file("d.nrrd"));
  EXPECT_EQ(d.dims(), (strata::Extent{40, 36, 30}));
  EXPECT_EQ(d.dtype(), strata::DType::u16);
  EXPECT_GT(strata::compare_volumes(source, d).snr_db, 20.0);

  ASSERT_EQ(run_command(strata_cmd("decompress " + q(compressed()) + " --float -o " + q(file("f.nrrd"))), &out), 0) << out;
  const strata::Volume f = strata::io::read_volume(file("f.nrrd"));
  EXPECT_EQ(f.dtype(), strata::DType::f32);
  // The u16 output is the float output rounded (and clamped to the u16 range).
  EXPECT_TRUE(f.converted(strata::DType::u16) == d);
}

TEST_F(CliTa, DecompressLevelRankAndBox) {
  std::string out;
  ASSERT_EQ(run_command(strata_cmd("decompress " + q(compressed()) + " --level 1 -o " + q(file("l1.nrrd"))), &out), 0) << out;
  const strata::Volume l1 = strata::io::read_volume(file("l1.nrrd"));
  EXPECT_EQ(l1.dims(), (strata::Extent{20, 18, 15}));
  EXPECT_EQ(l1.dtype(), strata::DType::f32);  // averages are not source samples
  EXPECT_EQ(l1.spacing().x, 2.0 * strata::io::read_volume(original()).spacing().x);

  ASSERT_EQ(run_command(strata_cmd("decompress " + q(compressed()) + " --level 2 -o " + q(file("l2.nrrd"))), &out), 0) << out;
  EXPECT_EQ(strata::io::read_volume(file("l2.nrrd")).dims(), (strata::Extent{10, 9, 8}));

  // A box across brick seams (cores are 12 wide) equals the same voxels of the full decode.
  ASSERT_EQ(run_command(strata_cmd("decompress " + q(compressed()) + " --float --rank 4 -o " + q(file("r4.nrrd"))), &out), 0)
      << out;
  ASSERT_EQ(run_command(strata_cmd("decompress " + q(compressed()) + " --float --rank 4 --box 5,10,11:30,25,26 -o " +
                                   q(file("box.nrrd"))),
                        &out),
            0)
      << out;
  const strata::Volume box = strata::io::read_volume(file("box.nrrd"));
  EXPECT_EQ(box.dims(), (strata::Extent{25, 15, 15}));
  EXPECT_TRUE(box == strata::io::read_volume(file("r4.nrrd")).crop({{5, 10, 11}, {30, 25, 26}}));
  // Rank 4 is a different (coarser) reconstruction than the stored rank 8.
  const strata::Volume f8 = [&] {
    EXPECT_EQ(run_command(strata_cmd("decompress " + q(compressed()) + " --float -o " + q(file("r8.nrrd"))), &out), 0);
    return strata::io::read_volume(file("r8.nrrd"));
  }();
  EXPECT_FALSE(f8 == strata::io::read_volume(file("r4.nrrd")));
  // Other output formats.
  ASSERT_EQ(run_command(strata_cmd("decompress " + q(compressed()) + " --box 0,0,0:8,8,8 -o " + q(file("b.raw"))), &out), 0)
      << out;
  EXPECT_EQ(fs::file_size(file("b.raw")), 8u * 8u * 8u * 2u);  // u16 samples
}

TEST_F(CliTa, EvalJsonReportsStorageAndError) {
  const nlohmann::json r = eval_json();
  const auto& s = r["storage"];
  const double voxels = 40.0 * 36 * 30;
  const double file_bytes = double(fs::file_size(compressed()));
  EXPECT_EQ(s["file_bytes"].get<double>(), file_bytes);
  EXPECT_NEAR(s["bits_per_voxel"].get<double>(), 8 * file_bytes / voxels, 1e-9);
  EXPECT_NEAR(s["bits_per_voxel_cores"].get<double>() + s["bits_per_voxel_factors"].get<double>() +
                  s["bits_per_voxel_brick_headers"].get<double>() + s["bits_per_voxel_container"].get<double>(),
              s["bits_per_voxel"].get<double>(), 1e-9);
  // Levels: dims, brick and constant counts.
  ASSERT_EQ(s["levels"].size(), 3u);
  EXPECT_EQ(s["levels"][0]["dims"], nlohmann::json({40, 36, 30}));
  EXPECT_EQ(s["levels"][0]["bricks"], 36);
  EXPECT_EQ(s["levels"][1]["dims"], nlohmann::json({20, 18, 15}));
  EXPECT_EQ(s["levels"][1]["bricks"], 8);
  EXPECT_EQ(s["levels"][2]["bricks"], 1);
  std::int64_t tucker = 0;
  for (const auto& l : s["levels"]) tucker += l["bricks"].get<std::int64_t>() - l["constant"].get<std::int64_t>();
  EXPECT_EQ(tucker, 45);  // prisms has no flat brick
  // Per-level payload bytes: every level stores some, they sum to the file's payloads (the rest
  // is index, metadata and alignment), and each level's bits/voxel is over the source's voxels.
  double payload = 0;
  for (const auto& l : s["levels"]) {
    EXPECT_GT(l["payload_bytes"].get<double>(), 0.0);
    EXPECT_NEAR(l["bits_per_voxel"].get<double>(), 8 * l["payload_bytes"].get<double>() / voxels, 1e-9);
    payload += l["payload_bytes"].get<double>();
  }
  EXPECT_LT(payload, file_bytes);
  EXPECT_GT(s["levels"][0]["payload_bytes"].get<double>(), s["levels"][1]["payload_bytes"].get<double>());
  EXPECT_NEAR(8 * (file_bytes - payload) / voxels, s["bits_per_voxel_container"].get<double>(), 1e-9);
  // The zstd stage (on by default) is attributed to the parts in proportion to their plain
  // sizes: u16,b8log+ at B = 16, R = 8 has 8^3 one-byte core codes and 3 * 16 * 8 two-byte
  // factor codes per brick, so cores : factors = 512 : 768 up to per-brick rounding.
  EXPECT_NEAR(s["bits_per_voxel_cores"].get<double>() / s["bits_per_voxel_factors"].get<double>(), 512.0 / 768.0, 0.01);
  EXPECT_LT(s["bits_per_voxel_cores"].get<double>(), 8.0 * double(tucker) * 512 / voxels);

  // The error figures are those of the decoded level 0 against the original.
  const auto& e = r["error"];
  EXPECT_EQ(e["rank"], 8);
  std::string out;
  ASSERT_EQ(run_command(strata_cmd("decompress " + q(compressed()) + " --float -o " + q(file("e.nrrd"))), &out), 0) << out;
  const strata::ErrorMetrics m =
      strata::compare_volumes(strata::io::read_volume(original()), strata::io::read_volume(file("e.nrrd")));
  EXPECT_NEAR(e["snr_db"].get<double>(), m.snr_db, 1e-6);
  EXPECT_NEAR(e["psnr_db"].get<double>(), m.psnr_db, 1e-6);
  EXPECT_NEAR(e["rmse"].get<double>(), m.rmse, 1e-6 * m.rmse);
  EXPECT_NEAR(e["max_abs_error"].get<double>(), m.max_abs_error, 1e-3);
  EXPECT_GT(r["decode_seconds"].get<double>(), 0.0);
}

TEST_F(CliTa, EvalWithoutZstdShowsThePlainPartSizes) {
  std::string out;
  const fs::path plain = file("plain.strata");
  ASSERT_EQ(run_command(strata_cmd("compress " + q(original()) + " -o " + q(plain) + " --brick 16 --rank 8 --zstd 0"), &out), 0)
      << out;
  EXPECT_LT(fs::file_size(compressed()), fs::file_size(plain));  // the zstd stage saves bytes
  ASSERT_EQ(run_command(strata_cmd("eval " + q(original()) + " " + q(plain) + " --json"), &out), 0) << out;
  const nlohmann::json r = nlohmann::json::parse(out);
  const auto& s = r["storage"];
  const double voxels = 40.0 * 36 * 30, tucker = 45;
  // Per brick: 8^3 one-byte core codes, 3 * 16 * 8 two-byte factor codes, 28 header bytes
  // (6 u16 extents and ranks, factor lo/hi, core max |b|, hot corner).
  EXPECT_NEAR(s["bits_per_voxel_cores"].get<double>(), 8.0 * tucker * 512 / voxels, 1e-9);
  EXPECT_NEAR(s["bits_per_voxel_factors"].get<double>(), 8.0 * tucker * 768 / voxels, 1e-9);
  EXPECT_NEAR(s["bits_per_voxel_brick_headers"].get<double>(), 8.0 * tucker * 28 / voxels, 1e-9);
  // The zstd stage is lossless: same reconstruction error.
  EXPECT_EQ(r["error"]["snr_db"].get<double>(), eval_json()["error"]["snr_db"].get<double>());
}

TEST_F(CliTa, EvalRankSlider) {
  const double s8 = eval_json()["error"]["snr_db"].get<double>();
  const nlohmann::json r4 = eval_json("--rank 4");
  EXPECT_EQ(r4["error"]["rank"], 4);
  EXPECT_LT(r4["error"]["snr_db"].get<double>(), s8);
  const nlohmann::json r8 = eval_json("--rank 8");  // the stored rank (more is refused, as decompress does)
  EXPECT_EQ(r8["error"]["rank"], 8);
  EXPECT_EQ(r8["error"]["snr_db"].get<double>(), s8);
  // The human-readable report carries the same figures.
  std::string out;
  ASSERT_EQ(run_command(strata_cmd("eval " + q(original()) + " " + q(compressed())), &out), 0) << out;
  EXPECT_TRUE(has(out, "bits/voxel")) << out;
  EXPECT_TRUE(has(out, "SNR")) << out;
}

TEST_F(CliTa, UsageErrorsExitWithTwo) {
  std::string out;
  const std::string in = q(original()), ta = q(compressed()), o = q(file("u.strata"));
  EXPECT_EQ(run_command(strata_cmd("compress " + in), &out), 2) << out;                       // no -o
  EXPECT_EQ(run_command(strata_cmd("compress " + in + " -o " + o + " --rank abc"), &out), 2) << out;
  EXPECT_EQ(run_command(strata_cmd("compress " + in + " -o " + o + " --brick 1.5"), &out), 2) << out;
  EXPECT_EQ(run_command(strata_cmd("decompress " + ta), &out), 2) << out;                      // no -o
  EXPECT_EQ(run_command(strata_cmd("decompress " + ta + " -o x.nrrd --level one"), &out), 2) << out;
  EXPECT_EQ(run_command(strata_cmd("eval " + in), &out), 2) << out;                            // no .strata
  EXPECT_EQ(run_command(strata_cmd("eval " + in + " " + ta + " --rank x"), &out), 2) << out;
  EXPECT_FALSE(fs::exists(file("u.strata")));
  EXPECT_EQ(run_command(strata_cmd("compress --help"), &out), 0);
  EXPECT_TRUE(has(out, "--rank")) << out;
}

// The library's errors name its parameters (CodecParams::rank, level, ...); the CLI reports
// them as the flags that set them.
TEST_F(CliTa, BadParameterValuesExitWithOneAndNameTheOption) {
  std::string out;
  const std::string in = q(original()), ta = q(compressed());
  EXPECT_EQ(run_command(strata_cmd("compress " + in + " -o " + q(file("r.strata")) + " --brick 16 --rank 17"), &out), 1) << out;
  EXPECT_TRUE(has(out, "error: --rank: must be between 1 and the brick width 16, got 17")) << out;
  EXPECT_FALSE(has(out, "CodecParams")) << out;
  EXPECT_EQ(run_command(strata_cmd("compress " + in + " -o " + q(file("r.strata")) + " --brick 16 --overlap 8"), &out), 1)
      << out;
  EXPECT_TRUE(has(out, "error: --overlap: ")) << out;
  EXPECT_EQ(run_command(strata_cmd("compress " + in + " -o " + q(file("r.strata")) + " --brick 300"), &out), 1) << out;
  EXPECT_TRUE(has(out, "error: --brick: must be in 2..256, got 300")) << out;
  EXPECT_FALSE(has(out, "BrickLayout")) << out;
  EXPECT_EQ(run_command(strata_cmd("compress " + in + " -o " + q(file("r.strata")) + " --memory-limit 1k"), &out), 1) << out;
  EXPECT_TRUE(has(out, "error: --memory-limit: ")) << out;
  EXPECT_EQ(run_command(strata_cmd("compress " + in + " -o " + q(file("r.strata")) + " --quant u16,b9log"), &out), 1) << out;
  EXPECT_TRUE(has(out, "u16,b9log")) << out;
  EXPECT_FALSE(fs::exists(file("r.strata")));
  EXPECT_FALSE(fs::exists(file("r.strata.tmp")));
  EXPECT_EQ(run_command(strata_cmd("decompress " + ta + " --level 3 -o " + q(file("x.nrrd"))), &out), 1) << out;
  EXPECT_TRUE(has(out, "error: --level: 3 is not in 0..2 for ")) << out;
  EXPECT_EQ(run_command(strata_cmd("decompress " + ta + " --rank 9 -o " + q(file("x.nrrd"))), &out), 1) << out;
  EXPECT_TRUE(has(out, "--rank")) << out;
  EXPECT_EQ(run_command(strata_cmd("decompress " + ta + " --box 0,0,0:41,1,1 -o " + q(file("x.nrrd"))), &out), 1) << out;
  EXPECT_TRUE(has(out, "error: --box: ")) << out;
  EXPECT_EQ(run_command(strata_cmd("decompress " + ta + " --box 1,2,3 -o " + q(file("x.nrrd"))), &out), 1) << out;
  EXPECT_FALSE(fs::exists(file("x.nrrd")));
}

// A negative rank is not "the default": it must be refused like any other out-of-range rank.
TEST_F(CliTa, NegativeRankIsRefused) {
  std::string out;
  EXPECT_NE(run_command(strata_cmd("compress " + q(original()) + " -o " + q(file("neg.strata")) + " --rank -3"), &out), 0)
      << out;
  EXPECT_FALSE(fs::exists(file("neg.strata")));
  EXPECT_NE(run_command(strata_cmd("decompress " + q(compressed()) + " --rank -3 -o " + q(file("neg.nrrd"))), &out), 0)
      << out;
  EXPECT_FALSE(fs::exists(file("neg.nrrd")));
  EXPECT_NE(run_command(strata_cmd("eval " + q(original()) + " " + q(compressed()) + " --rank -3"), &out), 0) << out;
}

TEST_F(CliTa, BadFilesExitWithOneAndNameTheFile) {
  std::string out;
  EXPECT_EQ(run_command(strata_cmd("compress " + q(file("missing.nrrd")) + " -o " + q(file("m.strata"))), &out), 1) << out;
  EXPECT_TRUE(has(out, "error: ") && has(out, "missing.nrrd")) << out;
  EXPECT_FALSE(fs::exists(file("m.strata.tmp")));

  std::ofstream(file("junk.strata")) << "this is not a strata container, just some text padding it out to size";
  EXPECT_EQ(run_command(strata_cmd("decompress " + q(file("junk.strata")) + " -o " + q(file("j.nrrd"))), &out), 1) << out;
  EXPECT_TRUE(has(out, "error: ") && has(out, "junk.strata")) << out;
  EXPECT_EQ(run_command(strata_cmd("eval " + q(original()) + " " + q(file("junk.strata"))), &out), 1) << out;
  EXPECT_TRUE(has(out, "junk.strata")) << out;
  EXPECT_EQ(run_command(strata_cmd("decompress " + q(file("nope.strata")) + " -o " + q(file("j.nrrd"))), &out), 1) << out;
  EXPECT_TRUE(has(out, "nope.strata")) << out;

  // eval against an original of other dims names that file.
  ASSERT_EQ(run_command(strata_cmd("generate prisms --size 20,36,30 -o " + q(file("small.nrrd"))), &out), 0) << out;
  EXPECT_EQ(run_command(strata_cmd("eval " + q(file("small.nrrd")) + " " + q(compressed())), &out), 1) << out;
  EXPECT_TRUE(has(out, "small.nrrd") && has(out, "dims")) << out;
}

TEST_F(CliTa, FailedCompressLeavesNoTemporary) {
  std::string out;
  // Output directory missing.
  EXPECT_EQ(run_command(strata_cmd("compress " + q(original()) + " -o " + q(file("no/such/dir/x.strata"))), &out), 1) << out;
  EXPECT_TRUE(has(out, "x.strata")) << out;
  EXPECT_FALSE(fs::exists(file("no")));
  // Output path is an existing directory: everything is encoded, the final rename fails.
  fs::create_directory(file("taken.strata"));
  EXPECT_EQ(run_command(strata_cmd("compress " + q(original()) + " -o " + q(file("taken.strata"))), &out), 1) << out;
  EXPECT_TRUE(has(out, "error: ") && has(out, "taken.strata")) << out;
  EXPECT_FALSE(fs::exists(file("taken.strata.tmp")));
  EXPECT_TRUE(fs::is_directory(file("taken.strata")));
}

// A NaN sample compresses (its brick keeps a mask), decompresses, and `compare` finds it alike
// in both files.
TEST_F(CliTa, NanSamplesCompressAndCompareAlike) {
  std::string out;
  strata::Volume v = strata::io::read_volume(original()).converted(strata::DType::f32);
  v.set_value(20, 18, 15, std::numeric_limits<double>::quiet_NaN());
  strata::io::write_volume(file("nan.raw"), v);
  ASSERT_EQ(run_command(strata_cmd("compress " + q(file("nan.raw")) + " -o " + q(file("nan.strata")) + " --psnr 40"), &out),
            0) << out;
  ASSERT_EQ(run_command(strata_cmd("decompress " + q(file("nan.strata")) + " --float -o " + q(file("nan.nrrd"))), &out), 0)
      << out;
  ASSERT_EQ(run_command(strata_cmd("compare " + q(file("nan.raw")) + " " + q(file("nan.nrrd"))), &out), 0) << out;
  EXPECT_TRUE(has(out, "1 voxels NaN or infinite in both alike, 0 in one only")) << out;
}

// Failures while bricks are encoded (a full disk) must end in `error: ...` and exit 1 with the
// temporary removed, not in an abort.
TEST_F(CliTa, FailuresDuringEncodingExitWithOneAndLeaveNoTemporary) {
  std::string out;
  if (!fs::exists("/dev/full")) return;
  fs::create_symlink("/dev/full", file("full.strata.tmp"));
  EXPECT_EQ(run_command(strata_cmd("compress " + q(original()) + " --brick 16 -o " + q(file("full.strata"))), &out), 1) << out;
  EXPECT_TRUE(has(out, "error: ") && has(out, "full.strata")) << out;
  EXPECT_FALSE(fs::exists(file("full.strata")));
  EXPECT_FALSE(fs::exists(fs::symlink_status(file("full.strata.tmp"))));
}

TEST_F(CliTa, IsaOptionLimitsTheKernelsAndRejectsUnknownLevels) {
  // Compressed and evaluated with the generic kernels only: the decomposition and the
  // reconstruction round differently from the vector kernels, but the error is the same to
  // far better than 0.01 dB.
  std::string out;
  const fs::path generic = file("generic.strata");
  ASSERT_EQ(run_command(strata_cmd("--isa generic compress " + q(original()) + " -o " + q(generic) +
                                   " --brick 16 --rank 8"),
                        &out),
            0)
      << out;
  ASSERT_EQ(run_command(strata_cmd("--isa generic eval " + q(original()) + " " + q(generic) + " --json"), &out), 0)
      << out;
  const double snr_generic = nlohmann::json::parse(out)["error"]["snr_db"].get<double>();
  EXPECT_NEAR(snr_generic, eval_json()["error"]["snr_db"].get<double>(), 0.01);

  EXPECT_EQ(run_command(strata_cmd("--isa avx3 info " + q(original())), &out), 2) << out;
  EXPECT_TRUE(has(out, "--isa")) << out;
  EXPECT_EQ(run_command("STRATA_ISA=avx3 " + strata_cmd("info " + q(original())), &out), 1) << out;
  EXPECT_TRUE(has(out, "STRATA_ISA") && has(out, "avx3")) << out;
  EXPECT_EQ(run_command("STRATA_ISA=generic " + strata_cmd("info " + q(original())), &out), 0) << out;
}

// Error targets from the command line: the bound holds in what `decompress` writes and `eval`
// reports; a bad target names its flag; fixed-rank options are refused beside a target.
TEST_F(CliTa, ErrorTargetsCompressToTheirBoundAndRejectBadValues) {
  std::string out;
  const std::string in = q(original()), t = q(file("t.strata"));
  ASSERT_EQ(run_command(strata_cmd("compress " + in + " -o " + t + " --brick 16 --max-error 3"), &out), 0) << out;
  ASSERT_EQ(run_command(strata_cmd("eval " + in + " " + t + " --json"), &out), 0) << out;
  const nlohmann::json e = nlohmann::json::parse(out);
  EXPECT_LE(e["error"]["max_abs_error"].get<double>(), 3.0);
  EXPECT_GT(e["error"]["max_abs_error"].get<double>(), 0.0);
  ASSERT_EQ(run_command(strata_cmd("decompress " + t + " -o " + q(file("t.nrrd"))), &out), 0) << out;
  const strata::ErrorMetrics m =
      strata::compare_volumes(strata::io::read_volume(original()), strata::io::read_volume(file("t.nrrd")));
  EXPECT_LE(m.max_abs_error, 3.0);  // integer output: rounding keeps an integer bound

  ASSERT_EQ(run_command(strata_cmd("compress " + in + " -o " + t + " --brick 16 --psnr 45"), &out), 0) << out;
  ASSERT_EQ(run_command(strata_cmd("eval " + in + " " + t + " --json"), &out), 0) << out;
  EXPECT_GE(nlohmann::json::parse(out)["error"]["psnr_db"].get<double>(), 45.0);

  EXPECT_EQ(run_command(strata_cmd("compress " + in + " -o " + q(file("bad.strata")) + " --psnr -3"), &out), 2) << out;
  EXPECT_TRUE(has(out, "error: --psnr: ")) << out;
  EXPECT_EQ(run_command(strata_cmd("compress " + in + " -o " + q(file("bad.strata")) + " --max-error 0"), &out), 2) << out;
  EXPECT_TRUE(has(out, "error: --max-error: ")) << out;
  EXPECT_EQ(run_command(strata_cmd("compress " + in + " -o " + q(file("bad.strata")) + " --rmse 1 --coarse-growth 0.5"), &out),
            2)
      << out;
  EXPECT_TRUE(has(out, "error: --coarse-growth: ")) << out;
  EXPECT_EQ(run_command(strata_cmd("compress " + in + " -o " + q(file("bad.strata")) + " --psnr 40 --quant u8,b8lin"), &out),
            2)
      << out;
  EXPECT_EQ(run_command(strata_cmd("compress " + in + " -o " + q(file("bad.strata")) + " --psnr 40 --rmse 2"), &out), 2)
      << out;
  EXPECT_FALSE(fs::exists(file("bad.strata")));
}

// The global-basis codec through every command that reads a TA file.
TEST_F(CliTa, GlobalCodecCompressesAndEveryReaderTakesIt) {
  const fs::path global = dir_->path() / "global.strata";
  std::string out;
  ASSERT_EQ(run_command(strata_cmd("compress " + q(original()) + " -o " + q(global) + " --brick 16 --rank 8 --codec ta-global"),
                        &out),
            0)
      << out;
  EXPECT_TRUE(has(out, "global bases: fit ")) << out;
  ASSERT_EQ(run_command(strata_cmd("info " + q(global)), &out), 0) << out;
  EXPECT_TRUE(has(out, "codec:       ta-global")) << out;
  EXPECT_TRUE(has(out, "feature-scale ranks [2,4,6,8]")) << out;
  ASSERT_EQ(run_command(strata_cmd("eval " + q(original()) + " " + q(global) + " --json"), &out), 0) << out;
  const nlohmann::json j = nlohmann::json::parse(out);
  EXPECT_GT(j["storage"]["bits_per_voxel_feature_scale"].get<double>(), 0);
  EXPECT_GT(j["error"]["psnr_db"].get<double>(), 25);  // rank 8 of 16-wide bricks of prisms
  const fs::path back = dir_->path() / "global_back.nrrd";
  ASSERT_EQ(run_command(strata_cmd("decompress " + q(global) + " -o " + q(back) + " --rank 4"), &out), 0) << out;
  EXPECT_EQ(strata::io::read_volume(back).dims(), (strata::Extent{40, 36, 30}));
  ASSERT_EQ(run_command(strata_cmd("render " + q(global) + " --size 48x40 -o " + q(dir_->path() / "global.png")), &out), 0)
      << out;
  EXPECT_FALSE(has(out, " 0 bricks in the cut")) << out;
  // Alg. 2: an error target picks ranks and levels from the feature-scale table.
  ASSERT_EQ(run_command(strata_cmd("render " + q(global) + " --size 48x40 --feature-scale 0.05 -o " +
                                   q(dir_->path() / "global_fs.png")),
                        &out),
            0)
      << out;
  EXPECT_TRUE(has(out, "feature scale 0.05: bricks per level L")) << out;
  EXPECT_TRUE(has(out, "; per rank K")) << out;
  EXPECT_EQ(run_command(strata_cmd("render " + q(compressed()) + " --size 48x40 --feature-scale 0.05 -o " +
                                   q(dir_->path() / "bricked_fs.png")),
                        &out),
            2)
      << out;
  EXPECT_TRUE(has(out, "--feature-scale: ") && has(out, "ta-global")) << out;
  EXPECT_EQ(run_command(strata_cmd("render " + q(global) + " --feature-scale 2 -o " + q(dir_->path() / "x.png")), &out), 2)
      << out;
  // Error targets belong to the default codec.
  EXPECT_EQ(run_command(strata_cmd("compress " + q(original()) + " -o " + q(dir_->path() / "x.strata") +
                                   " --codec ta-global --psnr 40"),
                        &out),
            2);
  EXPECT_TRUE(has(out, "--codec")) << out;
}

// Out of core (paper 2 on volumes larger than memory): a volume 2.4 times the memory limit
// compresses with ta-global while the process's peak resident set stays under the limit, which
// includes the compressor's 64 MiB allowance for code, the libraries and per-thread scratch. A tall volume
// keeps the slices, which the level pipelines hold a brick row of, small beside the whole.
TEST_F(CliTa, GlobalCodecStaysUnderTheMemoryLimit) {
  const fs::path tall = dir_->path() / "tall.raw";
  std::string out;
  ASSERT_EQ(run_command(strata_cmd("generate prisms --size 128,128,12288 --dtype u8 -o " + q(tall)), &out), 0) << out;
  ASSERT_EQ(fs::file_size(tall), 192ull << 20);
  const std::uint64_t limit = 80ull << 20;
  const PeakRun run = run_measuring_peak({"--threads", "2", "compress", tall.string(), "-o",
                                          (dir_->path() / "tall.strata").string(), "--codec", "ta-global",
                                          "--memory-limit", "80M"});
  ASSERT_EQ(run.exit_code, 0);
  EXPECT_LT(run.peak_rss_bytes, limit) << "peak RSS " << (run.peak_rss_bytes >> 20) << " MiB";
  EXPECT_GT(run.peak_rss_bytes, 8ull << 20) << "the measurement saw the compressor";
  ASSERT_EQ(run_command(strata_cmd("info " + q(dir_->path() / "tall.strata")), &out), 0) << out;
  EXPECT_TRUE(has(out, "source:      [128,128,12288] u8")) << out;
}
