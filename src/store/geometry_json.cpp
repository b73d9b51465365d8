#include "strata/store/geometry_json.hpp"

#include <cmath>
#include <string>

#include "strata/core/error.hpp"

namespace strata::store {

nlohmann::json geometry_to_json(const Geometry& geometry) {
  nlohmann::json direction = nlohmann::json::array();
  for (const Vector3& row : geometry.direction)
    for (double v : row) direction.push_back(v);
  nlohmann::json j{{"origin", geometry.origin},
                   {"direction", direction},
                   {"space", std::string(world_space_name(geometry.space))},
                   {"unit", geometry.unit}};
  if (!geometry.format_fields.empty()) j["format_fields"] = geometry.format_fields;
  return j;
}

namespace {

// Each column of a direction matrix is a unit vector; a looser check would let a scaled matrix
// (spacing folded in twice) through.
constexpr double kUnitTolerance = 1e-6;

void check_unit_columns(const Matrix3& d, const MetadataField& field) {
  for (int c = 0; c < 3; ++c) {
    const double norm = std::sqrt(d[0][c] * d[0][c] + d[1][c] * d[1][c] + d[2][c] * d[2][c]);
    if (std::abs(norm - 1.0) > kUnitTolerance)
      field.fail("column " + std::to_string(c) + " has length " + std::to_string(norm) + " (expected unit vectors)");
  }
}

}  // namespace

Geometry geometry_from_json(const nlohmann::json& parent, const MetadataField& parent_field, std::string_view key) {
  Geometry g;
  if (!parent.is_object() || !parent.contains(key)) return g;
  const MetadataField field = parent_field / key;
  const nlohmann::json& j = json_object(parent[std::string(key)], field);
  const auto origin = json_numbers(json_member(j, "origin", field), 3, field / "origin");
  g.origin = {origin[0], origin[1], origin[2]};
  const auto direction = json_numbers(json_member(j, "direction", field), 9, field / "direction");
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) g.direction[r][c] = direction[std::size_t(r * 3 + c)];
  check_unit_columns(g.direction, field / "direction");
  const std::string space = json_string(json_member(j, "space", field), field / "space");
  try {
    g.space = parse_world_space(space, (field / "space").path);
  } catch (const Error&) {
    (field / "space").fail("expected \"RAS\", \"LPS\" or \"unspecified\", found \"" + space + "\"");
  }
  g.unit = json_string(json_member(j, "unit", field), field / "unit");
  if (j.contains("format_fields")) {
    const MetadataField ff = field / "format_fields";
    for (const auto& [name, value] : json_object(j["format_fields"], ff).items())
      g.format_fields[name] = json_string(value, ff / name);
  }
  return g;
}

}  // namespace strata::store
