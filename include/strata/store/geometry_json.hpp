#pragma once
/// @file
/// @brief A volume's Geometry in the JSON metadata of a `.strata` file ("source.geometry"):
/// written only when it says something (Geometry::is_default() is false), read strictly.
///
///     "geometry": {"origin": [x, y, z], "direction": [9 numbers, row-major],
///                  "space": "RAS" | "LPS" | "unspecified", "unit": "mm",
///                  "format_fields": {"nifti.qform_code": "1", ...}}
#include <nlohmann/json.hpp>

#include "strata/core/geometry.hpp"
#include "strata/store/metadata_json.hpp"

namespace strata::store {

/// @brief The JSON object above.
nlohmann::json geometry_to_json(const Geometry& geometry);
/// @brief The geometry in `parent[key]`, or the default geometry when `parent` has no such key.
/// Throws FormatError naming `field / key / ...` on a malformed entry (wrong counts, non-finite
/// numbers, a direction column that is not of unit length, an unknown space).
Geometry geometry_from_json(const nlohmann::json& parent, const MetadataField& parent_field,
                            std::string_view key = "geometry");

}  // namespace strata::store
