#pragma once
/// @file
/// @brief An 8-bit RGBA image (row 0 at the top) and PNG output through libspng, written to a
/// temporary file and renamed, so a failed write never leaves a partial image.
#include <cstdint>
#include <filesystem>
#include <span>
#include <vector>

namespace strata::render {

/// @brief One pixel: straight (not premultiplied) 8-bit RGBA.
struct Rgba8 {
  std::uint8_t r = 0, g = 0, b = 0, a = 255;
  bool operator==(const Rgba8&) const = default;
};

/// @brief width x height pixels, row by row from the top; at(x, y) does not check bounds.
class Image {
 public:
  Image() = default;
  /// @brief Every pixel `fill`.
  Image(int width, int height, Rgba8 fill = {});

  int width() const { return width_; }
  int height() const { return height_; }
  Rgba8& at(int x, int y) { return pixels_[std::size_t(y) * std::size_t(width_) + std::size_t(x)]; }
  const Rgba8& at(int x, int y) const { return pixels_[std::size_t(y) * std::size_t(width_) + std::size_t(x)]; }
  const std::vector<Rgba8>& pixels() const { return pixels_; }
  std::vector<Rgba8>& pixels() { return pixels_; }
  Rgba8* row(int y) { return pixels_.data() + std::size_t(y) * std::size_t(width_); }

 private:
  int width_ = 0, height_ = 0;
  std::vector<Rgba8> pixels_;
};

/// @brief The per-channel mean of images of one size, kept in floats so that averaging many
/// rounds once: the image at rest, refined from jittered passes (RenderOptions::jitter_pass).
class ImageMean {
 public:
  /// @brief Adds `image`; throws Error when its size differs from the first one's.
  void add(const Image& image);
  int count() const { return count_; }
  /// @brief The mean, each channel rounded to the nearest level; throws Error before any add().
  Image mean() const;

 private:
  int width_ = 0, height_ = 0, count_ = 0;
  std::vector<float> sum_;  // 4 channels per pixel
};

/// @brief Bilinear resampling to width x height, pixel centres aligned (edges clamp): shows a
/// frame cast at a reduced image resolution (interactive image-space level of detail) at full size.
Image resize_bilinear(const Image& image, int width, int height);

/// @brief Writes `image` as a PNG file, atomically. Throws Error naming the file.
void write_png(const Image& image, const std::filesystem::path& path);
/// @brief The PNG file bytes of `image` (RGBA, 8 bits), encoded for speed over size (deflate level
/// 1, one filter): the images a viewer is served. Throws Error on an empty image.
std::vector<std::uint8_t> encode_png(const Image& image);
/// @brief The same for an 8-bit grey image (`grey` holds width x height samples, rows first): a
/// quarter of the bytes to filter and deflate. Throws Error if the sizes disagree.
std::vector<std::uint8_t> encode_grey_png(std::span<const std::uint8_t> grey, int width, int height);
/// @brief A baseline JPEG of `image`'s colour (alpha dropped), 4:2:0, quality 1..100 (libturbojpeg):
/// the small frames a viewer shows while the camera moves. Throws Error on an empty image.
std::vector<std::uint8_t> encode_jpeg(const Image& image, int quality = 80);
/// @brief Reads a PNG file as RGBA (for tests and comparisons). Throws Error naming the file.
Image read_png(const std::filesystem::path& path);

}  // namespace strata::render
