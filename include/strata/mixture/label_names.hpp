#pragma once
/// @file
/// @brief Names of segments (an atlas's region names, a proofreading table's cell types): read
/// from the tables such files come with, stored in the label file's metadata
/// (`metadata.label_names`, docs/format.md) so they travel with it, and searched in the viewer.
///
/// Table formats (by extension; lines starting with '#' and blank lines are skipped):
///   .json  {"17": "Precentral_L", ...}  (label values as decimal keys)
///   .csv   label,name[,...]            (a first line whose label is not a number is a header;
///                                       a name may be "quoted", with "" for a quote)
///   other  label name [...]            (whitespace-separated: MRIcron's `.nii.txt`, ITK-SNAP
///                                       and FreeSurfer LUTs; the name is the second field)
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

namespace strata::mixture {

using LabelNames = std::map<std::int64_t, std::string>;

/// @brief Longest name kept (a longer one is refused, naming the file and line).
inline constexpr std::size_t kMaxLabelNameBytes = 256;

/// @brief Reads a names table. Throws Error naming the file, and the line or key, for a label
/// that is not an integer, a missing or over-long name, or a label named twice.
LabelNames load_label_names(const std::filesystem::path& file);

/// @brief The names as metadata JSON: {"<label>": "name", ...}.
nlohmann::json label_names_json(const LabelNames& names);

/// @brief Names from metadata JSON; throws FormatError(file, "metadata.label_names[.<key>]", ...)
/// unless it is an object of decimal label keys and string names.
LabelNames label_names_from_json(const nlohmann::json& j, const std::string& file);

/// @brief The names table MRIcron keeps beside an atlas: `<input without .gz>.txt`
/// (aal.nii.gz -> aal.nii.txt), when that file exists.
std::optional<std::filesystem::path> sidecar_label_names(const std::filesystem::path& input);

}  // namespace strata::mixture
