#include "strata/render/image.hpp"

#include <algorithm>
#include <cmath>

#include <spng.h>
#include <turbojpeg.h>

#include <cstdlib>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>

#include "strata/core/error.hpp"
#include "strata/io/files.hpp"

namespace strata::render {

namespace {

static_assert(sizeof(Rgba8) == 4, "Rgba8 must be tightly packed for PNG encoding");

struct SpngDeleter {
  void operator()(spng_ctx* ctx) const { spng_ctx_free(ctx); }
};
using SpngPtr = std::unique_ptr<spng_ctx, SpngDeleter>;

void check(int rc, const std::filesystem::path& path, const char* what) {
  if (rc != 0) throw Error(path.string() + ": " + what + ": " + spng_strerror(rc));
}

}  // namespace

Image::Image(int width, int height, Rgba8 fill) : width_(width), height_(height) {
  if (width < 0 || height < 0) throw Error("image: negative size");
  pixels_.assign(std::size_t(width) * std::size_t(height), fill);
}

namespace {

struct PngBufferDeleter {
  void operator()(void* p) const { std::free(p); }
};

// The pixels of an 8-bit PNG: RGBA (4 bytes per pixel) or grey (1).
struct PngPixels {
  const void* data;
  int width, height;
  bool grey;
};

// PNG bytes of `image` in a buffer libspng allocated; `what` names the destination in errors.
std::unique_ptr<void, PngBufferDeleter> png_buffer(const PngPixels& image, const std::filesystem::path& what,
                                                   std::size_t& length, bool fast = false) {
  if (image.width <= 0 || image.height <= 0) throw Error(what.string() + ": cannot write an empty image");
  SpngPtr ctx(spng_ctx_new(SPNG_CTX_ENCODER));
  if (!ctx) throw Error(what.string() + ": out of memory creating the PNG encoder");
  check(spng_set_option(ctx.get(), SPNG_ENCODE_TO_BUFFER, 1), what, "PNG encoder option");
  spng_ihdr ihdr{};
  ihdr.width = std::uint32_t(image.width);
  ihdr.height = std::uint32_t(image.height);
  ihdr.bit_depth = 8;
  ihdr.color_type = image.grey ? SPNG_COLOR_TYPE_GRAYSCALE : SPNG_COLOR_TYPE_TRUECOLOR_ALPHA;
  check(spng_set_ihdr(ctx.get(), &ihdr), what, "PNG header");
  if (fast) {
    // Served images are decoded once, next to the server: deflate's fastest level and one
    // filter (no per-row trial of all five) take a 301x370 slice from ~35 ms to a few ms.
    check(spng_set_option(ctx.get(), SPNG_IMG_COMPRESSION_LEVEL, 1), what, "PNG compression level");
    check(spng_set_option(ctx.get(), SPNG_FILTER_CHOICE, SPNG_FILTER_CHOICE_SUB), what, "PNG filter");
  }
  const std::size_t bytes = std::size_t(image.width) * std::size_t(image.height) * (image.grey ? 1 : sizeof(Rgba8));
  check(spng_encode_image(ctx.get(), image.data, bytes, SPNG_FMT_PNG, SPNG_ENCODE_FINALIZE), what,
        "PNG encoding");
  int error = 0;
  std::unique_ptr<void, PngBufferDeleter> buffer(spng_get_png_buffer(ctx.get(), &length, &error));
  check(error, what, "PNG buffer");
  if (!buffer) throw Error(what.string() + ": PNG encoder produced no data");
  return buffer;
}

// A served image: encoded for speed (see png_buffer), copied out of libspng's buffer.
std::vector<std::uint8_t> served_png(const PngPixels& image) {
  std::size_t length = 0;
  const auto buffer = png_buffer(image, "PNG image", length, true);
  const auto* bytes = static_cast<const std::uint8_t*>(buffer.get());
  return {bytes, bytes + length};
}

struct TjDeleter {
  void operator()(void* handle) const { tjDestroy(handle); }
};

}  // namespace

void write_png(const Image& image, const std::filesystem::path& path) {
  std::size_t length = 0;
  const auto buffer = png_buffer({image.pixels().data(), image.width(), image.height(), false}, path, length);
  // Encoded to memory, then written through AtomicOutputFile so a failure leaves no partial PNG.
  io::AtomicOutputFile out(path);
  out.write(buffer.get(), length);
  out.commit();
}

std::vector<std::uint8_t> encode_png(const Image& image) {
  return served_png({image.pixels().data(), image.width(), image.height(), false});
}

std::vector<std::uint8_t> encode_grey_png(std::span<const std::uint8_t> grey, int width, int height) {
  if (grey.size() != std::size_t(std::max(width, 0)) * std::size_t(std::max(height, 0)))
    throw Error("PNG image: " + std::to_string(grey.size()) + " grey samples for " + std::to_string(width) + "x" +
                std::to_string(height));
  return served_png({grey.data(), width, height, true});
}

std::vector<std::uint8_t> encode_jpeg(const Image& image, int quality) {
  if (image.width() <= 0 || image.height() <= 0) throw Error("JPEG image: cannot encode an empty image");
  if (quality < 1 || quality > 100) throw ParameterError("quality", "must lie in 1..100, got " + std::to_string(quality));
  std::unique_ptr<void, TjDeleter> tj(tjInitCompress());
  if (!tj) throw Error("JPEG image: cannot create the encoder");
  unsigned char* out = nullptr;
  unsigned long size = 0;
  const int rc = tjCompress2(tj.get(), reinterpret_cast<const unsigned char*>(image.pixels().data()), image.width(),
                             0, image.height(), TJPF_RGBA, &out, &size, TJSAMP_420, quality, TJFLAG_FASTDCT);
  std::unique_ptr<unsigned char, decltype(&tjFree)> owned(out, &tjFree);
  if (rc != 0) throw Error(std::string("JPEG image: ") + tjGetErrorStr2(tj.get()));
  return {out, out + size};
}

Image read_png(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path.string() + ": cannot open PNG file");
  const std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  SpngPtr ctx(spng_ctx_new(0));
  if (!ctx) throw Error(path.string() + ": out of memory creating the PNG decoder");
  check(spng_set_png_buffer(ctx.get(), data.data(), data.size()), path, "PNG buffer");
  spng_ihdr ihdr{};
  check(spng_get_ihdr(ctx.get(), &ihdr), path, "PNG header");
  std::size_t size = 0;
  check(spng_decoded_image_size(ctx.get(), SPNG_FMT_RGBA8, &size), path, "PNG image size");
  Image image(int(ihdr.width), int(ihdr.height));
  if (size != image.pixels().size() * sizeof(Rgba8)) throw Error(path.string() + ": PNG size mismatch");
  check(spng_decode_image(ctx.get(), image.pixels().data(), size, SPNG_FMT_RGBA8, 0), path, "PNG pixels");
  return image;
}

namespace {

// Source coordinate and weight of destination index i when n_in pixels stretch over n_out.
struct Tap {
  int lo = 0, hi = 0;
  float t = 0;
};

std::vector<Tap> taps(int n_in, int n_out) {
  std::vector<Tap> out(static_cast<std::size_t>(n_out));
  const double scale = double(n_in) / double(n_out);
  for (int i = 0; i < n_out; ++i) {
    const double x = std::clamp((i + 0.5) * scale - 0.5, 0.0, double(n_in - 1));
    const int lo = int(x);
    out[std::size_t(i)] = {lo, std::min(lo + 1, n_in - 1), float(x - lo)};
  }
  return out;
}

std::uint8_t mix(std::uint8_t a, std::uint8_t b, std::uint8_t c, std::uint8_t d, float tx, float ty) {
  const float top = a + (b - a) * tx, bottom = c + (d - c) * tx;
  return std::uint8_t(std::lround(top + (bottom - top) * ty));
}

}  // namespace

void ImageMean::add(const Image& image) {
  if (count_ == 0) {
    width_ = image.width();
    height_ = image.height();
    sum_.assign(std::size_t(width_) * std::size_t(height_) * 4, 0.0f);
  } else if (image.width() != width_ || image.height() != height_) {
    throw Error("ImageMean: an image of " + std::to_string(image.width()) + "x" + std::to_string(image.height()) +
                " added to a mean of " + std::to_string(width_) + "x" + std::to_string(height_) + " images");
  }
  float* s = sum_.data();
  for (const Rgba8& p : image.pixels()) {
    s[0] += p.r;
    s[1] += p.g;
    s[2] += p.b;
    s[3] += p.a;
    s += 4;
  }
  ++count_;
}

Image ImageMean::mean() const {
  if (count_ == 0) throw Error("ImageMean: the mean of no images");
  Image out(width_, height_);
  const float inv = 1.0f / float(count_);
  const float* s = sum_.data();
  auto level = [inv](float v) { return std::uint8_t(std::lround(std::clamp(v * inv, 0.0f, 255.0f))); };
  for (Rgba8& p : out.pixels()) {
    p = {level(s[0]), level(s[1]), level(s[2]), level(s[3])};
    s += 4;
  }
  return out;
}

Image resize_bilinear(const Image& image, int width, int height) {
  if (width <= 0 || height <= 0 || image.width() <= 0 || image.height() <= 0)
    throw Error("resize: image sizes must be positive");
  Image out(width, height);
  const std::vector<Tap> xs = taps(image.width(), width), ys = taps(image.height(), height);
  for (int y = 0; y < height; ++y) {
    const Tap& ty = ys[std::size_t(y)];
    for (int x = 0; x < width; ++x) {
      const Tap& tx = xs[std::size_t(x)];
      const Rgba8 &a = image.at(tx.lo, ty.lo), &b = image.at(tx.hi, ty.lo);
      const Rgba8 &c = image.at(tx.lo, ty.hi), &d = image.at(tx.hi, ty.hi);
      out.at(x, y) = {mix(a.r, b.r, c.r, d.r, tx.t, ty.t), mix(a.g, b.g, c.g, d.g, tx.t, ty.t),
                      mix(a.b, b.b, c.b, d.b, tx.t, ty.t), mix(a.a, b.a, c.a, d.a, tx.t, ty.t)};
    }
  }
  return out;
}

}  // namespace strata::render
