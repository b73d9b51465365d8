#pragma once
// The lossless bricks, private to src/ta.
//
// raw_zstd (kind 5, format 1.1): the B^3 float samples split into four byte planes (all lowest
// bytes, then the next, ...: exponents and high mantissa bytes of neighbouring samples repeat,
// low bytes are noise) and zstd-compressed. Still read; no longer written.
//
// raw_packed (kind 6, format 1.3): what a raw_zstd brick holds, without its two wastes. A brick
// at the edge of a level repeats the level's edge samples to fill B^3 (a 512 x 512 x 1 image has
// 32 copies of each slice in every brick), and integer samples (u8/u16 sources, the common
// case) spend 32 bits on 8 or 16. The payload keeps only the smallest box whose outside repeats
// its edge, as integer codes above a base wherever they are exact: integer samples, and the
// coarser levels' means of them (multiples of 1/8, 1/64, ...) while the spread fits 16 bits:
//
// | offset | type   | field    | meaning                                                        |
// | ------ | ------ | -------- | -------------------------------------------------------------- |
// | 0      | u8     | coding   | 0: f32 samples, 4 byte planes; 1: u8 codes; 2: u16 codes, 2 byte planes |
// | 1      | u8     | fraction | f: codes count steps of 2^-f (0..8; 0 for coding 0)            |
// | 2      | u16[3] | lo       | first stored sample along x, y, z                              |
// | 8      | u16[3] | extent   | stored samples along x, y, z: >= 1, lo + extent <= B           |
// | 14     | f32    | base     | sample = base + code · 2^-f (codings 1, 2; 0 for coding 0); finite |
// | 18     | bytes  | planes   | one zstd frame: the box's codes, first index fastest, as planes |
//
// Decoding clamps each coordinate into the box, so the brick is bit-identical to the encoder's.
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace strata::ta {

// raw_zstd (kind 5).
std::vector<std::byte> encode_raw_brick(std::span<const float> samples, int zstd_level);
// Throws FormatError(context, "raw brick", ...) unless the payload inflates to out.size() floats.
void decode_raw_brick(std::span<const std::byte> payload, std::span<float> out, std::vector<std::byte>& scratch,
                      const std::string& context);

namespace packed {
enum class Coding : std::uint8_t { f32 = 0, u8 = 1, u16 = 2 };
// The stored box: samples [lo, lo + extent) along each axis.
struct Box {
  std::array<int, 3> lo{}, extent{};
  std::size_t voxels() const { return std::size_t(extent[0]) * std::size_t(extent[1]) * std::size_t(extent[2]); }
};
// sample = base + code * 2^-fraction_bits (codings u8, u16); f32 keeps the float bits.
struct SampleCoding {
  Coding coding = Coding::f32;
  int fraction_bits = 0;
  float base = 0;
};
}  // namespace packed

// raw_packed (kind 6) of one brick of `width`^3 samples, in steps an encoder can stop between:
// the stored box (cheap) and the coding (one pass over the box) are each found once, so
// comparing a lossy payload against their sizes first and then encoding repeats no work.
// Decoding returns exactly `samples`.
class PackedBrickEncoder {
 public:
  PackedBrickEncoder(std::span<const float> samples, int width);
  // Samples the payload stores (a bound on its size before any coding is chosen).
  std::size_t box_voxels() const { return box_.voxels(); }
  // Bytes of its planes before zstd: the box's samples at the chosen code width.
  std::size_t plain_bytes();
  std::vector<std::byte> encode(int zstd_level);

 private:
  const packed::SampleCoding& coding();
  std::span<const float> samples_;
  int width_;
  packed::Box box_;
  std::optional<packed::SampleCoding> coding_;
};

std::vector<std::byte> encode_packed_brick(std::span<const float> samples, int width, int zstd_level);
// Throws FormatError(context, "packed raw brick", ...) for any header field outside the table
// above, or planes that do not inflate to the box.
void decode_packed_brick(std::span<const std::byte> payload, int width, std::span<float> out,
                         std::vector<std::byte>& scratch, const std::string& context);

}  // namespace strata::ta
