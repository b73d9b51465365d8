// `strata render` end to end: TA files (stills, orbits, the rank slider, a transparent transfer
// function) and label files (colour maps), the statistics JSON and the errors users see.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "strata/render/image.hpp"
#include "support/test_support.hpp"

using strata::test::run_command;
using strata::test::TempDir;

namespace {

namespace fs = std::filesystem;

std::string strata_cmd(const std::string& args) { return std::string(STRATA_BINARY) + " --progress none " + args; }

nlohmann::json read_json(const fs::path& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

void write_text(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }

// Pixels that differ from the background colour (black, opaque).
std::size_t lit_pixels(const strata::render::Image& image) {
  std::size_t n = 0;
  for (const auto& p : image.pixels()) n += (p.r | p.g | p.b) != 0;
  return n;
}

class CliRender : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::string raw = (dir / "sphere.nrrd").string();
    std::string out;
    ASSERT_EQ(run_command(strata_cmd("generate sphere --size 40 -o " + raw), &out), 0) << out;
    ASSERT_EQ(run_command(strata_cmd("compress " + raw + " -o " + file.string()), &out), 0) << out;
  }
  TempDir dir;
  fs::path file = dir / "sphere.strata";
};

TEST_F(CliRender, DefaultTransferFunctionIsThePresetForTheData) {
  // No --tf: the preset the data suggests, as the viewer opens it. sphere.strata names no
  // modality and has no world space (grayscale); the same volume as a NIfTI file is MR's usual
  // container (mri).
  const std::string nifti = (dir / "sphere.nii.gz").string();
  std::string out;
  ASSERT_EQ(run_command(strata_cmd("convert " + (dir / "sphere.nrrd").string() + " " + nifti), &out), 0) << out;
  const auto render = [&](const std::string& input, const std::string& tf, const std::string& name) {
    const fs::path png = dir / name;
    EXPECT_EQ(run_command(strata_cmd("render " + input + " -o " + png.string() + " --size 48x36" + tf), &out), 0) << out;
    return strata::render::read_png(png).pixels();
  };
  EXPECT_EQ(render(file.string(), "", "a.png"), render(file.string(), " --tf grayscale", "b.png"));
  EXPECT_NE(render(file.string(), "", "a.png"), render(file.string(), " --tf ct", "c.png"));
  EXPECT_EQ(render(nifti, "", "d.png"), render(nifti, " --tf mri", "e.png"));
  EXPECT_EQ(render(nifti, " --tf auto", "f.png"), render(nifti, " --tf mri", "e.png"));
}

TEST_F(CliRender, StillImageAndStatistics) {
  const fs::path png = dir / "still.png", stats = dir / "stats.json";
  std::string out;
  ASSERT_EQ(run_command(strata_cmd("render " + file.string() + " -o " + png.string() + " --size 96x72 --tf grayscale" +
                                   " --stats " + stats.string()),
                        &out),
            0)
      << out;
  const auto image = strata::render::read_png(png);
  EXPECT_EQ(image.width(), 96);
  EXPECT_EQ(image.height(), 72);
  EXPECT_NE(image.at(48, 36), (strata::render::Rgba8{0, 0, 0, 255})) << "the sphere covers the centre";
  EXPECT_EQ(image.at(0, 0), (strata::render::Rgba8{0, 0, 0, 255})) << "corners show the background";
  const auto j = read_json(stats);
  ASSERT_EQ(j["frames"].size(), 1u);
  const auto& f = j["frames"][0];
  EXPECT_GT(f["selection"]["bricks"].get<int>(), 0);
  EXPECT_GT(f["load"]["bytes_read"].get<std::uint64_t>(), 0u);
  EXPECT_GT(f["render"]["samples"].get<std::uint64_t>(), 0u);
  EXPECT_EQ(j["summary"]["frames"], 1);
}

TEST_F(CliRender, OrbitWritesEveryFrame) {
  const fs::path frames = dir / "orbit", stats = dir / "orbit.json";
  std::string out;
  ASSERT_EQ(run_command(strata_cmd("render " + file.string() + " -o " + frames.string() +
                                   " --orbit 3 --size 48x40 --stats " + stats.string()),
                        &out),
            0)
      << out;
  for (const char* name : {"frame_0000.png", "frame_0001.png", "frame_0002.png"})
    EXPECT_TRUE(fs::exists(frames / name)) << name;
  const auto j = read_json(stats);
  EXPECT_EQ(j["summary"]["frames"], 3);
  EXPECT_DOUBLE_EQ(j["frames"][1]["azimuth"].get<double>(), 30.0 + 120.0);
  // Later frames find the first frame's bricks in the cache.
  EXPECT_GT(j["frames"][2]["load"]["cache_hits"].get<std::uint64_t>(), 0u);
}

TEST_F(CliRender, TargetFrameRateCastsFewerRaysAfterTheFirstFrame) {
  const fs::path frames = dir / "fast", stats = dir / "fast.json";
  std::string out;
  // A 100,000 frames/s budget cannot be met: the image grid coarsens after the first frame,
  // while every PNG keeps the requested size.
  ASSERT_EQ(run_command(strata_cmd("render " + file.string() + " -o " + frames.string() +
                                   " --orbit 3 --size 64x48 --target-fps 100000 --stats " + stats.string()),
                        &out),
            0)
      << out;
  const auto j = read_json(stats);
  EXPECT_EQ(j["frames"][0]["image_scale"], 1.0) << "the first frame is always full resolution";
  EXPECT_GT(j["frames"][2]["image_scale"].get<double>(), 1.0);
  EXPECT_LT(j["frames"][2]["render"]["rays"].get<std::uint64_t>(), j["frames"][0]["render"]["rays"].get<std::uint64_t>());
  const auto image = strata::render::read_png(frames / "frame_0002.png");
  EXPECT_EQ(image.width(), 64);
  EXPECT_EQ(image.height(), 48);
  EXPECT_EQ(j["summary"]["after_first"]["frames"], 2);
}

TEST_F(CliRender, RankSliderChangesTheImage) {
  const fs::path full = dir / "full.png", low = dir / "low.png";
  std::string out;
  const std::string common = " --size 64x48 --tf grayscale --shading off";
  ASSERT_EQ(run_command(strata_cmd("render " + file.string() + " -o " + full.string() + common), &out), 0) << out;
  ASSERT_EQ(run_command(strata_cmd("render " + file.string() + " -o " + low.string() + common + " --rank 1"), &out), 0)
      << out;
  EXPECT_NE(strata::render::read_png(full).pixels(), strata::render::read_png(low).pixels());
}

TEST_F(CliRender, TransparentTransferFunctionDecodesNothing) {
  const fs::path tf = dir / "clear.json", png = dir / "clear.png", stats = dir / "clear-stats.json";
  write_text(tf, R"({"points": [{"x": 0, "rgba": [1, 1, 1, 0]}, {"x": 1, "rgba": [1, 1, 1, 0]}]})");
  std::string out;
  ASSERT_EQ(run_command(strata_cmd("render " + file.string() + " -o " + png.string() + " --size 40x30 --tf " +
                                   tf.string() + " --stats " + stats.string()),
                        &out),
            0)
      << out;
  EXPECT_EQ(lit_pixels(strata::render::read_png(png)), 0u);
  const auto j = read_json(stats);
  const auto& f = j["frames"][0];
  EXPECT_EQ(f["selection"]["bricks"], 0);
  EXPECT_EQ(f["load"]["bytes_read"], 0);
  EXPECT_EQ(f["load"]["cache_misses"], 0);
}

// A file stored at full rank (rank = brick width) with f32 factors and cores reconstructs the
// input up to float rounding, so its image must match the plain file's (rendered as one block)
// within the 8-bit rounding of two renders plus float noise: 2/255 per channel.
TEST_F(CliRender, FullRankFileMatchesThePlainVolume) {
  const std::string raw = (dir / "sphere.nrrd").string(), exact = (dir / "full.strata").string();
  std::string out;
  ASSERT_EQ(run_command(strata_cmd("compress " + raw + " -o " + exact + " --brick 16 --rank 16 --quant f32"), &out), 0)
      << out;
  const std::string common = " --size 80x60 --tf ct --lod 0.01";
  const fs::path a = dir / "plain.png", b = dir / "full.png";
  ASSERT_EQ(run_command(strata_cmd("render " + raw + " -o " + a.string() + common), &out), 0) << out;
  ASSERT_EQ(run_command(strata_cmd("render " + exact + " -o " + b.string() + common), &out), 0) << out;
  const auto pa = strata::render::read_png(a), pb = strata::render::read_png(b);
  ASSERT_EQ(pa.pixels().size(), pb.pixels().size());
  int worst = 0;
  for (std::size_t i = 0; i < pa.pixels().size(); ++i) {
    const auto p = pa.pixels()[i], q = pb.pixels()[i];
    worst = std::max({worst, std::abs(p.r - q.r), std::abs(p.g - q.g), std::abs(p.b - q.b)});
  }
  EXPECT_LE(worst, 2);
  EXPECT_GT(lit_pixels(pa), 500u);
}

TEST_F(CliRender, BadArgumentsAreReported) {
  const fs::path tf = dir / "broken.json";
  write_text(tf, R"({"points": [{"x": 0.5, "rgba": [1, 1]}]})");
  std::string out;
  EXPECT_EQ(run_command(strata_cmd("render " + file.string() + " -o " + (dir / "x.png").string() + " --tf " +
                                   tf.string()),
                        &out),
            1);
  EXPECT_NE(out.find("broken.json"), std::string::npos) << out;
  EXPECT_NE(out.find("rgba"), std::string::npos) << out;
  EXPECT_EQ(run_command(strata_cmd("render " + file.string() + " -o " + (dir / "x.png").string() + " --size 10by10"),
                        &out),
            2);
  EXPECT_NE(out.find("--size"), std::string::npos) << out;
  EXPECT_EQ(run_command(strata_cmd("render " + file.string() + " -o " + (dir / "x.png").string() + " --tf nosuch"), &out),
            1);
  EXPECT_NE(out.find("error: --tf: \"nosuch\" is neither a preset"), std::string::npos) << out;
  EXPECT_EQ(run_command(strata_cmd("render " + (dir / "missing.strata").string() + " -o x.png"), &out), 2);
  EXPECT_FALSE(fs::exists(dir / "x.png"));
}

TEST(CliRenderLabels, ColourMapChangesTheImage) {
  TempDir dir;
  const std::string raw = (dir / "cells.nrrd").string(), enc = (dir / "cells.strata").string();
  std::string out;
  ASSERT_EQ(run_command(strata_cmd("generate voronoi --size 32 --count 6 -o " + raw), &out), 0) << out;
  ASSERT_EQ(run_command(strata_cmd("labels encode " + raw + " -o " + enc), &out), 0) << out;
  const fs::path hashed = dir / "hash.png", red = dir / "red.png", colours = dir / "red.json";
  write_text(colours, R"({"default": [1, 0, 0, 0.5]})");
  ASSERT_EQ(run_command(strata_cmd("render " + enc + " -o " + hashed.string() + " --size 48x40"), &out), 0) << out;
  ASSERT_EQ(run_command(strata_cmd("render " + enc + " -o " + red.string() + " --size 48x40 --colors " +
                                   colours.string() + " --shading off"),
                        &out),
            0)
      << out;
  const auto a = strata::render::read_png(hashed), b = strata::render::read_png(red);
  EXPECT_GT(lit_pixels(a), 100u);
  EXPECT_NE(a.pixels(), b.pixels());
  // Every label is red: no lit pixel of the recoloured image has green or blue.
  for (const auto& p : b.pixels()) EXPECT_EQ(p.g | p.b, 0);
}

}  // namespace
