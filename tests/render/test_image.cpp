// PNG output round-trips and never leaves partial files.
#include <gtest/gtest.h>

#include <fstream>
#include <random>

#include "strata/core/error.hpp"
#include "strata/render/image.hpp"
#include "support/test_support.hpp"

using namespace strata;
using namespace strata::render;

TEST(RenderImage, PngRoundTripKeepsEveryPixelAndAlpha) {
  test::TempDir dir;
  Image img(37, 21);
  std::mt19937 rng(5);
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x)
      img.at(x, y) = {std::uint8_t(rng()), std::uint8_t(rng()), std::uint8_t(rng()), std::uint8_t(rng())};
  const auto path = dir / "out.png";
  write_png(img, path);
  EXPECT_FALSE(std::filesystem::exists(dir / "out.png.tmp"));
  const Image back = read_png(path);
  ASSERT_EQ(back.width(), 37);
  ASSERT_EQ(back.height(), 21);
  EXPECT_EQ(back.pixels(), img.pixels());
}

TEST(RenderImage, FillAndRowAccess) {
  Image img(4, 3, {1, 2, 3, 4});
  EXPECT_EQ(img.at(3, 2), (Rgba8{1, 2, 3, 4}));
  img.row(1)[2] = {9, 9, 9, 9};
  EXPECT_EQ(img.at(2, 1), (Rgba8{9, 9, 9, 9}));
}

TEST(RenderImage, WriteErrorsNameTheFile) {
  test::TempDir dir;
  const auto path = dir / "missing-dir" / "x.png";
  try {
    write_png(Image(2, 2), path);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("x.png"), std::string::npos) << e.what();
  }
  EXPECT_THROW(write_png(Image(), dir / "empty.png"), Error);
}

TEST(RenderImage, ReadErrorsNameTheFile) {
  test::TempDir dir;
  const auto path = dir / "bad.png";
  std::ofstream(path) << "not a png";
  try {
    read_png(path);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.png"), std::string::npos) << e.what();
  }
}

// Doubling a 2x1 image: pixel centres at 0.25/0.75 of the source span map to source x -0.25
// (clamped to 0), 0.25, 0.75 and 1.25 (clamped to 1), so the middle pixels mix 3:1 and 1:3.
TEST(RenderImage, BilinearResizeInterpolatesBetweenPixelCentres) {
  Image src(2, 1);
  src.at(0, 0) = {0, 100, 200, 255};
  src.at(1, 0) = {200, 100, 0, 255};
  const Image out = resize_bilinear(src, 4, 2);
  ASSERT_EQ(out.width(), 4);
  ASSERT_EQ(out.height(), 2);
  for (int y = 0; y < 2; ++y) {
    EXPECT_EQ(out.at(0, y), (Rgba8{0, 100, 200, 255}));
    EXPECT_EQ(out.at(1, y), (Rgba8{50, 100, 150, 255}));
    EXPECT_EQ(out.at(2, y), (Rgba8{150, 100, 50, 255}));
    EXPECT_EQ(out.at(3, y), (Rgba8{200, 100, 0, 255}));
  }
  EXPECT_EQ(resize_bilinear(out, 4, 2).pixels(), out.pixels()) << "same size is the identity";
  EXPECT_THROW(resize_bilinear(src, 0, 2), Error);
}
