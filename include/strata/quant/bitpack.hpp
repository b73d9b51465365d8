#pragma once
/// @file
/// @brief Fixed-width code packing: code i occupies bits [i*bits, (i+1)*bits) of a little-endian,
/// least-significant-bit-first stream. For 12-bit codes that is two codes per three bytes:
///   byte0 = c0[7:0], byte1 = c0[11:8] | c1[3:0] << 4, byte2 = c1[11:4].
/// 8-, 16- and 32-bit codes are plain little-endian arrays.
#include <cstddef>
#include <cstdint>
#include <span>

namespace strata::quant {

/// @brief Bytes needed for `count` codes of `bits` bits (the last byte zero-padded).
constexpr std::size_t packed_size(std::size_t count, int bits) { return (count * std::size_t(bits) + 7) / 8; }

/// @brief Writes packed_size(codes.size(), bits) bytes to `out` (which must be at least that large).
/// bits in 1..32; throws Error if a code does not fit in `bits` bits or `out` is too small.
void pack_codes(std::span<const std::uint32_t> codes, int bits, std::span<std::byte> out);

/// @brief Reads codes.size() codes; throws Error if `in` is shorter than packed_size(codes.size(), bits).
void unpack_codes(std::span<const std::byte> in, int bits, std::span<std::uint32_t> codes);

/// @brief Code `index` of a packed stream, without bounds checks (callers validate the stream size once).
inline std::uint32_t read_code(const std::byte* in, int bits, std::size_t index) {
  const std::size_t bit = index * std::size_t(bits);
  const std::byte* p = in + bit / 8;
  // Gather the (at most 5) bytes that hold the code; bytes past the code are masked away, and
  // only bytes inside the stream are read.
  const unsigned shift = unsigned(bit % 8);
  const std::size_t span_bytes = (shift + std::size_t(bits) + 7) / 8;
  std::uint64_t word = 0;
  for (std::size_t b = 0; b < span_bytes; ++b) word |= std::uint64_t(p[b]) << (8 * b);
  const std::uint64_t mask = bits == 32 ? 0xFFFFFFFFull : ((1ull << bits) - 1);
  return std::uint32_t((word >> shift) & mask);
}

}  // namespace strata::quant
