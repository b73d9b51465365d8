#pragma once
/// @file
/// @brief Byte serialization for the project's binary formats: one writer that appends
/// fixed-width values, one bounds-checked reader that throws FormatError(file, field,
/// "truncated …") instead of reading past its span, and fixed-offset field access for records
/// of known size (file headers, index entries). Integers and floats are stored little endian
/// (the host's order; the project requires a little-endian host); load_field also reads
/// big-endian records (NIfTI files may be either).
#include <algorithm>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

#include "strata/core/error.hpp"

namespace strata {

static_assert(std::endian::native == std::endian::little, "the binary formats assume a little-endian host");

namespace detail {
[[noreturn]] inline void field_outside_record(std::size_t offset, std::size_t bytes, std::size_t record) {
  throw Error("internal error: a " + std::to_string(bytes) + "-byte field at byte " + std::to_string(offset) +
              " lies outside a " + std::to_string(record) + "-byte record");
}
}  // namespace detail

/// @brief Stores `value` little endian at byte `offset` of `record`. A field outside the record
/// is a programming error and throws Error("internal error: …").
template <class T>
void store_field(std::span<std::byte> record, std::size_t offset, T value) {
  static_assert(std::is_arithmetic_v<T>, "store_field writes integers and floats");
  if (offset > record.size() || sizeof(T) > record.size() - offset)
    detail::field_outside_record(offset, sizeof(T), record.size());
  std::memcpy(record.data() + offset, &value, sizeof(T));
}

/// @brief Loads the field at byte `offset` of `record`, stored in byte order `order`. A field
/// outside the record throws Error("internal error: …"): callers check a record's size (and
/// report a truncated file) before they read its fields.
template <class T>
T load_field(std::span<const std::byte> record, std::size_t offset, std::endian order = std::endian::little) {
  static_assert(std::is_arithmetic_v<T>, "load_field reads integers and floats");
  if (offset > record.size() || sizeof(T) > record.size() - offset)
    detail::field_outside_record(offset, sizeof(T), record.size());
  std::byte raw[sizeof(T)];
  std::memcpy(raw, record.data() + offset, sizeof(T));
  if (order != std::endian::native) std::reverse(raw, raw + sizeof(T));
  T value;
  std::memcpy(&value, raw, sizeof(T));
  return value;
}

class ByteWriter {
 public:
  /// `expected_size`: bytes to reserve up front (the final size, when the caller knows it).
  explicit ByteWriter(std::size_t expected_size = 0) { bytes_.reserve(expected_size); }
  template <class T>
  void put(T value) {
    static_assert(std::is_arithmetic_v<T>, "ByteWriter::put writes integers and floats");
    const std::size_t at = bytes_.size();
    bytes_.resize(at + sizeof(T));
    std::memcpy(bytes_.data() + at, &value, sizeof(T));
  }
  void put_bytes(std::span<const std::byte> b) { bytes_.insert(bytes_.end(), b.begin(), b.end()); }
  std::size_t size() const { return bytes_.size(); }
  std::vector<std::byte> take() { return std::move(bytes_); }

 private:
  std::vector<std::byte> bytes_;
};

class ByteReader {
 public:
  /// `file` names the input in errors (a path, or what the bytes are).
  ByteReader(std::span<const std::byte> bytes, std::string file) : bytes_(bytes), file_(std::move(file)) {}

  /// Throws FormatError(file, field, "truncated …") unless `n` more bytes remain.
  void need(std::uint64_t n, const char* field) const {
    if (n > bytes_.size() - at_)
      throw FormatError(file_, field,
                        "truncated at byte " + std::to_string(at_) + " (" + std::to_string(n) + " bytes needed, " +
                            std::to_string(bytes_.size() - at_) + " left)");
  }
  /// The same for `count` items of `item_bytes` each, without overflowing on a hostile count.
  void need_array(std::uint64_t count, std::size_t item_bytes, const char* field) const {
    if (item_bytes != 0 && count > (bytes_.size() - at_) / item_bytes)
      throw FormatError(file_, field,
                        "truncated at byte " + std::to_string(at_) + " (" + std::to_string(count) + " items of " +
                            std::to_string(item_bytes) + " bytes needed, " + std::to_string(bytes_.size() - at_) +
                            " bytes left)");
  }
  template <class T>
  T get(const char* field) {
    static_assert(std::is_arithmetic_v<T>, "ByteReader::get reads integers and floats");
    need(sizeof(T), field);
    T value;
    std::memcpy(&value, bytes_.data() + at_, sizeof(T));
    at_ += sizeof(T);
    return value;
  }
  std::span<const std::byte> bytes(std::uint64_t n, const char* field) {
    need(n, field);
    const auto s = bytes_.subspan(at_, std::size_t(n));
    at_ += std::size_t(n);
    return s;
  }
  std::size_t position() const { return at_; }
  std::size_t remaining() const { return bytes_.size() - at_; }
  const std::string& file() const { return file_; }

 private:
  std::span<const std::byte> bytes_;
  std::string file_;
  std::size_t at_ = 0;
};

}  // namespace strata
