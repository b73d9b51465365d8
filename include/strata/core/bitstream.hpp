#pragma once
/// @brief LSB-first bit streams, the one bit order of the project's formats: bit i of a stream is
/// bit i mod 8 of byte ⌊i/8⌋, and a value of n bits occupies the next n stream bits, lowest bit
/// first (the Mixture Graph bitstream, packed quantization codes). The writer zero-pads the last
/// byte; the reader throws FormatError(file, field, "bitstream ends early (truncated)") rather than
/// read past its span.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "strata/core/error.hpp"

namespace strata {

class BitWriter {
 public:
  /// Appends the low `bits` bits of `value` (0 <= bits <= 64; higher bits of `value` are ignored).
  void put(std::uint64_t value, int bits) {
    if (bits > 32) {
      put(value & 0xFFFFFFFFull, 32);
      put(value >> 32, bits - 32);
      return;
    }
    if (bits < 32) value &= (std::uint64_t(1) << bits) - 1;
    acc_ |= value << filled_;  // filled_ < 8 here, so at most 39 bits are in use
    filled_ += bits;
    bit_count_ += std::uint64_t(bits);
    while (filled_ >= 8) {
      bytes_.push_back(std::byte(acc_ & 0xFF));
      acc_ >>= 8;
      filled_ -= 8;
    }
  }
  std::uint64_t bit_count() const { return bit_count_; }
  /// The stream, its last byte zero-padded; the writer is left empty.
  std::vector<std::byte> take() {
    if (filled_ > 0) bytes_.push_back(std::byte(acc_ & 0xFF));
    acc_ = 0;
    filled_ = 0;
    bit_count_ = 0;
    return std::move(bytes_);
  }

 private:
  std::vector<std::byte> bytes_;
  std::uint64_t acc_ = 0;
  int filled_ = 0;
  std::uint64_t bit_count_ = 0;
};

class BitReader {
 public:
  /// `file` names the input in errors; `field_prefix` is prepended to every field name.
  BitReader(std::span<const std::byte> bytes, std::string file, std::string field_prefix = {})
      : bytes_(bytes), file_(std::move(file)), prefix_(std::move(field_prefix)) {}

  /// The next `bits` bits (0 <= bits <= 64) as an integer, lowest stream bit lowest.
  std::uint64_t get(int bits, const char* field) {
    if (pos_ + std::uint64_t(bits) > size_bits())
      throw FormatError(file_, prefix_ + field, "bitstream ends early (truncated)");
    std::uint64_t value = 0;
    for (int got = 0; got < bits;) {
      const unsigned byte = std::to_integer<unsigned>(bytes_[std::size_t(pos_ / 8)]);
      const int offset = int(pos_ % 8), take = std::min(8 - offset, bits - got);
      value |= std::uint64_t((byte >> offset) & ((1u << take) - 1u)) << got;
      got += take;
      pos_ += std::uint64_t(take);
    }
    return value;
  }
  std::uint64_t position() const { return pos_; }
  std::uint64_t size_bits() const { return std::uint64_t(bytes_.size()) * 8u; }

 private:
  std::span<const std::byte> bytes_;
  std::string file_, prefix_;
  std::uint64_t pos_ = 0;
};

}  // namespace strata
