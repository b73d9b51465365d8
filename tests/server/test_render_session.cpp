// RenderSession as the server uses it, on a file with many small bricks: slices that span
// several acquire batches read the same values as the codec's box decoding, and values at voxels
// agree with slices.
#include <gtest/gtest.h>

#include <cmath>

#include "strata/gen/generators.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/mixture/encoded_labels.hpp"
#include "strata/render/transfer_function.hpp"
#include "strata/quant/scheme.hpp"
#include "strata/render/render_session.hpp"
#include "strata/ta/compress.hpp"
#include "strata/ta/ta_volume.hpp"
#include "support/label_volumes.hpp"
#include "support/test_support.hpp"

namespace strata::render {
namespace {

// 64 x 60 x 20 prisms in 8-wide bricks (core 4): a z slice meets 16 x 15 = 240 bricks.
class ServerRenderSession : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir;
    gen::Params p;
    p.kind = gen::Kind::prisms;
    p.dims = {64, 60, 20};
    p.seed = 9;
    io::write_volume(*dir_ / "small.nrrd", gen::generate(p));
    ta::CompressParams params;
    params.layout = {8, 2};
    params.codec.rank = 4;
    params.codec.quant = quant::QuantScheme::parse("u16,b8log+");
    auto source = io::open_volume(*dir_ / "small.nrrd");
    ta::compress_volume(*source, *dir_ / "small.strata", params, silent_progress());
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static std::filesystem::path file() { return *dir_ / "small.strata"; }
  static test::TempDir* dir_;
};

test::TempDir* ServerRenderSession::dir_ = nullptr;

TEST_F(ServerRenderSession, SlicesOverManyBricksMatchBoxDecoding) {
  SessionOptions options;
  options.cache_bytes = 2u << 20;  // far less than the slice's bricks: they cannot all stay cached
  RenderSession session(file(), options);
  const ta::TaVolume volume(file());
  for (int rank : {4, 2}) {
    const Slice<float> slice = session.value_slice({SliceAxis::z, 11, 0, rank});
    ASSERT_EQ(slice.width, 64);
    ASSERT_EQ(slice.height, 60);
    const Volume expected = volume.decode_box(0, {{0, 0, 11}, {64, 60, 12}}, rank);
    double worst = 0;
    for (std::int64_t y = 0; y < 60; ++y)
      for (std::int64_t x = 0; x < 64; ++x)
        worst = std::max(worst, std::abs(double(slice.values[std::size_t(y * 64 + x)]) - expected.value(x, y, 0)));
    EXPECT_LT(worst, 0.05) << "rank " << rank;
    EXPECT_NEAR(session.value_at({37, 41, 11}, rank), slice.values[41 * 64 + 37], 1e-6);
  }
}

TEST_F(ServerRenderSession, FrameSettingsChangePerCall) {
  RenderSession session(file());
  FrameSettings settings;
  settings.camera.width = 48;
  settings.camera.height = 36;
  nlohmann::json stats;
  const Image full = session.frame(settings, stats);
  EXPECT_EQ(stats["rank"], 4);
  settings.rank = 1;
  const Image coarse = session.frame(settings, stats);
  EXPECT_EQ(stats["rank"], 1);
  EXPECT_EQ(stats["load"]["bytes_read"], 0) << "rank 1 comes from the cached models";
  EXPECT_NE(full.pixels(), coarse.pixels());
  settings.tf = std::make_shared<const TransferFunction>(TransferFunction::preset("fire"));
  EXPECT_NE(session.frame(settings, stats).pixels(), coarse.pixels()) << "a new TF, a new ray caster";
  settings.tf = std::make_shared<const TransferFunction>(TransferFunction::from_points_text("0:1:1:1:0;1:1:1:1:0"));
  const Image clear = session.frame(settings, stats);
  for (const Rgba8& p : clear.pixels()) ASSERT_EQ(p, (Rgba8{0, 0, 0, 255})) << "a transparent TF shows the background";
}

}  // namespace
}  // namespace strata::render

namespace strata::render {
namespace {

// A 48³ f32 volume, zero but for a ball of radius 6 at the centre: the default camera frames
// the ball (plus the voxels it touches), not the volume's bounding sphere, in plain, TA and
// label files alike, and says so in describe() for the viewer's own framing.
Volume centred_ball() { return test::label_ball(48, 6, 24, 200); }

std::uint64_t lit_pixels(const Image& image) {
  std::uint64_t n = 0;
  for (int y = 0; y < image.height(); ++y)
    for (int x = 0; x < image.width(); ++x) n += image.at(x, y).r + image.at(x, y).g + image.at(x, y).b > 30;
  return n;
}

TEST(RenderSessionFraming, TheDefaultCameraFramesTheContent) {
  test::TempDir dir;
  const Volume ball = centred_ball();
  io::write_volume(dir / "ball.nrrd", ball);
  ta::CompressParams params;
  params.layout = {16, 2};
  params.codec.rank = 8;
  auto source = io::open_volume(dir / "ball.nrrd");
  ta::compress_volume(*source, dir / "ball.strata", params, silent_progress());
  mixture::EncodeOptions o;
  o.measure_error = false;
  mixture::encode_labels(ball, dir / "labels.strata", o);
  const double volume_radius = 0.5 * std::sqrt(3.0) * 48;
  FrameSettings settings;
  settings.camera.width = settings.camera.height = 96;
  settings.tf = std::make_shared<const TransferFunction>(TransferFunction::preset("grayscale"));
  for (const char* name : {"ball.nrrd", "ball.strata", "labels.strata"}) {
    RenderSession session(dir / name);
    const double radius = session.describe()["frame_radius"].get<double>();
    // The ball's voxels reach 6 voxels (and one voxel's corner) from the centre; TA bricks of 12
    // core voxels round that out to the bricks it touches, 24 from the centre at most.
    EXPECT_GT(radius, 6.0) << name;
    EXPECT_LT(radius, std::string(name) == "ball.strata" ? 0.6 * volume_radius : 0.35 * volume_radius) << name;
    nlohmann::json stats;
    if (std::string(name) == "labels.strata") settings.tf = nullptr;
    const std::uint64_t framed = lit_pixels(session.frame(settings, stats));
    FrameSettings whole = settings;
    whole.camera.frame_radius = volume_radius;  // the old framing: the whole bounding sphere
    const std::uint64_t small = lit_pixels(session.frame(whole, stats));
    EXPECT_GT(framed, 2 * small) << name << ": the framed ball should cover several times the pixels";
  }
}

}  // namespace
}  // namespace strata::render
