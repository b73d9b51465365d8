#pragma once
/// @file
/// @brief Voxel sample types: their sizes and names, the C++ type of each, and visit_dtype, which
/// runs a template once per type so typed kernels are written once.
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <type_traits>

#include "strata/core/error.hpp"

namespace strata {

/// @brief Voxel sample types. Storage is always native little endian in memory.
/// u64 and i64 come last so the codes of the older types never change; they exist for label
/// (segmentation) volumes, whose ids are opaque 64-bit values in connectomics.
enum class DType : std::uint8_t { u8, i8, u16, i16, u32, i32, f32, f64, u64, i64 };
/// @brief Every sample type, in code order: the one list loops over types take.
inline constexpr std::array<DType, 10> kAllDTypes{DType::u8,  DType::i8,  DType::u16, DType::i16, DType::u32,
                                                  DType::i32, DType::f32, DType::f64, DType::u64, DType::i64};

/// @brief Bytes per sample: 1, 2, 4 or 8.
constexpr std::size_t dtype_size(DType t) {
  switch (t) {
    case DType::u8: case DType::i8: return 1;
    case DType::u16: case DType::i16: return 2;
    case DType::u32: case DType::i32: case DType::f32: return 4;
    case DType::f64: case DType::u64: case DType::i64: return 8;
  }
  return 0;
}
constexpr bool dtype_is_float(DType t) { return t == DType::f32 || t == DType::f64; }
constexpr bool dtype_is_signed(DType t) {
  return t == DType::i8 || t == DType::i16 || t == DType::i32 || t == DType::i64 || dtype_is_float(t);
}
constexpr bool dtype_is_integer(DType t) { return !dtype_is_float(t); }

/// @brief "u8", "i8", "u16", "i16", "u32", "i32", "f32", "f64", "u64" or "i64".
std::string_view dtype_name(DType t);
/// @brief Accepts our names (u8, i16, f32, ...) and common spellings (uint8, int16, float, double).
/// Throws Error naming `context` when the name is unknown.
DType parse_dtype(std::string_view name, std::string_view context = "dtype");

/// @brief The DType of the C++ sample type T (defined for the ten sample types only).
template <class T> constexpr DType dtype_of();
template <> constexpr DType dtype_of<std::uint8_t>() { return DType::u8; }
template <> constexpr DType dtype_of<std::int8_t>() { return DType::i8; }
template <> constexpr DType dtype_of<std::uint16_t>() { return DType::u16; }
template <> constexpr DType dtype_of<std::int16_t>() { return DType::i16; }
template <> constexpr DType dtype_of<std::uint32_t>() { return DType::u32; }
template <> constexpr DType dtype_of<std::int32_t>() { return DType::i32; }
template <> constexpr DType dtype_of<float>() { return DType::f32; }
template <> constexpr DType dtype_of<double>() { return DType::f64; }
template <> constexpr DType dtype_of<std::uint64_t>() { return DType::u64; }
template <> constexpr DType dtype_of<std::int64_t>() { return DType::i64; }

/// @brief Calls f(T{}) with the C++ type of `t`, so typed kernels are written once as templates.
template <class F>
decltype(auto) visit_dtype(DType t, F&& f) {
  switch (t) {
    case DType::u8: return f(std::uint8_t{});
    case DType::i8: return f(std::int8_t{});
    case DType::u16: return f(std::uint16_t{});
    case DType::i16: return f(std::int16_t{});
    case DType::u32: return f(std::uint32_t{});
    case DType::i32: return f(std::int32_t{});
    case DType::f32: return f(float{});
    case DType::f64: return f(double{});
    case DType::u64: return f(std::uint64_t{});
    case DType::i64: return f(std::int64_t{});
  }
  throw Error("visit_dtype: invalid dtype value");
}

}  // namespace strata
