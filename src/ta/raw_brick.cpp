#include "ta/raw_brick.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "strata/core/bytes.hpp"
#include "strata/core/error.hpp"
#include "strata/store/byte_planes.hpp"
#include "strata/store/zstd_frame.hpp"

namespace strata::ta {

std::vector<std::byte> encode_raw_brick(std::span<const float> samples, int zstd_level) {
  const auto bytes = std::as_bytes(samples);
  std::vector<std::byte> planes(bytes.size());
  store::split_byte_planes(bytes, planes, sizeof(float));
  return store::zstd_compress(planes, zstd_level > 0 ? zstd_level : 3);
}

void decode_raw_brick(std::span<const std::byte> payload, std::span<float> out, std::vector<std::byte>& scratch,
                      const std::string& context) {
  const std::uint64_t expected = out.size() * sizeof(float);
  store::zstd_decompress(payload, expected, scratch, context, "raw brick");
  if (scratch.size() != expected)
    throw FormatError(context, "raw brick",
                      "inflates to " + std::to_string(scratch.size()) + " bytes, expected " + std::to_string(expected));
  store::merge_byte_planes(scratch, std::as_writable_bytes(out), sizeof(float));
}

namespace {

using packed::Box;
using packed::Coding;
using packed::SampleCoding;

constexpr std::size_t kPackedHeaderBytes = 18;
// Integer codes are exact while base + code stays an integer a float holds exactly.
constexpr double kExactInteger = 16777216.0;  // 2^24

std::size_t code_bytes(Coding c) { return c == Coding::f32 ? 4 : c == Coding::u16 ? 2 : 1; }

std::array<std::size_t, 3> strides(int width) {
  const auto w = std::size_t(width);
  return {1, w, w * w};
}

// Whether the samples with index `a` along `axis` equal those with index `b`, bit for bit.
bool slices_equal(std::span<const float> s, int width, int axis, int a, int b) {
  const auto st = strides(width);
  const std::size_t step_a = st[std::size_t(axis)];
  const int u = axis == 0 ? 1 : 0, v = axis == 2 ? 1 : 2;
  for (int j = 0; j < width; ++j)
    for (int i = 0; i < width; ++i) {
      const std::size_t base = std::size_t(i) * st[std::size_t(u)] + std::size_t(j) * st[std::size_t(v)];
      if (std::memcmp(&s[base + std::size_t(a) * step_a], &s[base + std::size_t(b) * step_a], sizeof(float)) != 0)
        return false;
    }
  return true;
}

// The smallest box whose outside repeats its edge along each axis: how gather_samples pads a
// brick at a level's edge (and any brick whose border happens to repeat).
Box replicated_box(std::span<const float> s, int width) {
  Box box;
  for (int axis = 0; axis < 3; ++axis) {
    int lo = 0, hi = width - 1;
    while (lo < hi && slices_equal(s, width, axis, lo, lo + 1)) ++lo;
    while (hi > lo && slices_equal(s, width, axis, hi, hi - 1)) --hi;
    box.lo[std::size_t(axis)] = lo;
    box.extent[std::size_t(axis)] = hi - lo + 1;
  }
  return box;
}

template <class F>
void for_each_in_box(const Box& box, int width, F&& f) {
  const auto st = strides(width);
  std::size_t n = 0;
  for (int k = 0; k < box.extent[2]; ++k)
    for (int j = 0; j < box.extent[1]; ++j) {
      const std::size_t row = std::size_t(box.lo[0]) + std::size_t(box.lo[1] + j) * st[1] + std::size_t(box.lo[2] + k) * st[2];
      for (int i = 0; i < box.extent[0]; ++i, ++n) f(n, row + std::size_t(i));
    }
}

constexpr int kMaxFractionBits = 8;  // the means of a few levels of 2 x 2 x 2 integer samples

// Whether `v` is an integer a float holds exactly (|v| < 2^24): a truncating conversion, not
// nearbyint (a libm call that honours the rounding mode), on the per-sample path.
bool exact_integer(double v) { return std::abs(v) < kExactInteger && v == double(std::int32_t(v)); }

// The fraction bits sample `v` needs to be such an integer code, or -1 when more than
// kMaxFractionBits would.
int fraction_bits_of(double v) {
  for (int f = 0; f <= kMaxFractionBits; ++f, v *= 2) {
    if (std::abs(v) >= kExactInteger) return -1;
    if (exact_integer(v)) return f;
  }
  return -1;
}

// Integer codes where every sample is base + code · 2^-f exactly, for the smallest such f:
// integer sources at level 0 (f = 0), and their 2 x 2 x 2 means at the coarser levels (f = 3
// per level while the spread allows). Anything else keeps its float bits. One pass that stops
// at the first sample no code holds (float data, the common case there).
SampleCoding choose_coding(std::span<const float> s, const Box& box, int width) {
  const auto st = strides(width);
  int f = 0;
  double lo = INFINITY, hi = -INFINITY;
  for (int k = 0; k < box.extent[2]; ++k)
    for (int j = 0; j < box.extent[1]; ++j) {
      const float* row = s.data() + std::size_t(box.lo[0]) + std::size_t(box.lo[1] + j) * st[1] + std::size_t(box.lo[2] + k) * st[2];
      for (int i = 0; i < box.extent[0]; ++i) {
        const double v = row[i];
        // -0 is left to the f32 coding: a code would bring it back as +0.
        if (v == 0 && std::signbit(v)) return {};
        if (!exact_integer(v)) {
          const int needed = fraction_bits_of(v);
          if (needed < 0) return {};
          f = std::max(f, needed);
        }
        lo = std::min(lo, v);
        hi = std::max(hi, v);
      }
    }
  const double spread = std::ldexp(hi - lo, f);
  if (spread > 65535 || std::abs(std::ldexp(hi, f)) >= kExactInteger || std::abs(std::ldexp(lo, f)) >= kExactInteger)
    return {};
  return {spread <= 255 ? Coding::u8 : Coding::u16, f, float(lo)};
}

std::vector<std::byte> box_codes(std::span<const float> s, const Box& box, int width, const SampleCoding& c) {
  const std::size_t bytes = code_bytes(c.coding);
  std::vector<std::byte> codes(box.voxels() * bytes);
  for_each_in_box(box, width, [&](std::size_t n, std::size_t at) {
    if (c.coding == Coding::f32) {
      std::memcpy(&codes[n * 4], &s[at], 4);
    } else {
      const auto code = std::uint16_t(std::ldexp(double(s[at]) - double(c.base), c.fraction_bits));
      std::memcpy(&codes[n * bytes], &code, bytes);  // little endian: the low byte first
    }
  });
  if (bytes == 1) return codes;
  std::vector<std::byte> planes(codes.size());
  store::split_byte_planes(codes, planes, bytes);
  return planes;
}

Box read_box(ByteReader& in, int width, const std::string& context) {
  Box box;
  for (int& lo : box.lo) lo = in.get<std::uint16_t>("packed raw brick lo");
  for (int& e : box.extent) e = in.get<std::uint16_t>("packed raw brick extent");
  for (std::size_t a = 0; a < 3; ++a)
    if (box.extent[a] < 1 || box.lo[a] + box.extent[a] > width)
      throw FormatError(context, "packed raw brick",
                        "stored box [" + std::to_string(box.lo[a]) + ", +" + std::to_string(box.extent[a]) +
                            ") along axis " + std::to_string(a) + " is empty or leaves the brick of width " +
                            std::to_string(width));
  return box;
}

}  // namespace

PackedBrickEncoder::PackedBrickEncoder(std::span<const float> samples, int width) : samples_(samples), width_(width) {
  if (samples.size() != std::size_t(width) * std::size_t(width) * std::size_t(width))
    throw Error("encode_packed_brick: the samples are not a brick of width " + std::to_string(width));
  box_ = replicated_box(samples, width);
}

const SampleCoding& PackedBrickEncoder::coding() {
  if (!coding_) coding_ = choose_coding(samples_, box_, width_);
  return *coding_;
}

std::size_t PackedBrickEncoder::plain_bytes() { return box_.voxels() * code_bytes(coding().coding); }

std::vector<std::byte> PackedBrickEncoder::encode(int zstd_level) {
  const SampleCoding& c = coding();
  const std::vector<std::byte> frame = store::zstd_compress(box_codes(samples_, box_, width_, c), zstd_level > 0 ? zstd_level : 3);
  ByteWriter out(kPackedHeaderBytes + frame.size());
  out.put(std::uint8_t(c.coding));
  out.put(std::uint8_t(c.fraction_bits));
  for (int lo : box_.lo) out.put(std::uint16_t(lo));
  for (int e : box_.extent) out.put(std::uint16_t(e));
  out.put(c.base);
  out.put_bytes(frame);
  return out.take();
}

std::vector<std::byte> encode_packed_brick(std::span<const float> samples, int width, int zstd_level) {
  return PackedBrickEncoder(samples, width).encode(zstd_level);
}

void decode_packed_brick(std::span<const std::byte> payload, int width, std::span<float> out,
                         std::vector<std::byte>& scratch, const std::string& context) {
  if (out.size() != std::size_t(width) * std::size_t(width) * std::size_t(width))
    throw Error(context + ": decode buffer does not hold a brick of width " + std::to_string(width));
  ByteReader in(payload, context);
  const auto coding = Coding(in.get<std::uint8_t>("packed raw brick coding"));
  if (coding != Coding::f32 && coding != Coding::u8 && coding != Coding::u16)
    throw FormatError(context, "packed raw brick coding", "must be 0 (f32), 1 (u8) or 2 (u16), got " + std::to_string(int(coding)));
  SampleCoding c{coding, in.get<std::uint8_t>("packed raw brick fraction bits"), 0};
  if (c.fraction_bits > (coding == Coding::f32 ? 0 : kMaxFractionBits))
    throw FormatError(context, "packed raw brick fraction bits",
                      "must be 0 for f32 samples and at most " + std::to_string(kMaxFractionBits) + ", got " +
                          std::to_string(c.fraction_bits));
  const Box box = read_box(in, width, context);
  c.base = in.get<float>("packed raw brick base");
  if (!std::isfinite(c.base) || (coding == Coding::f32 && c.base != 0))
    throw FormatError(context, "packed raw brick base", "must be finite (and 0 for f32 samples)");
  const std::size_t bytes = code_bytes(coding), expected = box.voxels() * bytes;
  store::zstd_decompress(in.bytes(in.remaining(), "packed raw brick planes"), expected, scratch, context,
                         "packed raw brick planes");
  if (scratch.size() != expected)
    throw FormatError(context, "packed raw brick planes",
                      "inflate to " + std::to_string(scratch.size()) + " bytes, the box needs " + std::to_string(expected));
  // The codes are read straight from their byte planes (plane p holds byte p of every code).
  const std::size_t count = box.voxels();
  const double scale = std::ldexp(1.0, -c.fraction_bits);  // exact: code * scale == ldexp(code, -f)
  const auto stored = [&](std::size_t n) -> float {
    std::uint32_t code = 0;
    for (std::size_t p = 0; p < bytes; ++p) code |= std::uint32_t(scratch[p * count + n]) << (8 * p);
    return coding == Coding::f32 ? std::bit_cast<float>(code) : float(double(c.base) + double(code) * scale);
  };
  // Clamping each coordinate into the box repeats its edge the way the encoder found it.
  const auto st = strides(width);
  auto clamp_into = [&](int i, std::size_t a) { return std::size_t(std::clamp(i - box.lo[a], 0, box.extent[a] - 1)); };
  for (int k = 0; k < width; ++k)
    for (int j = 0; j < width; ++j) {
      const std::size_t src_row = (clamp_into(k, 2) * std::size_t(box.extent[1]) + clamp_into(j, 1)) * std::size_t(box.extent[0]);
      float* dst = out.data() + std::size_t(j) * st[1] + std::size_t(k) * st[2];
      for (int i = 0; i < width; ++i) dst[i] = stored(src_row + clamp_into(i, 0));
    }
}

}  // namespace strata::ta
