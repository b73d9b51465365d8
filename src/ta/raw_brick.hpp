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

std::vector<std::byte> encode_raw_brick(std::span<const float> samples, int zstd_level);
// Throws FormatError(context, "raw brick", ...) unless the payload inflates to out.size() floats.
void decode_raw_brick(std::span<const std::byte> payload, std::span<float> out, std::vector<std::byte>& scratch,
                      const std::string& context);

}  // namespace strata::ta
