// Careless or hostile arguments: every case here crashed, hung, destroyed its input or printed raw
// library text before. The program must refuse each one with `error: <flag>: ...` and the exit
// code of a usage error (2) or a runtime error (1), leave no output behind and keep its inputs.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli/cli_test_util.hpp"
#include "store/forge.hpp"
#include "strata/store/zstd_frame.hpp"
#include "support/test_support.hpp"

using strata::test::run_command;
using strata::test::strata_cmd;
using strata::test::shell_quoted;
using strata::test::TempDir;

namespace {

namespace fs = std::filesystem;


bool has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

std::uintmax_t size_of(const fs::path& p) { return fs::file_size(p); }

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

// Small inputs made once: a scalar NRRD and its .strata, a label NRRD and its encoding.
class HostileCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new TempDir();
    std::string out;
    ASSERT_EQ(run_command(strata_cmd("generate prisms --size 24 -o " + q("p.nrrd")), &out), 0) << out;
    ASSERT_EQ(run_command(strata_cmd("compress " + q("p.nrrd") + " --brick 16 -o " + q("p.strata")), &out), 0) << out;
    ASSERT_EQ(run_command(strata_cmd("generate voronoi --size 16 --count 8 -o " + q("v.nrrd")), &out), 0) << out;
    ASSERT_EQ(run_command(strata_cmd("labels encode " + q("v.nrrd") + " -o " + q("v.strata")), &out), 0) << out;
    ASSERT_EQ(run_command(strata_cmd("generate sphere --size 8 -o " + q("f.nrrd")), &out), 0) << out;
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static fs::path file(const std::string& name) { return dir_->path() / name; }
  static std::string q(const std::string& name) { return shell_quoted(file(name)); }

  // Runs `args`, expects exit `code` and `error: <flag>` in the output; returns the output.
  static std::string refused(const std::string& args, int code, const std::string& flag) {
    std::string out;
    EXPECT_EQ(run_command(strata_cmd(args), &out), code) << args << "\n" << out;
    EXPECT_TRUE(has(out, "error: " + flag)) << args << "\n" << out;
    return out;
  }
  // Runs `args`, expects exit `code`; returns the output.
  static std::string run(const std::string& args, int code) {
    std::string out;
    EXPECT_EQ(run_command(strata_cmd(args), &out), code) << args << "\n" << out;
    return out;
  }

  static TempDir* dir_;
};

TempDir* HostileCli::dir_ = nullptr;

TEST_F(HostileCli, RenderRefusesNonFiniteAndOutOfRangeCameraValues) {
  const std::string png = " -o " + q("r.png") + " --size 32x32 ";
  for (const std::string input : {"p.strata", "p.nrrd", "v.strata"}) {
    for (const std::string value : {"inf", "nan", "-inf", "1e300"})
      refused("render " + q(input) + png + "--azimuth " + value, 2, "--azimuth: ");
    for (const std::string value : {"inf", "nan", "91", "-1e9"})
      refused("render " + q(input) + png + "--elevation " + value, 2, "--elevation: ");
    for (const std::string value : {"inf", "nan", "-1"}) refused("render " + q(input) + png + "--distance " + value, 2, "--distance: ");
    for (const std::string value : {"0", "180", "nan", "inf"}) refused("render " + q(input) + png + "--fov " + value, 2, "--fov: ");
    for (const std::string value : {"0", "inf", "nan", "-1"}) refused("render " + q(input) + png + "--lod " + value, 2, "--lod: ");
    refused("render " + q(input) + png + "--lod-bias nan", 2, "--lod-bias: ");
    refused("render " + q(input) + png + "--lod-bias 1e300", 2, "--lod-bias: ");
    refused("render " + q(input) + png + "--rank -3", 2, "--rank: ");
    refused("render " + q(input) + png + "--target-fps inf", 2, "--target-fps: ");
    refused("render " + q(input) + png + "--max-bricks 0", 2, "--max-bricks: ");
    refused("render " + q(input) + " -o " + q("r.png") + " --size 0x5", 2, "--size: ");
    refused("render " + q(input) + " -o " + q("r.png") + " --size 99999999999x5", 2, "--size: ");
    refused("render " + q(input) + " -o " + q("r.png") + " --size 5x5junk", 2, "--size: ");
  }
  EXPECT_FALSE(fs::exists(file("r.png")));
}

TEST_F(HostileCli, RenderBoundsSamplesPerRayAndFrames) {
  const std::string png = " -o " + q("r.png") + " --size 32x32 ";
  for (const std::string input : {"p.strata", "p.nrrd", "v.strata"}) {
    const std::string out = refused("render " + q(input) + png + "--step 1e-9", 2, "--step: ");
    EXPECT_TRUE(has(out, "0.05")) << out;  // the allowed range
    refused("render " + q(input) + png + "--step inf", 2, "--step: ");
    refused("render " + q(input) + png + "--step 0", 2, "--step: ");
  }
  std::string out = refused("render " + q("p.strata") + " -o " + q("frames") + " --size 16x16 --orbit 100000", 2, "--orbit: ");
  EXPECT_TRUE(has(out, "3600")) << out;
  refused("render " + q("p.strata") + " -o " + q("frames") + " --size 16x16 --orbit -1", 2, "--orbit: ");
  EXPECT_FALSE(fs::exists(file("frames")));
  refused("render " + q("p.strata") + png + "--cache inf", 2, "--cache: ");
  for (const std::string passes : {"0", "257", "-1", "nan", "1e9"})
    refused("render " + q("p.strata") + png + "--passes " + passes, 2, "--passes: ");
  refused("render " + q("p.strata") + png + "--jitter maybe", 2, "--jitter: ");
  refused("render " + q("p.strata") + png + "--cache 1", 1, "--cache: ");
}

TEST_F(HostileCli, ThreadCountIsCapped) {
  const int cap = 4 * std::max(1, int(std::thread::hardware_concurrency()));
  for (const std::string& n : {std::string("100000"), std::to_string(cap + 1)})
    refused("--threads " + n + " info " + q("p.nrrd"), 2, "--threads: ");
  refused("--threads 400000 compress " + q("p.nrrd") + " -o " + q("t.strata"), 2, "--threads: ");
  EXPECT_FALSE(fs::exists(file("t.strata")));
  // A negative count is not wrapped into a huge one.
  const std::string out_negative = refused("--threads -1 info " + q("p.nrrd"), 2, "--threads: ");
  EXPECT_TRUE(has(out_negative, "non-negative integer")) << out_negative;
  // The cap itself is accepted.
  std::string out;
  EXPECT_EQ(run_command(strata_cmd("--threads " + std::to_string(cap) + " info " + q("f.nrrd")), &out), 0) << out;
}

TEST_F(HostileCli, OutputEqualToAnInputIsRefusedAndTheInputKept) {
  const auto p_nrrd = size_of(file("p.nrrd")), p_strata = size_of(file("p.strata")), v_nrrd = size_of(file("v.nrrd"));
  refused("compress " + q("p.nrrd") + " -o " + q("p.nrrd"), 2, "--output: ");
  refused("labels encode " + q("v.nrrd") + " -o " + q("v.nrrd"), 2, "--output: ");
  refused("render " + q("p.strata") + " -o " + q("p.strata") + " --size 16x16", 2, "--output: ");
  refused("decompress " + q("p.strata") + " -o " + q("p.strata"), 2, "--output: ");
  refused("convert " + q("p.nrrd") + " " + q("p.nrrd"), 2, "output: ");
  refused("labels decode " + q("v.strata") + " -o " + q("v.strata"), 2, "--output: ");
  // Another spelling, a symlink and a hard link of the input are the same file.
  fs::create_directories(file("sub"));
  refused("compress " + q("p.nrrd") + " -o " + shell_quoted(file("sub") / ".." / "p.nrrd"), 2, "--output: ");
  fs::create_symlink(file("p.nrrd"), file("link.nrrd"));
  refused("convert " + q("p.nrrd") + " " + q("link.nrrd"), 2, "output: ");
  fs::create_hard_link(file("p.nrrd"), file("hard.nrrd"));
  refused("convert " + q("hard.nrrd") + " " + q("p.nrrd"), 2, "output: ");
  refused("render " + q("p.strata") + " -o " + q("r.png") + " --size 16x16 --stats " + q("p.strata"), 2, "--stats: ");
  refused("render " + q("p.strata") + " -o " + q("r.json") + " --size 16x16 --stats " + q("r.json"), 2, "--output: ");
  EXPECT_EQ(size_of(file("p.nrrd")), p_nrrd);
  EXPECT_EQ(size_of(file("p.strata")), p_strata);
  EXPECT_EQ(size_of(file("v.nrrd")), v_nrrd);
}

TEST_F(HostileCli, OutputExtensionsMatchWhatTheCommandWrites) {
  refused("compress " + q("p.nrrd") + " -o " + q("out.nrrd"), 2, "--output: ");
  refused("labels encode " + q("v.nrrd") + " -o " + q("out.nrrd"), 2, "--output: ");
  refused("render " + q("p.strata") + " -o " + q("out.jpg") + " --size 16x16", 2, "--output: ");
  refused("render " + q("p.strata") + " -o " + q("r.png") + " --size 16x16 --stats " + q("s.txt"), 2, "--stats: ");
  refused("decompress " + q("p.strata") + " -o " + q("out.strata"), 2, "--output: ");
  refused("generate sphere --size 8 -o " + q("out.strata"), 2, "--output: ");
  refused("generate sphere --size 8 --dtype i8 -o " + q("out.nii"), 2, "--output: ");
  for (const char* name : {"out.nrrd", "out.jpg", "out.strata", "out.nii"}) EXPECT_FALSE(fs::exists(file(name))) << name;
}

TEST_F(HostileCli, FailedRenderLeavesNoOutput) {
  std::string out;
  EXPECT_EQ(run_command(strata_cmd("render " + q("p.strata") + " -o " + q("r.png") +
                                   " --size 16x16 --stats /nonexistent-strata-dir/s.json"),
                        &out),
            1)
      << out;
  EXPECT_TRUE(has(out, "error: --stats: ")) << out;
  EXPECT_FALSE(fs::exists(file("r.png")));
  EXPECT_EQ(run_command(strata_cmd("render " + q("p.strata") + " -o " + q("orbit") +
                                   " --size 16x16 --orbit 2 --stats /nonexistent-strata-dir/s.json"),
                        &out),
            1)
      << out;
  EXPECT_FALSE(fs::exists(file("orbit")));
  // The orbit folder is an existing file.
  refused("render " + q("p.strata") + " -o " + q("p.nrrd") + " --size 16x16 --orbit 2", 2, "--output: ");
}

TEST_F(HostileCli, GeneratorsRefuseWhatCannotStreamInBoundedMemory) {
  std::string out = refused("generate voronoi --size 16 --count 100000000 -o " + q("g.nrrd"), 2, "--count: ");
  EXPECT_TRUE(has(out, "4096 voxels")) << out;
  refused("generate prisms --size 1000000 -o " + q("g.nrrd"), 2, "--size: ");
  refused("generate prisms --size 4294967296,4294967296,4294967296 -o " + q("g.nrrd"), 2, "--size: ");
  refused("generate prisms --size 4294967296,2,2 -o " + q("g.nrrd"), 2, "--size: ");
  refused("generate sphere --size 100000,100000,1 -o " + q("g.nrrd"), 2, "--size: ");
  refused("generate fibres --size 16 --count 5000 -o " + q("g.nrrd"), 2, "--count: ");
  refused("generate superpixels --size 16 --count 1000 -o " + q("g.nrrd"), 2, "--count: ");
  // Negative seeds and counts are refused, not wrapped into huge unsigned values.
  out = refused("generate sphere --size 8 --seed -1 -o " + q("g.nrrd"), 2, "--seed: ");
  EXPECT_TRUE(has(out, "non-negative integer, got '-1'")) << out;
  refused("generate voronoi --size 8 --count -5 -o " + q("g.nrrd"), 2, "--count: ");
  refused("labels calibrate " + q("v.strata") + " --seed -1", 2, "--seed: ");
  refused("labels calibrate " + q("v.strata") + " --boxes 1000000", 2, "--boxes: ");
  EXPECT_FALSE(fs::exists(file("g.nrrd")));
  // A deep volume of small slices still streams (memory does not grow with the depth).
  EXPECT_EQ(run_command(strata_cmd("generate sphere --size 8,8,8192 -o " + q("deep.raw")), &out), 0) << out;
  EXPECT_EQ(size_of(file("deep.raw")), 8u * 8u * 8192u * 4u);
}

TEST_F(HostileCli, LibraryTextIsExplained) {
  // A float volume is no label volume: the message names the file.
  const std::string out = refused("labels encode " + q("f.nrrd") + " -o " + q("f.strata"), 1, "");
  EXPECT_TRUE(has(out, "f.nrrd")) << out;
  EXPECT_TRUE(has(out, "integer")) << out;
  EXPECT_FALSE(fs::exists(file("f.strata")));
  refused("compress " + q("p.nrrd") + " -o " + q("t.strata") + " --rmse 1e-300", 2, "--rmse: ");
  refused("compress " + q("p.nrrd") + " -o " + q("t.strata") + " --coarse-growth nan", 2, "--coarse-growth: ");
  refused("compress " + q("p.nrrd") + " -o " + q("t.strata") + " --memory-limit 1e30G", 2, "--memory-limit: ");
  refused("compress " + q("p.nrrd") + " -o " + q("t.strata") + " --hooi 100000", 2, "--hooi: ");
  // The library's one parameter check, reported against the flag that set the value.
  refused("compress " + q("p.nrrd") + " -o " + q("t.strata") + " --zstd 20", 2, "--zstd: ");
  refused("compress " + q("p.nrrd") + " -o " + q("t.strata") + " --codec zfp", 2, "--codec: unknown codec");
  refused("compress " + q("p.nrrd") + " -o " + q("t.strata") + " --psnr 40 --hooi 2", 2, "--hooi: ");
  refused("labels encode " + q("p.nrrd") + " -o " + q("t.strata") + " --bits 17", 2, "--bits: ");
  refused("labels encode " + q("p.nrrd") + " -o " + q("t.strata") + " --zstd 23", 2, "--zstd: ");
  EXPECT_FALSE(fs::exists(file("t.strata")));
}

// `compress --help` lists the codecs of the registry with what each stores.
TEST_F(HostileCli, CompressHelpListsTheRegisteredCodecs) {
  std::string out;
  ASSERT_EQ(run_command(strata_cmd("compress --help"), &out), 0) << out;
  EXPECT_TRUE(has(out, "ta-bricked:")) << out;
  EXPECT_TRUE(has(out, "ta-global:")) << out;
  EXPECT_TRUE(has(out, "error-target")) << out;
}

// `labels query --top -1` wrapped to 2^64-1 and listed every label.
TEST_F(HostileCli, LabelsQueryRefusesANegativeTop) {
  const std::string out = run("labels query " + q("v.strata") + " --top -1", 2);
  EXPECT_TRUE(has(out, "error: --top: expected a non-negative integer, got '-1'")) << out;
  const std::string two = run("labels query " + q("v.strata") + " --top 2 --json", 0);
  EXPECT_EQ(nlohmann::json::parse(two)["labels"].size(), 2u) << two;
}

// A seed of 2^64 or more was saturated to 2^64-1 without a word; "010" was read as octal 8.
TEST_F(HostileCli, SeedsBeyond64BitsAreRefusedAndDecimalIsDecimal) {
  for (const std::string seed : {"18446744073709551616", "99999999999999999999999"}) {
    std::string out = run("generate sphere --size 8 --seed " + seed + " -o " + q("s.nrrd"), 2);
    EXPECT_TRUE(has(out, "error: --seed: expected an integer in [0, 2^64-1], got '" + seed + "'")) << out;
    out = run("labels calibrate " + q("v.strata") + " --boxes 1 --seed " + seed, 2);
    EXPECT_TRUE(has(out, "error: --seed: expected an integer in [0, 2^64-1]")) << out;
  }
  EXPECT_FALSE(fs::exists(file("s.nrrd")));
  run("generate prisms --size 12 --seed 18446744073709551615 -o " + q("max.nrrd"), 0);
  // --seed 010 is ten, as --seed 10.
  run("generate prisms --size 12 --seed 010 -o " + q("s010.nrrd"), 0);
  run("generate prisms --size 12 --seed 10 -o " + q("s10.nrrd"), 0);
  EXPECT_EQ(strata::test::forge::file_bytes(file("s010.nrrd")), strata::test::forge::file_bytes(file("s10.nrrd")));
  // The other integer flags keep their types' ranges too.
  std::string out = run("generate voronoi --size 8 --count 9223372036854775808 -o " + q("s.nrrd"), 2);
  EXPECT_TRUE(has(out, "error: --count: expected an integer in [0, 2^63-1]")) << out;
  out = run("--threads 2147483648 info " + q("p.nrrd"), 2);
  EXPECT_TRUE(has(out, "error: --threads: expected an integer in [0, 2147483647]")) << out;
}

// decompress refused --rank 99 while render and eval clamped it to the stored rank: all three now
// use the library's one rule, with the same message.
TEST_F(HostileCli, RankAboveTheStoredRankIsRefusedByEveryCommand) {
  const std::string expected = "error: --rank: expected 1..8 (the stored rank of ";
  const std::vector<std::string> commands{"decompress " + q("p.strata") + " -o " + q("rank.nrrd"),
                                          "eval " + q("p.nrrd") + " " + q("p.strata"),
                                          "render " + q("p.strata") + " -o " + q("rank.png") + " --size 16x16"};
  for (const std::string& command : commands) {
    const std::string out = run(command + " --rank 99", 1);
    EXPECT_TRUE(has(out, expected)) << command << "\n" << out;
    EXPECT_TRUE(has(out, "p.strata) or 0 for the stored rank, got 99")) << command << "\n" << out;
    // A negative rank is a usage error everywhere.
    EXPECT_TRUE(has(run(command + " --rank -2", 2), "error: --rank: ")) << command;
    run(command + " --rank 8", 0);
  }
  // A label file stores no rank: render refuses one rather than ignoring it.
  const std::string out = run("render " + q("v.strata") + " -o " + q("rank-labels.png") + " --size 16x16 --rank 3", 1);
  EXPECT_TRUE(has(out, "error: --rank: ")) << out;
  EXPECT_TRUE(has(out, "stores no Tucker rank")) << out;
  EXPECT_FALSE(fs::exists(file("rank-labels.png")));
}

// The JSON library's text ("parse error at line 1, column 3: syntax error while parsing value -
// invalid literal; last read: '<bytes of the file>'") is replaced by the file, the field, the
// position and what was expected; no byte of the input is echoed.
TEST_F(HostileCli, JsonErrorsAreInStrataWordsAndEchoNoInputBytes) {
  const std::string secret = "SECRETBYTES";
  const auto expect_strata_words = [&](const std::string& out, const std::string& file_name) {
    EXPECT_TRUE(has(out, file_name)) << out;
    EXPECT_TRUE(has(out, "invalid JSON")) << out;
    EXPECT_TRUE(has(out, "expected")) << out;
    for (const char* library : {"parse error", "syntax error while parsing", "last read", "json.exception",
                                "number overflow parsing", secret.c_str()})
      EXPECT_FALSE(has(out, library)) << library << "\n" << out;
  };
  // A raw file's sidecar.
  write_text(file("s.raw"), std::string(8, 'x'));
  write_text(file("s.raw.json"), "{\"dims\": [2, 2, 2], \"dtype\": " + secret + "}");
  std::string out = run("info " + q("s.raw"), 1);
  expect_strata_words(out, "s.raw.json");
  EXPECT_TRUE(has(out, "line 1, column")) << out;
  // A number beyond a double's range: the library quoted the token.
  write_text(file("s.raw.json"), "{\"dims\": [2, 2, 2], \"dtype\": \"u8\", \"spacing\": [1e999" + secret + "]}");
  out = run("info " + q("s.raw"), 1);
  expect_strata_words(out, "s.raw.json");
  // A transfer function and a colour map.
  write_text(file("tf.json"), "{\"points\": [" + secret + "]}");
  expect_strata_words(run("render " + q("p.strata") + " -o " + q("t.png") + " --size 8x8 --tf " + q("tf.json"), 1),
                      "tf.json");
  write_text(file("colors.json"), "{\"3\": [1e999, 0, 0, 1]}");
  expect_strata_words(
      run("labels palette " + q("v.strata") + " --colors " + q("colors.json") + " -o " + q("pal.json"), 1),
      "colors.json");
  // A .strata file whose metadata is not JSON (checksums recomputed, as a forger would).
  fs::copy_file(file("p.strata"), file("m.strata"), fs::copy_options::overwrite_existing);
  strata::test::forge::replace_metadata_text(file("m.strata"), "{\"codec\": " + secret + "}");
  out = run("info " + q("m.strata"), 1);
  expect_strata_words(out, "m.strata");
  EXPECT_TRUE(has(out, "metadata")) << out;
}

// A damaged zstd chunk of a Zarr array: zstd's own "Data corruption detected" became
// "<file>: <chunk>: damaged zstd data: ...".
TEST_F(HostileCli, ZstdErrorsAreInStrataWords) {
  const fs::path zarr = file("z.zarr");
  fs::create_directories(zarr);
  write_text(zarr / ".zarray", R"({"zarr_format": 2, "shape": [16, 16, 16], "chunks": [16, 16, 16], "dtype": "<u2",
    "compressor": {"id": "zstd", "level": 3}, "fill_value": 0, "order": "C", "filters": null})");
  std::vector<std::uint16_t> samples(16 * 16 * 16);
  for (std::size_t i = 0; i < samples.size(); ++i) samples[i] = std::uint16_t((i * i) % 977 + (i / 7) % 13);
  std::vector<std::byte> frame = strata::store::zstd_compress(std::as_bytes(std::span(samples)), 3);
  ASSERT_GT(frame.size(), 64u);
  // The first block's type set to the reserved 3 (after a 7-byte frame header: single segment,
  // a 2-byte content size): zstd's "Data corruption detected".
  ASSERT_EQ(frame[4], std::byte(0x60));
  frame[7] |= std::byte(0x06);
  strata::test::forge::write_file(zarr / "0.0.0", frame);
  const std::string out = run("info " + shell_quoted(zarr), 1);
  EXPECT_TRUE(has(out, "z.zarr")) << out;
  EXPECT_TRUE(has(out, "damaged zstd data")) << out;
  for (const char* library : {"Data corruption detected", "Corrupted block detected", "Src size is incorrect",
                              "Destination buffer is too small", "Unknown frame descriptor"})
    EXPECT_FALSE(has(out, library)) << library << "\n" << out;
}

// CLI11's "File is actually a directory: <path>" and "File does not exist: <path>" for render's
// input became Strata's words.
TEST_F(HostileCli, RenderInputErrorsAreInStrataWords) {
  fs::create_directories(file("folder"));
  std::string out = run("render " + q("folder") + " -o " + q("f.png"), 2);
  EXPECT_TRUE(has(out, "error: input: '")) << out;
  EXPECT_TRUE(has(out, "folder' is a folder, expected a .strata file, a volume file or an http(s) URL")) << out;
  EXPECT_FALSE(has(out, "File is actually a directory")) << out;
  out = run("render " + q("missing.strata") + " -o " + q("f.png"), 2);
  EXPECT_TRUE(has(out, "missing.strata' does not exist, expected a .strata file")) << out;
  EXPECT_FALSE(has(out, "File does not exist")) << out;
}

}  // namespace
