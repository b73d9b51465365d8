#pragma once
/// @file
/// @brief Overflow-checked integer arithmetic for sizes that come from input files. A product of
/// header fields (dims × sample size) must never wrap modulo 2^64: a wrapped size passes every
/// "enough bytes" check and then drives reads and loops far past the data. Every size derived from
/// untrusted values goes through these helpers, which report overflow instead of wrapping.
#include <cstdint>
#include <initializer_list>
#include <optional>
#include <type_traits>

namespace strata {

namespace checked_detail {
// `overflows(a, b, &result)` is one of the __builtin_*_overflow functions.
template <class T, class Overflows>
constexpr std::optional<T> checked(T a, T b, Overflows overflows) {
  static_assert(std::is_integral_v<T>, "checked arithmetic is for integers");
  T result{};
  if (overflows(a, b, &result)) return std::nullopt;
  return result;
}
}  // namespace checked_detail

/// a * b, or std::nullopt when the exact product does not fit in T.
template <class T>
constexpr std::optional<T> checked_mul(T a, T b) {
  return checked_detail::checked(a, b, [](T x, T y, T* r) { return __builtin_mul_overflow(x, y, r); });
}

/// a + b, or std::nullopt when the exact sum does not fit in T.
template <class T>
constexpr std::optional<T> checked_add(T a, T b) {
  return checked_detail::checked(a, b, [](T x, T y, T* r) { return __builtin_add_overflow(x, y, r); });
}

/// The product of all factors, or std::nullopt when any partial product overflows T.
template <class T>
constexpr std::optional<T> checked_product(std::initializer_list<T> factors) {
  T product = 1;
  for (T f : factors) {
    const auto next = checked_mul(product, f);
    if (!next) return std::nullopt;
    product = *next;
  }
  return product;
}

}  // namespace strata
