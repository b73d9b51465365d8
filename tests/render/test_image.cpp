// PNG output round-trips and never leaves partial files.
#include <gtest/gtest.h>

#include <fstream>
#include <random>

#include "strata/core/error.hpp"
#include "strata/render/image.hpp"
#include "support/test_support.hpp"

using namespace strata;
using namespace strata::render;

TEST(Image, PngRoundTripKeepsEveryPixelAndAlpha) {
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

TEST(Image, FillAndRowAccess) {
  Image img(4, 3, {1, 2, 3, 4});
  EXPECT_EQ(img.at(3, 2), (Rgba8{1, 2, 3, 4}));
  img.row(1)[2] = {9, 9, 9, 9};
  EXPECT_EQ(img.at(2, 1), (Rgba8{9, 9, 9, 9}));
}

TEST(Image, WriteErrorsNameTheFile) {
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

TEST(Image, ReadErrorsNameTheFile) {
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
