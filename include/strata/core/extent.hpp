#pragma once
/// @file
/// @brief Voxel sizes, positions and boxes (Extent, Box) in 64-bit integers, and their text forms.
#include <algorithm>
#include <cstdint>
#include <optional>
#include <string>

#include "strata/core/checked.hpp"

namespace strata {

/// @brief A size or a position in voxels, x fastest. 64-bit so terabyte volumes index safely.
struct Extent {
  std::int64_t x = 0, y = 0, z = 0;

  /// x * y * z, or std::nullopt when the product overflows 64 bits (dims read from a hostile header).
  constexpr std::optional<std::int64_t> checked_voxel_count() const { return checked_product<std::int64_t>({x, y, z}); }
  /// x * y * z; throws Error when the product overflows 64 bits (readers reject such dims first).
  constexpr std::int64_t voxel_count() const {
    if (const auto n = checked_voxel_count()) return *n;
    throw_voxel_count_overflow();
  }
  constexpr bool operator==(const Extent&) const = default;
  std::string to_string() const;  // "XxYxZ"

 private:
  [[noreturn]] void throw_voxel_count_overflow() const;
};

/// @brief A half-open axis-aligned box [lo, hi) in voxel coordinates.
struct Box {
  Extent lo, hi;

  constexpr Extent size() const { return {hi.x - lo.x, hi.y - lo.y, hi.z - lo.z}; }
  constexpr bool empty() const { return hi.x <= lo.x || hi.y <= lo.y || hi.z <= lo.z; }
  constexpr std::int64_t voxel_count() const { return empty() ? 0 : size().voxel_count(); }
  constexpr bool contains(const Box& o) const {
    return o.lo.x >= lo.x && o.lo.y >= lo.y && o.lo.z >= lo.z && o.hi.x <= hi.x && o.hi.y <= hi.y &&
           o.hi.z <= hi.z;
  }
  constexpr Box intersect(const Box& o) const {
    return {{std::max(lo.x, o.lo.x), std::max(lo.y, o.lo.y), std::max(lo.z, o.lo.z)},
            {std::min(hi.x, o.hi.x), std::min(hi.y, o.hi.y), std::min(hi.z, o.hi.z)}};
  }
  constexpr bool operator==(const Box&) const = default;
  static constexpr Box whole(const Extent& dims) { return {{0, 0, 0}, dims}; }
  std::string to_string() const;  // "x0,y0,z0:x1,y1,z1"
};

/// @brief Parses "x0,y0,z0:x1,y1,z1"; throws Error on malformed text.
Box parse_box(const std::string& text);
/// @brief Parses "X" (cube) or "X,Y,Z" / "XxYxZ"; throws Error on malformed text.
Extent parse_extent(const std::string& text);

}  // namespace strata
