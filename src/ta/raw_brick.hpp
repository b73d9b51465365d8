#pragma once
// The lossless brick (payload kind raw_zstd): the B^3 float samples split into four byte planes
// (all lowest bytes, then the next, ...: exponents and high mantissa bytes of neighbouring
// samples repeat, low bytes are noise) and zstd-compressed. The error-target codec's fallback,
// so a brick never costs more than storing it losslessly. Private to src/ta.
#include <cstddef>
#include <span>
#include <string>
#include <vector>

namespace strata::ta {

// Byte plane p of `in` (items of `width` bytes) goes to out[p * n .. (p + 1) * n); bytes after
// the last whole item are copied as they are. merge_byte_planes is its inverse.
void split_byte_planes(std::span<const std::byte> in, std::span<std::byte> out, std::size_t width);
void merge_byte_planes(std::span<const std::byte> in, std::span<std::byte> out, std::size_t width);

std::vector<std::byte> encode_raw_brick(std::span<const float> samples, int zstd_level);
// Throws FormatError(context, "raw brick", ...) unless the payload inflates to out.size() floats.
void decode_raw_brick(std::span<const std::byte> payload, std::span<float> out, std::vector<std::byte>& scratch,
                      const std::string& context);

}  // namespace strata::ta
