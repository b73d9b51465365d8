#include "strata/core/geometry.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <utility>

#include "strata/core/error.hpp"
#include "strata/core/volume.hpp"

namespace strata {

std::string_view world_space_name(WorldSpace space) {
  switch (space) {
    case WorldSpace::unspecified: return "unspecified";
    case WorldSpace::ras: return "RAS";
    case WorldSpace::lps: return "LPS";
  }
  return "?";
}

namespace {
std::string lower(std::string_view text) {
  std::string out(text);
  std::transform(out.begin(), out.end(), out.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return out;
}
}  // namespace

WorldSpace parse_world_space(std::string_view name, std::string_view context) {
  const std::string n = lower(name);
  if (n == "unspecified" || n.empty()) return WorldSpace::unspecified;
  if (n == "ras") return WorldSpace::ras;
  if (n == "lps") return WorldSpace::lps;
  throw Error(std::string(context) + ": unknown world space '" + std::string(name) +
              "' (expected RAS, LPS or unspecified)");
}

bool Geometry::is_default() const { return *this == Geometry{}; }

Matrix4 index_to_world(const Geometry& g, const Spacing& spacing) {
  const std::array<double, 3> s{spacing.x, spacing.y, spacing.z};
  Matrix4 m{};
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) m[r][c] = g.direction[r][c] * s[c];
    m[r][3] = g.origin[r];
  }
  m[3] = {0.0, 0.0, 0.0, 1.0};
  return m;
}

Geometry geometry_from_affine(const Matrix4& affine, Spacing& spacing, WorldSpace space, std::string_view context) {
  Geometry g;
  g.space = space;
  std::array<double, 3> s{};
  for (int c = 0; c < 3; ++c) {
    const double norm = std::sqrt(affine[0][c] * affine[0][c] + affine[1][c] * affine[1][c] + affine[2][c] * affine[2][c]);
    if (!(norm > 0.0) || !std::isfinite(norm))
      throw Error(std::string(context) + ": axis " + std::to_string(c) + " of the affine has length " +
                  std::to_string(norm) + " (expected a finite length > 0)");
    s[c] = norm;
    for (int r = 0; r < 3; ++r) g.direction[r][c] = affine[r][c] / norm;
  }
  for (int r = 0; r < 3; ++r) {
    if (!std::isfinite(affine[r][3])) throw Error(std::string(context) + ": the affine's translation is not finite");
    g.origin[r] = affine[r][3];
  }
  spacing = {s[0], s[1], s[2]};
  return g;
}

Geometry in_world_space(const Geometry& geometry, WorldSpace space) {
  if (geometry.space == space || geometry.space == WorldSpace::unspecified || space == WorldSpace::unspecified)
    return geometry;
  // RAS <-> LPS: x and y change sign, z does not.
  Geometry g = geometry;
  g.space = space;
  for (int r = 0; r < 2; ++r) {
    g.origin[r] = -g.origin[r];
    for (int c = 0; c < 3; ++c) g.direction[r][c] = -g.direction[r][c];
  }
  return g;
}

Geometry level_geometry(const Geometry& level0, const Spacing& level0_spacing, int level) {
  if (level == 0) return level0;
  Geometry g = level0;
  g.format_fields.clear();
  // The centre of level-0 voxels [0, 2^L) lies (2^L - 1) / 2 voxels from voxel 0's centre.
  const double shift = (std::ldexp(1.0, level) - 1.0) / 2.0;
  const std::array<double, 3> s{level0_spacing.x, level0_spacing.y, level0_spacing.z};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) g.origin[r] += level0.direction[r][c] * s[c] * shift;
  return g;
}

Geometry box_geometry(const Geometry& geometry, const Spacing& spacing, const std::array<std::int64_t, 3>& first) {
  if (first == std::array<std::int64_t, 3>{0, 0, 0}) return geometry;
  Geometry g = geometry;
  g.format_fields.clear();
  const std::array<double, 3> s{spacing.x, spacing.y, spacing.z};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) g.origin[r] += geometry.direction[r][c] * s[c] * double(first[c]);
  return g;
}

bool affines_match(const Matrix4& a, const Matrix4& b, double tolerance) {
  double scale = 0.0, diff = 0.0;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) {
      scale = std::max({scale, std::abs(a[r][c]), std::abs(b[r][c])});
      diff = std::max(diff, std::abs(a[r][c] - b[r][c]));
    }
  return diff <= tolerance * std::max(scale, 1.0);
}

std::string canonical_length_unit(std::string_view unit) {
  static const std::array<std::pair<std::string_view, std::string_view>, 19> kUnits{{
      {"m", "m"},           {"meter", "m"},        {"metre", "m"},
      {"cm", "cm"},         {"centimeter", "cm"},  {"mm", "mm"},
      {"millimeter", "mm"}, {"millimetre", "mm"},  {"um", "um"},
      {"µm", "um"},         {"micron", "um"},      {"micrometer", "um"},
      {"micrometre", "um"}, {"nm", "nm"},          {"nanometer", "nm"},
      {"nanometre", "nm"},  {"angstrom", "angstrom"}, {"Å", "angstrom"},
      {"å", "angstrom"},
  }};
  const std::string n = lower(unit);
  for (const auto& [name, canonical] : kUnits)
    if (n == name) return std::string(canonical);
  return {};
}

double metres_per_unit(std::string_view unit) {
  static const std::array<std::pair<std::string_view, double>, 6> kScale{
      {{"m", 1.0}, {"cm", 1e-2}, {"mm", 1e-3}, {"um", 1e-6}, {"nm", 1e-9}, {"angstrom", 1e-10}}};
  const std::string canonical = canonical_length_unit(unit);
  for (const auto& [name, scale] : kScale)
    if (name == canonical) return scale;
  return 0.0;
}

}  // namespace strata
