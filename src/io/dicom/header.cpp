// Reading one DICOM file's header with GDCM (gdcm::Reader::ReadUpToTag stops before the pixel
// data, skipping its value) and taking the values series.cpp needs out of the data set.
//
// Tags read (PS3.3 / PS3.6; VR, where). Enhanced multi-frame files (PS3.3 C.7.6.16) keep the
// plane and pixel tags in functional groups: the shared group's item first, else each frame's.
// | tag         | keyword                          | VR | use                                       |
// | ----------- | -------------------------------- | -- | ----------------------------------------- |
// | (0002,0002) | MediaStorageSOPClassUID          | UI | DICOMDIR files are skipped                |
// | (0002,0010) | TransferSyntaxUID                | UI | native, or a codec GDCM decodes           |
// | (0008,103E) | SeriesDescription                | LO | named when a folder holds several series  |
// | (0018,0050) | SliceThickness                   | DS | z spacing of a single slice only          |
// | (0018,0088) | SpacingBetweenSlices             | DS | z spacing of a single slice; frames apart |
// | (0020,000E) | SeriesInstanceUID                | UI | groups a folder's files                   |
// | (0020,0032) | ImagePositionPatient             | DS | centre of the first voxel (LPS, mm)       |
// | (0020,0037) | ImageOrientationPatient          | DS | row and column direction cosines          |
// | (0028,0002) | SamplesPerPixel                  | US | 1 (grey-scale) only                       |
// | (0028,0008) | NumberOfFrames                   | IS | frames of a multi-frame file              |
// | (0028,0010) | Rows, (0028,0011) Columns        | US | dims y, x                                 |
// | (0028,0030) | PixelSpacing                     | DS | row spacing (y), then column spacing (x)  |
// | (0028,0100) | BitsAllocated                    | US | 8, 16 or 32                               |
// | (0028,0101) | BitsStored                       | US | high bits above it are masked             |
// | (0028,0102) | HighBit                          | US | BitsStored - 1 (GDCM shifts otherwise)    |
// | (0028,0103) | PixelRepresentation              | US | 0 unsigned, 1 two's complement            |
// | (0028,1052) | RescaleIntercept, (0028,1053) RescaleSlope | DS | value = stored x slope + intercept |
// | (5200,9229) | SharedFunctionalGroupsSequence   | SQ | PlaneOrientation (0020,9116), PixelMeasures (0028,9110), PixelValueTransformation (0028,9145) |
// | (5200,9230) | PerFrameFunctionalGroupsSequence | SQ | PlanePosition (0020,9113) of each frame   |
// | (7FE0,0010) | PixelData                        | OB/OW | present; native: long enough           |
#include "io/dicom/header.hpp"
#include "io/dicom/structure.hpp"

#include <gdcmDataSet.h>
#include <gdcmReader.h>
#include <gdcmSequenceOfItems.h>
#include <gdcmTrace.h>
#include <gdcmTransferSyntax.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <mutex>

#include <fmt/format.h>

#include "strata/core/error.hpp"

namespace strata::io::detail::dicom {

namespace {

namespace fs = std::filesystem;

gdcm::Tag tag_of(const TagName& t) { return gdcm::Tag(t.group, t.element); }

// A data element's value as text, without the trailing spaces and NULs that pad it to even length.
std::optional<std::string> text_value(const gdcm::DataSet& ds, const TagName& t) {
  if (!ds.FindDataElement(tag_of(t))) return std::nullopt;
  const gdcm::ByteValue* value = ds.GetDataElement(tag_of(t)).GetByteValue();
  if (!value || value->GetLength() == 0) return std::nullopt;
  std::string text(value->GetPointer(), value->GetLength());
  while (!text.empty() && (text.back() == ' ' || text.back() == '\0')) text.pop_back();
  return text;
}

// A decimal string (DS) or integer string (IS) value: numbers separated by backslashes.
class NumberParser {
 public:
  NumberParser(const fs::path& file, const TagName& t) : file_(file.string()), tag_(t) {}

  std::optional<std::vector<double>> read(const gdcm::DataSet& ds, std::size_t expected) const {
    const auto text = text_value(ds, tag_);
    if (!text) return std::nullopt;
    std::vector<double> numbers;
    std::size_t start = 0;
    while (numbers.size() <= expected) {
      const std::size_t end = std::min(text->find('\\', start), text->size());
      numbers.push_back(parse(std::string_view(*text).substr(start, end - start), *text));
      if (end == text->size()) break;
      start = end + 1;
    }
    if (numbers.size() != expected)
      throw FormatError(file_, tag_.text(), fmt::format("is \"{}\"; expected {} number(s)", *text, expected));
    return numbers;
  }

 private:
  double parse(std::string_view item, const std::string& whole) const {
    while (!item.empty() && item.front() == ' ') item.remove_prefix(1);
    while (!item.empty() && item.back() == ' ') item.remove_suffix(1);
    if (!item.empty() && item.front() == '+') item.remove_prefix(1);
    double value = 0;
    const auto [end, error] = std::from_chars(item.data(), item.data() + item.size(), value);
    if (item.empty() || error != std::errc() || end != item.data() + item.size() || !std::isfinite(value))
      throw FormatError(file_, tag_.text(), fmt::format("is \"{}\"; expected decimal numbers", whole));
    return value;
  }

  std::string file_;
  TagName tag_;
};

std::optional<double> one_number(const gdcm::DataSet& ds, const TagName& t, const fs::path& file) {
  const auto v = NumberParser(file, t).read(ds, 1);
  return v ? std::optional<double>((*v)[0]) : std::nullopt;
}

template <std::size_t N>
std::optional<std::array<double, N>> numbers(const gdcm::DataSet& ds, const TagName& t, const fs::path& file) {
  const auto v = NumberParser(file, t).read(ds, N);
  if (!v) return std::nullopt;
  std::array<double, N> out{};
  std::copy(v->begin(), v->end(), out.begin());
  return out;
}

// An unsigned short (US) value, little-endian (the transfer syntaxes read are all little-endian).
std::optional<std::uint16_t> us_value(const gdcm::DataSet& ds, const TagName& t, const fs::path& file) {
  if (!ds.FindDataElement(tag_of(t))) return std::nullopt;
  const gdcm::ByteValue* value = ds.GetDataElement(tag_of(t)).GetByteValue();
  if (!value || value->GetLength() == 0) return std::nullopt;
  if (value->GetLength() != 2)
    throw FormatError(file.string(), t.text(), fmt::format("is {} bytes long; expected one 2-byte US value", value->GetLength()));
  const auto* b = reinterpret_cast<const unsigned char*>(value->GetPointer());
  return std::uint16_t(b[0] | (b[1] << 8));
}

// The items of a sequence (SQ) element; empty when absent. The pointer keeps them alive.
gdcm::SmartPointer<gdcm::SequenceOfItems> sequence(const gdcm::DataSet& ds, const TagName& t) {
  if (!ds.FindDataElement(tag_of(t))) return nullptr;
  return ds.GetDataElement(tag_of(t)).GetValueAsSQ();
}

// The data set of item `index` (from 1) of a sequence, or null.
const gdcm::DataSet* item(const gdcm::SmartPointer<gdcm::SequenceOfItems>& sq, std::size_t index) {
  if (!sq || index == 0 || sq->GetNumberOfItems() < index) return nullptr;
  return &sq->GetItem(index).GetNestedDataSet();
}

// The first item of `macro` within a functional group item, or null.
const gdcm::DataSet* macro_item(const gdcm::DataSet* group, const TagName& macro,
                                gdcm::SmartPointer<gdcm::SequenceOfItems>& keep) {
  if (!group) return nullptr;
  keep = sequence(*group, macro);
  return item(keep, 1);
}

// Where a multi-frame file keeps a functional group macro for frame `frame` (from 0): the
// shared item, else the frame's own; falls back to the top-level data set (classic files).
class FunctionalGroups {
 public:
  explicit FunctionalGroups(const gdcm::DataSet& ds)
      : top_(ds), shared_(sequence(ds, tags::kSharedFunctionalGroupsSequence)),
        per_frame_(sequence(ds, tags::kPerFrameFunctionalGroupsSequence)) {}

  const gdcm::DataSet& find(const TagName& macro, std::size_t frame, const TagName& wanted) {
    for (const gdcm::DataSet* group : {item(shared_, 1), item(per_frame_, frame + 1)})
      if (const gdcm::DataSet* m = macro_item(group, macro, keep_); m && m->FindDataElement(tag_of(wanted))) return *m;
    return top_;
  }
  std::size_t per_frame_items() const { return per_frame_ ? per_frame_->GetNumberOfItems() : 0; }

 private:
  const gdcm::DataSet& top_;
  gdcm::SmartPointer<gdcm::SequenceOfItems> shared_, per_frame_, keep_;
};

// The bytes one frame takes uncompressed, for bounding NumberOfFrames before allocating.
std::uint64_t frame_bytes(const Header& h) {
  return std::uint64_t(h.rows.value_or(0)) * h.columns.value_or(0) * std::max<std::uint16_t>(h.bits_allocated.value_or(8), 8) / 8 *
         std::max<std::uint16_t>(h.samples_per_pixel.value_or(1), 1);
}

// NumberOfFrames, checked against the bytes after the pixel data's start: every frame takes at
// least frame_bytes() of a native file and an 8-byte item header in an encapsulated one.
std::size_t frame_count(const gdcm::DataSet& ds, const Header& h, std::uint64_t pixel_bytes, bool native) {
  const auto declared = one_number(ds, tags::kNumberOfFrames, h.file);
  if (!declared) return 1;
  if (*declared < 1 || *declared != std::floor(*declared))
    throw FormatError(h.file.string(), tags::kNumberOfFrames.text(), fmt::format("is {}; expected a positive integer", *declared));
  const std::uint64_t each = native ? std::max<std::uint64_t>(frame_bytes(h), 1) : 8;
  if (*declared > double(pixel_bytes / each))
    throw FormatError(h.file.string(), tags::kNumberOfFrames.text(),
                      fmt::format("is {}, but the pixel data has room for {} frame(s) of {} bytes", *declared,
                                  pixel_bytes / each, each));
  return std::size_t(*declared);
}

void read_frames(const gdcm::DataSet& ds, Header& h, std::size_t count) {
  FunctionalGroups groups(ds);
  if (groups.per_frame_items() != 0 && groups.per_frame_items() != count)
    throw FormatError(h.file.string(), tags::kPerFrameFunctionalGroupsSequence.text(),
                      fmt::format("has {} items for {} frames", groups.per_frame_items(), count));
  h.frames.resize(count);
  for (std::size_t f = 0; f < count; ++f) {
    Frame& frame = h.frames[f];
    if (const auto p = numbers<3>(groups.find(tags::kPlanePositionSequence, f, tags::kImagePositionPatient),
                                  tags::kImagePositionPatient, h.file))
      frame.position = Vector3{(*p)[0], (*p)[1], (*p)[2]};
    const gdcm::DataSet& values = groups.find(tags::kPixelValueTransformationSequence, f, tags::kRescaleSlope);
    frame.slope = one_number(values, tags::kRescaleSlope, h.file).value_or(1.0);
    frame.intercept = one_number(values, tags::kRescaleIntercept, h.file).value_or(0.0);
  }
  // Orientation and pixel measures are one per file: the shared item's, else the first frame's.
  h.orientation = numbers<6>(groups.find(tags::kPlaneOrientationSequence, 0, tags::kImageOrientationPatient),
                             tags::kImageOrientationPatient, h.file);
  const gdcm::DataSet& measures = groups.find(tags::kPixelMeasuresSequence, 0, tags::kPixelSpacing);
  h.pixel_spacing = numbers<2>(measures, tags::kPixelSpacing, h.file);
  h.slice_thickness = one_number(measures, tags::kSliceThickness, h.file);
  h.spacing_between_slices = one_number(measures, tags::kSpacingBetweenSlices, h.file);
}

// Transfer syntaxes whose pixel data gdcm::ImageRegionReader reads: native little-endian, RLE,
// JPEG (baseline, extended, lossless), JPEG-LS and JPEG 2000. Deflated and big-endian data
// sets, MPEG and private syntaxes are refused.
bool region_decodable(gdcm::TransferSyntax::TSType ts) {
  using TS = gdcm::TransferSyntax;
  switch (ts) {
    case TS::ImplicitVRLittleEndian: case TS::ExplicitVRLittleEndian: case TS::RLELossless:
    case TS::JPEGBaselineProcess1: case TS::JPEGExtendedProcess2_4: case TS::JPEGLosslessProcess14:
    case TS::JPEGLosslessProcess14_1: case TS::JPEGLSLossless: case TS::JPEGLSNearLossless:
    case TS::JPEG2000Lossless: case TS::JPEG2000:
      return true;
    default:
      return false;
  }
}

void read_values(const gdcm::Reader& reader, Header& h, std::uint64_t pixel_bytes) {
  const gdcm::DataSet& ds = reader.GetFile().GetDataSet();
  const gdcm::TransferSyntax ts = reader.GetFile().GetHeader().GetDataSetTransferSyntax();
  h.transfer_syntax = ts.IsValid() ? ts.GetString() : "unknown";
  h.decodable = region_decodable(gdcm::TransferSyntax::TSType(ts));
  h.sop_class_uid = text_value(reader.GetFile().GetHeader(), tags::kMediaStorageSOPClassUID).value_or("");
  h.series_uid = text_value(ds, tags::kSeriesInstanceUID).value_or("");
  h.series_description = text_value(ds, tags::kSeriesDescription).value_or("");
  h.rows = us_value(ds, tags::kRows, h.file);
  h.columns = us_value(ds, tags::kColumns, h.file);
  h.bits_allocated = us_value(ds, tags::kBitsAllocated, h.file);
  h.bits_stored = us_value(ds, tags::kBitsStored, h.file);
  h.high_bit = us_value(ds, tags::kHighBit, h.file);
  h.pixel_representation = us_value(ds, tags::kPixelRepresentation, h.file);
  h.samples_per_pixel = us_value(ds, tags::kSamplesPerPixel, h.file);
  const bool native = !ts.IsEncapsulated();
  read_frames(ds, h, frame_count(ds, h, pixel_bytes, native));
  if (h.has_pixel_data && native && pixel_bytes < frame_bytes(h) * h.frames.size())
    throw FormatError(h.file.string(), tags::kPixelData.text(),
                      fmt::format("holds {} bytes; {} frame(s) of {} x {} need {}", pixel_bytes, h.frames.size(),
                                  h.columns.value_or(0), h.rows.value_or(0), frame_bytes(h) * h.frames.size()));
}

}  // namespace

std::string TagName::text() const { return fmt::format("{} ({:04X},{:04X})", keyword, group, element); }

bool has_dicom_magic(std::span<const std::byte> head) {
  return head.size() >= kMagicBytes && std::equal(head.begin() + kMagicOffset, head.begin() + kMagicBytes,
                                                  reinterpret_cast<const std::byte*>("DICM"));
}

bool file_has_dicom_magic(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::array<std::byte, kMagicBytes> head{};
  in.read(reinterpret_cast<char*>(head.data()), head.size());
  return in.gcount() == std::streamsize(head.size()) && has_dicom_magic(head);
}

bool is_directory_record(const Header& header) { return header.sop_class_uid == "1.2.840.10008.1.3.10"; }

void quiet_gdcm() {
  static std::once_flag once;
  std::call_once(once, [] {
    gdcm::Trace::SetWarning(false);
    gdcm::Trace::SetError(false);
    gdcm::Trace::SetDebug(false);
  });
}

Header read_header(const fs::path& file) {
  quiet_gdcm();
  check_element_structure(file);  // before GDCM, whose parser aborts on a truncated file
  Header h;
  h.file = file;
  gdcm::Reader reader;
  reader.SetFileName(file.c_str());
  try {
    const std::set<gdcm::Tag> skip{tag_of(tags::kPixelData)};
    if (!reader.ReadUpToTag(tag_of(tags::kPixelData), skip))
      throw FormatError(file.string(), "DICOM header", "GDCM cannot parse the file as DICOM");
    // Stopped before the pixel data's value, the stream is at its first byte; at the end (or
    // failed: -1) when the file has none.
    std::error_code ec;
    const std::uint64_t size = fs::file_size(file, ec);
    const std::uint64_t position = reader.GetStreamCurrentPosition();
    h.has_pixel_data = !ec && position < size;
    read_values(reader, h, h.has_pixel_data ? size - position : 0);
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw FormatError(file.string(), "DICOM header", fmt::format("GDCM cannot parse it: {}", e.what()));
  }
  return h;
}

}  // namespace strata::io::detail::dicom
