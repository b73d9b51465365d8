#include "strata/quant/bitpack.hpp"

#include <algorithm>
#include <string>
#include <vector>

#include "strata/core/bitstream.hpp"
#include "strata/core/error.hpp"

namespace strata::quant {
namespace {

void check_bits(int bits, const char* context) {
  if (bits < 1 || bits > 32) throw Error(std::string(context) + ": bits must be in [1, 32], got " + std::to_string(bits));
}

// Little-endian byte-aligned widths: each code is its own group of bytes.
template <int Bytes>
void pack_aligned(std::span<const std::uint32_t> codes, std::byte* out) {
  for (std::uint32_t c : codes)
    for (int b = 0; b < Bytes; ++b) *out++ = std::byte((c >> (8 * b)) & 0xFF);
}

template <int Bytes>
void unpack_aligned(const std::byte* in, std::span<std::uint32_t> codes) {
  for (std::uint32_t& c : codes) {
    std::uint32_t v = 0;
    for (int b = 0; b < Bytes; ++b) v |= std::uint32_t(in[b]) << (8 * b);
    c = v;
    in += Bytes;
  }
}

// Any width: the project's one bit stream (LSB first), then copied into the caller's span.
void pack_generic(std::span<const std::uint32_t> codes, int bits, std::byte* out) {
  BitWriter w;
  for (std::uint32_t c : codes) w.put(c, bits);
  const std::vector<std::byte> packed = w.take();
  std::copy(packed.begin(), packed.end(), out);
}

void check_fits(std::span<const std::uint32_t> codes, int bits) {
  if (bits == 32) return;
  const std::uint32_t limit = 1u << bits;
  for (std::size_t i = 0; i < codes.size(); ++i) {
    if (codes[i] >= limit) {
      throw Error("pack_codes: code " + std::to_string(codes[i]) + " at index " + std::to_string(i) +
                  " does not fit in " + std::to_string(bits) + " bits");
    }
  }
}

}  // namespace

void pack_codes(std::span<const std::uint32_t> codes, int bits, std::span<std::byte> out) {
  check_bits(bits, "pack_codes");
  const std::size_t need = packed_size(codes.size(), bits);
  if (out.size() < need) {
    throw Error("pack_codes: output holds " + std::to_string(out.size()) + " bytes, " + std::to_string(need) + " needed");
  }
  check_fits(codes, bits);
  switch (bits) {
    case 8: pack_aligned<1>(codes, out.data()); break;
    case 16: pack_aligned<2>(codes, out.data()); break;
    case 32: pack_aligned<4>(codes, out.data()); break;
    default: pack_generic(codes, bits, out.data()); break;
  }
}

void unpack_codes(std::span<const std::byte> in, int bits, std::span<std::uint32_t> codes) {
  check_bits(bits, "unpack_codes");
  const std::size_t need = packed_size(codes.size(), bits);
  if (in.size() < need) {
    throw Error("unpack_codes: input holds " + std::to_string(in.size()) + " bytes, " + std::to_string(need) +
                " needed for " + std::to_string(codes.size()) + " codes of " + std::to_string(bits) + " bits");
  }
  switch (bits) {
    case 8: unpack_aligned<1>(in.data(), codes); break;
    case 16: unpack_aligned<2>(in.data(), codes); break;
    case 32: unpack_aligned<4>(in.data(), codes); break;
    default:
      for (std::size_t i = 0; i < codes.size(); ++i) codes[i] = read_code(in.data(), bits, i);
      break;
  }
}

}  // namespace strata::quant
