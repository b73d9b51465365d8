#pragma once
/// @file
/// @brief A small double-precision 3-vector for geometry (cameras, rays, frusta). Kernels that touch
/// voxels use floats and plain arrays; this type is for per-frame and per-ray set-up.
#include <cmath>

namespace strata {

/// @brief A point or direction (x, y, z) with the arithmetic the geometry code needs.
struct Vec3 {
  double x = 0, y = 0, z = 0;

  constexpr Vec3 operator+(const Vec3& o) const { return {x + o.x, y + o.y, z + o.z}; }
  constexpr Vec3 operator-(const Vec3& o) const { return {x - o.x, y - o.y, z - o.z}; }
  constexpr Vec3 operator-() const { return {-x, -y, -z}; }
  constexpr Vec3 operator*(double s) const { return {x * s, y * s, z * s}; }
  constexpr Vec3 operator/(double s) const { return {x / s, y / s, z / s}; }
  constexpr Vec3& operator+=(const Vec3& o) { x += o.x; y += o.y; z += o.z; return *this; }
  constexpr bool operator==(const Vec3&) const = default;
  constexpr double operator[](int axis) const { return axis == 0 ? x : axis == 1 ? y : z; }
};

constexpr Vec3 operator*(double s, const Vec3& v) { return v * s; }
constexpr double dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
constexpr Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
constexpr Vec3 hadamard(const Vec3& a, const Vec3& b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }
inline double length(const Vec3& v) { return std::sqrt(dot(v, v)); }
/// @brief `v` scaled to length 1; a zero vector is returned unchanged.
inline Vec3 normalized(const Vec3& v) {
  const double n = length(v);
  return n > 0 ? v / n : v;
}

}  // namespace strata
