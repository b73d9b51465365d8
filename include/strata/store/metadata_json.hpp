#pragma once
/// @file
/// @brief Strict reading of the JSON metadata of a `.strata` file. Every accessor names the
/// field by its full path ("metadata.source.dims") and throws FormatError(file, field, what was
/// expected and what was found) instead of letting a JSON library exception, a silent
/// conversion (−5 read as an unsigned 4294967291, 2.7 as 2) or a missing key through.
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

namespace strata::store {

/// @brief Names a metadata field: the file it belongs to and its path inside the metadata.
struct MetadataField {
  std::string file;
  std::string path;  // "metadata.source.dims"
  /// The field `key` inside this one ("metadata.source" + "dims").
  MetadataField operator/(std::string_view key) const { return {file, path + "." + std::string(key)}; }
  /// Element `i` of this array field ("metadata.levels" + 2 -> "metadata.levels[2]").
  MetadataField operator[](std::size_t i) const { return {file, path + "[" + std::to_string(i) + "]"}; }
  /// Throws FormatError(file, path, problem).
  [[noreturn]] void fail(const std::string& problem) const;
};

/// @brief `object[key]`; throws "missing" when `object` is not an object or lacks `key`.
const nlohmann::json& json_member(const nlohmann::json& object, std::string_view key, const MetadataField& field);
/// @brief `value` as an object.
const nlohmann::json& json_object(const nlohmann::json& value, const MetadataField& field);
/// @brief An integer in [lo, hi] (a JSON number without fraction or exponent).
std::int64_t json_integer(const nlohmann::json& value, const MetadataField& field,
                          std::int64_t lo = std::numeric_limits<std::int64_t>::min(),
                          std::int64_t hi = std::numeric_limits<std::int64_t>::max());
/// @brief An unsigned integer up to `hi`.
std::uint64_t json_unsigned(const nlohmann::json& value, const MetadataField& field,
                            std::uint64_t hi = std::numeric_limits<std::uint64_t>::max());
/// @brief A finite number.
double json_number(const nlohmann::json& value, const MetadataField& field);
std::string json_string(const nlohmann::json& value, const MetadataField& field);
bool json_bool(const nlohmann::json& value, const MetadataField& field);
/// @brief An array of exactly `n` integers, each in [lo, hi].
std::vector<std::int64_t> json_integers(const nlohmann::json& value, std::size_t n, const MetadataField& field,
                                        std::int64_t lo, std::int64_t hi);
/// @brief An array of exactly `n` finite numbers.
std::vector<double> json_numbers(const nlohmann::json& value, std::size_t n, const MetadataField& field);
/// @brief An array of exactly `n` finite numbers > 0 (voxel spacings).
std::vector<double> json_positive_numbers(const nlohmann::json& value, std::size_t n, const MetadataField& field);

/// @brief `value` as JSON text for a message, cut to `limit` characters.
std::string json_excerpt(const nlohmann::json& value, std::size_t limit = 40);

}  // namespace strata::store
