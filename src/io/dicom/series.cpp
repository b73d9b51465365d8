// Assembling a DICOM series (PS3.3 C.7.6.2, Image Plane module) from its headers: slices
// sorted by ImagePositionPatient projected on the normal of ImageOrientationPatient, the z
// spacing from the distance between them (SliceThickness is the thickness of the slab each
// slice integrates, not where slices lie), x/y spacing from PixelSpacing (row spacing first),
// and the LPS geometry the DICOM patient coordinate system defines.
#include "io/dicom/series.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include <fmt/format.h>

#include "io/io_detail.hpp"
#include "strata/core/error.hpp"
#include "strata/core/text.hpp"

namespace strata::io::detail::dicom {

namespace {

namespace fs = std::filesystem;

// Slices whose gaps differ from the mean gap by more than this fraction of it are refused, as
// are slices closer than it (duplicates): DS values carry a few significant digits at most.
constexpr double kGapTolerance = 0.01;
// Direction cosines are DS values too: unit length and orthogonality to this.
constexpr double kCosineTolerance = 1e-3;

double dot(const Vector3& a, const Vector3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vector3 cross(const Vector3& a, const Vector3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
Vector3 minus(const Vector3& a, const Vector3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vector3 scaled(const Vector3& a, double s) { return {a[0] * s, a[1] * s, a[2] * s}; }
Vector3 plus(const Vector3& a, const Vector3& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }

template <class T>
const T& required(const std::optional<T>& value, const Header& h, const TagName& tag) {
  if (!value) throw FormatError(h.file.string(), tag.text(), "missing");
  return *value;
}

DType stored_dtype(std::uint16_t bits, bool is_signed, const Header& h) {
  switch (bits) {
    case 8: return is_signed ? DType::i8 : DType::u8;
    case 16: return is_signed ? DType::i16 : DType::u16;
    case 32: return is_signed ? DType::i32 : DType::u32;
    default:
      throw FormatError(h.file.string(), tags::kBitsAllocated.text(), fmt::format("is {}; expected 8, 16 or 32", bits));
  }
}

StoredSamples stored_samples(const Header& h) {
  StoredSamples s;
  s.rows = required(h.rows, h, tags::kRows);
  s.columns = required(h.columns, h, tags::kColumns);
  if (s.rows == 0 || s.columns == 0)
    throw FormatError(h.file.string(), fmt::format("{}/{}", tags::kRows.text(), tags::kColumns.text()), "is 0");
  s.bits_allocated = required(h.bits_allocated, h, tags::kBitsAllocated);
  s.bits_stored = h.bits_stored.value_or(s.bits_allocated);
  const std::uint16_t representation = required(h.pixel_representation, h, tags::kPixelRepresentation);
  if (representation > 1)
    throw FormatError(h.file.string(), tags::kPixelRepresentation.text(),
                      fmt::format("is {}; expected 0 (unsigned) or 1 (signed)", representation));
  s.is_signed = representation == 1;
  s.dtype = stored_dtype(s.bits_allocated, s.is_signed, h);
  if (s.bits_stored == 0 || s.bits_stored > s.bits_allocated)
    throw FormatError(h.file.string(), tags::kBitsStored.text(),
                      fmt::format("is {}; expected 1 to BitsAllocated ({})", s.bits_stored, s.bits_allocated));
  // GDCM moves the stored bits when the high bit is elsewhere: only the usual layout is read.
  if (const std::uint16_t high_bit = required(h.high_bit, h, tags::kHighBit); high_bit + 1 != s.bits_stored)
    throw FormatError(h.file.string(), tags::kHighBit.text(),
                      fmt::format("is {}; only BitsStored - 1 ({}) is read", high_bit, s.bits_stored - 1));
  if (const std::uint16_t samples = h.samples_per_pixel.value_or(1); samples != 1)
    throw FormatError(h.file.string(), tags::kSamplesPerPixel.text(),
                      fmt::format("is {}; only grey-scale images (1 sample per pixel) are read", samples));
  if (!h.has_pixel_data) throw FormatError(h.file.string(), tags::kPixelData.text(), "missing");
  if (!h.decodable)
    throw FormatError(h.file.string(), "TransferSyntaxUID (0002,0010)",
                      fmt::format("is {}; GDCM decodes native little-endian, RLE, JPEG, JPEG-LS and JPEG 2000 pixel data "
                                  "here, not this one",
                                  h.transfer_syntax));
  return s;
}

void check_same_samples(const StoredSamples& s, const StoredSamples& first, const Header& h, const Header& first_header) {
  const auto check = [&](const TagName& tag, std::uint64_t here, std::uint64_t there) {
    if (here != there)
      throw FormatError(h.file.string(), tag.text(),
                        fmt::format("is {}, but {} has {}", here, first_header.file.filename().string(), there));
  };
  check(tags::kRows, s.rows, first.rows);
  check(tags::kColumns, s.columns, first.columns);
  check(tags::kBitsAllocated, s.bits_allocated, first.bits_allocated);
  check(tags::kBitsStored, s.bits_stored, first.bits_stored);
  check(tags::kPixelRepresentation, s.is_signed, first.is_signed);
}

// The row direction, column direction and normal (their cross product), all unit length.
Matrix3 plane_axes(const Header& h) {
  const auto& o = required(h.orientation, h, tags::kImageOrientationPatient);
  const Vector3 row{o[0], o[1], o[2]}, column{o[3], o[4], o[5]};
  const double row_norm = std::sqrt(dot(row, row)), column_norm = std::sqrt(dot(column, column));
  if (std::abs(row_norm - 1) > kCosineTolerance || std::abs(column_norm - 1) > kCosineTolerance ||
      std::abs(dot(row, column)) > kCosineTolerance)
    throw FormatError(h.file.string(), tags::kImageOrientationPatient.text(),
                      fmt::format("is {}\\{}\\{}\\{}\\{}\\{}; expected two orthogonal unit vectors", o[0], o[1], o[2], o[3],
                                  o[4], o[5]));
  const Vector3 r = scaled(row, 1 / row_norm), c = scaled(column, 1 / column_norm);
  Vector3 n = cross(r, c);
  n = scaled(n, 1 / std::sqrt(dot(n, n)));
  return {r, c, n};
}

void check_same_axes(const Matrix3& axes, const Matrix3& first, const Header& h, const Header& first_header) {
  for (std::size_t a = 0; a < 2; ++a)
    for (std::size_t k = 0; k < 3; ++k)
      if (std::abs(axes[a][k] - first[a][k]) > kCosineTolerance)
        throw FormatError(h.file.string(), tags::kImageOrientationPatient.text(),
                          fmt::format("differs from {}'s: the slices are not parallel",
                                      first_header.file.filename().string()));
}

// PixelSpacing: (row spacing = y, column spacing = x), positive and the same in every file.
std::array<double, 2> pixel_spacing(const Header& h, const std::array<double, 2>* first, const Header& first_header) {
  const auto& ps = required(h.pixel_spacing, h, tags::kPixelSpacing);
  if (!(ps[0] > 0 && ps[1] > 0))
    throw FormatError(h.file.string(), tags::kPixelSpacing.text(), fmt::format("is {}\\{}; expected positive", ps[0], ps[1]));
  if (first && (std::abs(ps[0] - (*first)[0]) > 1e-6 * (*first)[0] || std::abs(ps[1] - (*first)[1]) > 1e-6 * (*first)[1]))
    throw FormatError(h.file.string(), tags::kPixelSpacing.text(),
                      fmt::format("is {}\\{}, but {} has {}\\{}", ps[0], ps[1], first_header.file.filename().string(),
                                  (*first)[0], (*first)[1]));
  return ps;
}

std::string slice_label(const Header& h, std::size_t frame) {
  return h.frames.size() > 1 ? fmt::format("{} frame {}", h.file.string(), frame) : h.file.string();
}

// A multi-frame file whose frames share one position (a legacy multi-frame object) has them
// SpacingBetweenSlices apart along the normal, when it says so.
void spread_shared_positions(Header& h, const Vector3& normal) {
  if (h.frames.size() < 2 || !h.spacing_between_slices || *h.spacing_between_slices <= 0 || !h.frames[0].position) return;
  for (const Frame& f : h.frames)
    if (f.position != h.frames[0].position) return;
  for (std::size_t k = 1; k < h.frames.size(); ++k)
    h.frames[k].position = plus(*h.frames[0].position, scaled(normal, double(k) * *h.spacing_between_slices));
}

std::vector<Slice> slices_of(std::vector<Header>& headers, const Vector3& normal) {
  std::vector<Slice> slices;
  for (std::size_t i = 0; i < headers.size(); ++i) {
    Header& h = headers[i];
    spread_shared_positions(h, normal);
    for (std::size_t f = 0; f < h.frames.size(); ++f) {
      const Frame& frame = h.frames[f];
      if (!(frame.slope != 0))
        throw FormatError(slice_label(h, f), tags::kRescaleSlope.text(), "is 0");
      slices.push_back({i, std::int64_t(f), required(frame.position, h, tags::kImagePositionPatient), frame.slope,
                        frame.intercept, slice_label(h, f)});
    }
  }
  std::stable_sort(slices.begin(), slices.end(),
                   [&](const Slice& a, const Slice& b) { return dot(a.position, normal) < dot(b.position, normal); });
  return slices;
}

// The distance between consecutive slices along the normal, after refusing duplicates, gaps
// that differ from the smallest (a missing slice) and slices off the normal through the first
// (a tilted gantry).
double slice_gap(const std::vector<Slice>& slices, const Vector3& normal) {
  const auto along = [&](const Slice& s) { return dot(s.position, normal); };
  const double mean = (along(slices.back()) - along(slices.front())) / double(slices.size() - 1);
  const std::string field = tags::kImagePositionPatient.text();
  double smallest = std::numeric_limits<double>::infinity();
  for (std::size_t i = 1; i < slices.size(); ++i) {
    const double gap = along(slices[i]) - along(slices[i - 1]);
    if (!(gap > kGapTolerance * mean))
      throw FormatError(slices[i].label, field,
                        fmt::format("is at the position of {} along the slice normal ({:.6g} mm apart): a duplicate "
                                    "slice",
                                    slices[i - 1].label, gap));
    smallest = std::min(smallest, gap);
  }
  const double tolerance = kGapTolerance * smallest;
  for (std::size_t i = 1; i < slices.size(); ++i) {
    const Slice &a = slices[i - 1], &b = slices[i];
    const double gap = along(b) - along(a);
    if (gap - smallest > tolerance)
      throw FormatError(b.label, field,
                        fmt::format("lies {:.6g} mm after {}, but other slices are {:.6g} mm apart: uneven gaps (a "
                                    "missing slice?)",
                                    gap, a.label, smallest));
    const Vector3 offset = minus(b.position, slices.front().position);
    const Vector3 in_plane = minus(offset, scaled(normal, dot(offset, normal)));
    if (std::sqrt(dot(in_plane, in_plane)) > tolerance)
      throw FormatError(b.label, field,
                        fmt::format("lies {:.6g} mm off the slice normal through {} (a tilted gantry or sheared stack "
                                    "is not read)",
                                    std::sqrt(dot(in_plane, in_plane)), slices.front().label));
  }
  return mean;
}

// A single slice has no neighbour: its slab's spacing or thickness says how thick it is.
double single_slice_gap(const Header& h) {
  if (h.spacing_between_slices && *h.spacing_between_slices > 0) return *h.spacing_between_slices;
  if (h.slice_thickness && *h.slice_thickness > 0) return *h.slice_thickness;
  return 1.0;
}

// The sample type of stored values after rescaling: the stored type when nothing changes them;
// the smallest integer type holding every stored value plus every intercept when the slopes
// are 1 and the intercepts integers (CT's 12-bit values with intercept -1024: int16); else float32.
DType rescaled_dtype(const StoredSamples& s, const std::vector<Slice>& slices) {
  double lowest_intercept = 0, highest_intercept = 0;
  bool integral = true, identity = true;
  for (const Slice& slice : slices) {
    integral = integral && slice.slope == 1 && slice.intercept == std::floor(slice.intercept) &&
               std::abs(slice.intercept) < 0x1p52;
    identity = identity && slice.slope == 1 && slice.intercept == 0;
    lowest_intercept = std::min(lowest_intercept, slice.intercept);
    highest_intercept = std::max(highest_intercept, slice.intercept);
  }
  if (identity) return s.dtype;
  if (!integral) return DType::f32;
  const double stored_min = s.is_signed ? -std::ldexp(1.0, s.bits_stored - 1) : 0.0;
  const double stored_max = s.is_signed ? std::ldexp(1.0, s.bits_stored - 1) - 1 : std::ldexp(1.0, s.bits_stored) - 1;
  const double lo = stored_min + lowest_intercept, hi = stored_max + highest_intercept;
  for (DType t : {DType::u8, DType::i8, DType::u16, DType::i16, DType::u32, DType::i32, DType::i64}) {
    const auto [min, max] = visit_dtype(t, [](auto tag) {
      using T = decltype(tag);
      return std::pair<double, double>(double(std::numeric_limits<T>::lowest()), double(std::numeric_limits<T>::max()));
    });
    if (lo >= min && hi <= max) return t;
  }
  return DType::f32;
}

Geometry lps_geometry(const Matrix3& axes, const Vector3& origin) {
  Geometry g;
  g.origin = origin;
  for (std::size_t axis = 0; axis < 3; ++axis)
    for (std::size_t k = 0; k < 3; ++k) g.direction[k][axis] = axes[axis][k];
  g.space = WorldSpace::lps;
  g.unit = "mm";
  return g;
}

}  // namespace

Series assemble_series(std::vector<Header> headers) {
  Series series;
  const Header& first = headers.front();
  series.stored = stored_samples(first);
  const Matrix3 axes = plane_axes(first);
  const std::array<double, 2> spacing = pixel_spacing(first, nullptr, first);
  for (const Header& h : headers) {
    check_same_samples(stored_samples(h), series.stored, h, first);
    check_same_axes(plane_axes(h), axes, h, first);
    pixel_spacing(h, &spacing, first);
  }
  series.slices = slices_of(headers, axes[2]);
  const double gap = series.slices.size() > 1 ? slice_gap(series.slices, axes[2]) : single_slice_gap(headers.front());
  VolumeInfo& info = series.info;
  info.dims = {series.stored.columns, series.stored.rows, std::int64_t(series.slices.size())};
  info.dtype = rescaled_dtype(series.stored, series.slices);
  info.spacing = {spacing[1], spacing[0], gap};
  info.geometry = lps_geometry(axes, series.slices.front().position);
  checked_volume_bytes(info, headers.front().file.string(), fmt::format("{}/{}", tags::kRows.text(), tags::kColumns.text()));
  series.headers = std::move(headers);
  return series;
}

std::vector<Header> folder_series_headers(const fs::path& dir, const std::string& uid) {
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(dir))
    if (entry.is_regular_file() && !entry.path().filename().string().starts_with(".") &&
        file_has_dicom_magic(entry.path()))
      files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  std::map<std::string, std::vector<Header>> by_series;
  for (const fs::path& file : files) {
    Header h = read_header(file);
    if (is_directory_record(h)) continue;
    if (h.series_uid.empty()) throw FormatError(file.string(), tags::kSeriesInstanceUID.text(), "missing");
    by_series[h.series_uid].push_back(std::move(h));
  }
  if (by_series.empty())
    throw FormatError(dir.string(), "DICOM files", "the folder has no DICOM images (files with \"DICM\" at byte 128)");
  std::vector<std::string> listing;
  for (const auto& [series_uid, headers] : by_series) {
    std::size_t slices = 0;
    for (const Header& h : headers) slices += h.frames.size();
    listing.push_back(fmt::format("{} \"{}\" ({} slices)", series_uid, headers.front().series_description, slices));
  }
  if (!uid.empty()) {
    const auto found = by_series.find(uid);
    if (found == by_series.end())
      throw FormatError(dir.string(), tags::kSeriesInstanceUID.text(),
                        fmt::format("no series {} in the folder; it holds {}", uid, joined_list(listing, "and")));
    return std::move(found->second);
  }
  if (by_series.size() > 1)
    throw FormatError(dir.string(), tags::kSeriesInstanceUID.text(),
                      fmt::format("the folder holds {} series: {}; choose one by its UID (ReadOptions::dataset, or the "
                                  "path <folder>:<UID>)",
                                  by_series.size(), joined_list(listing, "and")));
  return std::move(by_series.begin()->second);
}

}  // namespace strata::io::detail::dicom
