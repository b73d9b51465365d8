#include "strata/core/dtype.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <utility>

namespace strata {

std::string_view dtype_name(DType t) {
  switch (t) {
    case DType::u8: return "u8";
    case DType::i8: return "i8";
    case DType::u16: return "u16";
    case DType::i16: return "i16";
    case DType::u32: return "u32";
    case DType::i32: return "i32";
    case DType::f32: return "f32";
    case DType::f64: return "f64";
    case DType::u64: return "u64";
    case DType::i64: return "i64";
  }
  return "?";
}

DType parse_dtype(std::string_view name, std::string_view context) {
  static const std::array<std::pair<std::string_view, DType>, 28> kNames{{
      {"u8", DType::u8},     {"uint8", DType::u8},     {"uchar", DType::u8},
      {"i8", DType::i8},     {"int8", DType::i8},      {"char", DType::i8},
      {"u16", DType::u16},   {"uint16", DType::u16},   {"ushort", DType::u16},
      {"i16", DType::i16},   {"int16", DType::i16},    {"short", DType::i16},
      {"u32", DType::u32},   {"uint32", DType::u32},   {"uint", DType::u32},
      {"i32", DType::i32},   {"int32", DType::i32},    {"int", DType::i32},
      {"f32", DType::f32},   {"float32", DType::f32},  {"float", DType::f32},
      {"f64", DType::f64},   {"float64", DType::f64},  {"double", DType::f64},
      {"u64", DType::u64},   {"uint64", DType::u64},   {"i64", DType::i64},      {"int64", DType::i64},
  }};
  std::string lower(name);
  std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return std::tolower(c); });
  for (const auto& [n, t] : kNames)
    if (n == lower) return t;
  throw Error(std::string(context) + ": unknown sample type '" + std::string(name) +
              "' (expected one of u8, i8, u16, i16, u32, i32, f32, f64, u64, i64)");
}

}  // namespace strata
