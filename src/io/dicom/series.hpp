#pragma once
// A DICOM series assembled from its files' headers: the slices in order along the slice
// normal, the sample type after rescaling, spacing and geometry. No pixel data is read here.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "io/dicom/header.hpp"
#include "strata/core/volume.hpp"

namespace strata::io::detail::dicom {

// How the stored samples of every slice are laid out (the same for all of them).
struct StoredSamples {
  std::uint16_t rows = 0, columns = 0, bits_allocated = 0, bits_stored = 0;
  bool is_signed = false;
  DType dtype = DType::u8;  // of bits_allocated and the sign, before rescaling
};

// One slice of the volume: a frame of a file, with its own rescale.
struct Slice {
  std::size_t header = 0;  // index into Series::headers
  std::int64_t frame = 0;  // of a multi-frame file
  Vector3 position{};
  double slope = 1, intercept = 0;
  std::string label;  // the file (and frame) in messages
};

struct Series {
  std::vector<Header> headers;
  std::vector<Slice> slices;  // sorted by position along the normal: z order
  StoredSamples stored;
  VolumeInfo info;  // dims, rescaled dtype, spacing, LPS geometry in mm
};

/// @brief The series of these headers (the files of one SeriesInstanceUID, or one file): checks
/// the tags every slice needs and that they agree, sorts the slices along the normal of
/// ImageOrientationPatient and refuses duplicate positions and uneven gaps, naming the files.
/// Throws FormatError(file, tag, ...).
Series assemble_series(std::vector<Header> headers);

/// @brief The headers of a folder's DICOM files (DICM signature; DICOMDIR skipped) of the series
/// `uid`, or of its only series when `uid` is empty; several series without a choice are refused
/// by a FormatError naming each UID with its description and slice count.
std::vector<Header> folder_series_headers(const std::filesystem::path& dir, const std::string& uid);

}  // namespace strata::io::detail::dicom
