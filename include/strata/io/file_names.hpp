#pragma once
/// @file
/// @brief The extensions of the files Strata names that are not volume formats (those are the
/// entries of the format registry, strata/io/formats.hpp): one constant each, so that every
/// extension is spelled in one place.
#include <string_view>

namespace strata::io {

/// @brief Strata's own container (docs/format.md): what `compress` and `labels encode` write.
inline constexpr std::string_view kStrataExtension = ".strata";
/// @brief The images `render` and `demo` write.
inline constexpr std::string_view kPngExtension = ".png";
/// @brief JSON documents: raw sidecars, reports, statistics, colour maps.
inline constexpr std::string_view kJsonExtension = ".json";
/// @brief Tables of segment names (mixture/label_names.hpp): comma-separated, and
/// whitespace-separated text (MRIcron keeps `<atlas>.nii.txt` beside `<atlas>.nii.gz`).
inline constexpr std::string_view kCsvExtension = ".csv";
inline constexpr std::string_view kTextExtension = ".txt";
/// @brief The gzip suffix of compressed files (`.nii.gz`, `.raw.gz`).
inline constexpr std::string_view kGzSuffix = ".gz";
/// @brief What an output in progress is called until it is complete (`<name>.tmp`, renamed into
/// place: AtomicOutputFile, the TIFF writers).
inline constexpr std::string_view kTemporarySuffix = ".tmp";

}  // namespace strata::io
