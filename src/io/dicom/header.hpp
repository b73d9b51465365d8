#pragma once
// One DICOM file's header, read through GDCM up to (not into) the pixel data: the tags a
// series is assembled from. Values are kept as the file has them (optional when absent);
// whether a series can do without one is decided by series.cpp, which names the missing tag.
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "strata/core/geometry.hpp"

namespace strata::io::detail::dicom {

// A data element's tag with its keyword, for messages: "ImagePositionPatient (0020,0032)".
struct TagName {
  std::uint16_t group, element;
  const char* keyword;
  std::string text() const;
};

// The tags read (PS3.6 keywords). Enhanced multi-frame files keep some of them inside the
// functional group sequences (header.cpp looks there too).
namespace tags {
inline constexpr TagName kMediaStorageSOPClassUID{0x0002, 0x0002, "MediaStorageSOPClassUID"};
inline constexpr TagName kSeriesDescription{0x0008, 0x103E, "SeriesDescription"};
inline constexpr TagName kSliceThickness{0x0018, 0x0050, "SliceThickness"};
inline constexpr TagName kSpacingBetweenSlices{0x0018, 0x0088, "SpacingBetweenSlices"};
inline constexpr TagName kSeriesInstanceUID{0x0020, 0x000E, "SeriesInstanceUID"};
inline constexpr TagName kImagePositionPatient{0x0020, 0x0032, "ImagePositionPatient"};
inline constexpr TagName kImageOrientationPatient{0x0020, 0x0037, "ImageOrientationPatient"};
inline constexpr TagName kPlanePositionSequence{0x0020, 0x9113, "PlanePositionSequence"};
inline constexpr TagName kPlaneOrientationSequence{0x0020, 0x9116, "PlaneOrientationSequence"};
inline constexpr TagName kSamplesPerPixel{0x0028, 0x0002, "SamplesPerPixel"};
inline constexpr TagName kNumberOfFrames{0x0028, 0x0008, "NumberOfFrames"};
inline constexpr TagName kRows{0x0028, 0x0010, "Rows"};
inline constexpr TagName kColumns{0x0028, 0x0011, "Columns"};
inline constexpr TagName kPixelSpacing{0x0028, 0x0030, "PixelSpacing"};
inline constexpr TagName kBitsAllocated{0x0028, 0x0100, "BitsAllocated"};
inline constexpr TagName kBitsStored{0x0028, 0x0101, "BitsStored"};
inline constexpr TagName kHighBit{0x0028, 0x0102, "HighBit"};
inline constexpr TagName kPixelRepresentation{0x0028, 0x0103, "PixelRepresentation"};
inline constexpr TagName kRescaleIntercept{0x0028, 0x1052, "RescaleIntercept"};
inline constexpr TagName kRescaleSlope{0x0028, 0x1053, "RescaleSlope"};
inline constexpr TagName kPixelMeasuresSequence{0x0028, 0x9110, "PixelMeasuresSequence"};
inline constexpr TagName kPixelValueTransformationSequence{0x0028, 0x9145, "PixelValueTransformationSequence"};
inline constexpr TagName kSharedFunctionalGroupsSequence{0x5200, 0x9229, "SharedFunctionalGroupsSequence"};
inline constexpr TagName kPerFrameFunctionalGroupsSequence{0x5200, 0x9230, "PerFrameFunctionalGroupsSequence"};
inline constexpr TagName kPixelData{0x7FE0, 0x0010, "PixelData"};
}  // namespace tags

// One frame of a file (a classic image has one): where it lies and how its values rescale.
struct Frame {
  std::optional<Vector3> position;  // ImagePositionPatient, mm
  double slope = 1, intercept = 0;  // RescaleSlope, RescaleIntercept
};

struct Header {
  std::filesystem::path file;
  std::string sop_class_uid, series_uid, series_description;
  std::optional<std::uint16_t> rows, columns, bits_allocated, bits_stored, high_bit, pixel_representation, samples_per_pixel;
  std::optional<std::array<double, 6>> orientation;    // ImageOrientationPatient: row, then column direction
  std::optional<std::array<double, 2>> pixel_spacing;  // PixelSpacing: between rows (y), then columns (x)
  std::optional<double> spacing_between_slices, slice_thickness;
  std::vector<Frame> frames;  // NumberOfFrames of them
  bool has_pixel_data = false;
  std::string transfer_syntax;  // its UID
  bool decodable = false;       // native little-endian or a codec GDCM decodes region by region
};

// The DICOM Part 10 signature: "DICM" after a 128-byte preamble.
inline constexpr std::size_t kMagicOffset = 128, kMagicBytes = 132;
bool has_dicom_magic(std::span<const std::byte> head);
bool file_has_dicom_magic(const std::filesystem::path& file);

// A DICOMDIR (the index CD exports put beside the images): a DICOM file that is no image.
bool is_directory_record(const Header& header);

/// @brief Reads the header of `file`, stopping before the pixel data (whose presence it notes,
/// and whose size it checks against the frames for native transfer syntaxes). Throws
/// FormatError(file, tag, ...) when GDCM cannot parse it or a value read is malformed.
Header read_header(const std::filesystem::path& file);

// Silences GDCM's warnings on stderr (reading reports problems through exceptions instead).
void quiet_gdcm();

}  // namespace strata::io::detail::dicom
