#pragma once
// What the writer (encode_labels.cpp) and the reader (encoded_labels.cpp) of a Mixture Graph
// label file share: the metadata version, the id section names and the JSON form of extents.
#include <string>

#include <nlohmann/json.hpp>

#include "strata/core/extent.hpp"

namespace strata::mixture::detail {

inline constexpr int kFormatVersion = 1;

inline std::string level_section(int level) { return "ids_L" + std::to_string(level); }

inline nlohmann::json extent_json(const Extent& e) { return nlohmann::json::array({e.x, e.y, e.z}); }

}  // namespace strata::mixture::detail
