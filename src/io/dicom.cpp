// DICOM series, read through GDCM: a folder of slice files of one series (or the series a
// ReadOptions::dataset UID names), or one file, a slice or the frames of a multi-frame image.
// Opening reads the headers only (io/dicom/header.cpp) and assembles the series from them
// (io/dicom/series.cpp); read_box decodes, for each slice the box touches, the box's rectangle
// of that slice's frame (gdcm::ImageRegionReader), then masks the stored bits and rescales.
#include <gdcmBoxRegion.h>
#include <gdcmImageRegionReader.h>

#include <limits>
#include <type_traits>

#include <fmt/format.h>

#include "io/builtin_formats.hpp"
#include "io/dicom/header.hpp"
#include "io/dicom/series.hpp"
#include "io/io_detail.hpp"
#include "strata/core/error.hpp"

namespace strata::io::detail {

namespace {

namespace fs = std::filesystem;
using namespace dicom;

// A stored sample's value: its BitsStored low bits, sign-extended when signed (the bits above
// may hold overlays or garbage).
template <class S>
std::int64_t stored_value(S raw, unsigned bits_stored, bool is_signed) {
  const std::uint64_t mask = (std::uint64_t(1) << bits_stored) - 1;
  std::uint64_t bits = std::uint64_t(std::make_unsigned_t<S>(raw)) & mask;
  if (is_signed && (bits >> (bits_stored - 1)) != 0) bits |= ~mask;
  return std::int64_t(bits);
}

// Stored samples of one slice's rectangle to the volume's samples: value x slope + intercept.
void rescale(const std::byte* stored, std::size_t count, const StoredSamples& layout, const Slice& slice, DType out_dtype,
             std::byte* out) {
  visit_dtype(layout.dtype, [&](auto stored_tag) {
    using S = decltype(stored_tag);
    if constexpr (std::is_integral_v<S>) visit_dtype(out_dtype, [&](auto out_tag) {
      using T = decltype(out_tag);
      const auto* in = reinterpret_cast<const S*>(stored);
      auto* to = reinterpret_cast<T*>(out);
      const auto intercept = std::int64_t(slice.intercept);
      for (std::size_t i = 0; i < count; ++i) {
        const std::int64_t v = stored_value(in[i], layout.bits_stored, layout.is_signed);
        if constexpr (std::is_floating_point_v<T>)
          to[i] = T(double(v) * slice.slope + slice.intercept);
        else
          to[i] = T(v + intercept);  // rescaled_dtype chose T to hold every value
      }
    });
  });
}

class DicomSource final : public VolumeSource {
 public:
  DicomSource(fs::path path, Series series) : path_(std::move(path)), series_(std::move(series)) {}

  const VolumeInfo& info() const override { return series_.info; }
  const fs::path& path() const override { return path_; }

  Volume read_box(const Box& box) override {
    check_box_inside(box, series_.info.dims, path_);
    Volume out(box.size(), series_.info.dtype, series_.info.spacing);
    const std::size_t count = std::size_t(box.size().x * box.size().y);
    const std::size_t out_slice = count * dtype_size(series_.info.dtype);
    std::vector<std::byte> stored(count * dtype_size(series_.stored.dtype));
    for (std::int64_t z = box.lo.z; z < box.hi.z; ++z) {
      const Slice& slice = series_.slices[std::size_t(z)];
      decode_rectangle(slice, box, stored);
      rescale(stored.data(), count, series_.stored, slice, series_.info.dtype, out.bytes() + std::size_t(z - box.lo.z) * out_slice);
    }
    return out;
  }

 private:
  // The stored samples of the box's rectangle of one slice, x fastest.
  void decode_rectangle(const Slice& slice, const Box& box, std::vector<std::byte>& stored) const {
    const Header& header = series_.headers[slice.header];
    const std::string field = tags::kPixelData.text();
    try {
      gdcm::ImageRegionReader reader;
      reader.SetFileName(header.file.c_str());
      if (!reader.ReadInformation())
        throw FormatError(slice.label, "DICOM header", "GDCM cannot read it (changed since the series was opened?)");
      check_unchanged(reader.GetImage(), slice);
      gdcm::BoxRegion region;
      region.SetDomain(unsigned(box.lo.x), unsigned(box.hi.x - 1), unsigned(box.lo.y), unsigned(box.hi.y - 1),
                       unsigned(slice.frame), unsigned(slice.frame));
      reader.SetRegion(region);
      if (reader.ComputeBufferLength() != stored.size())
        throw FormatError(slice.label, field, "GDCM's region size disagrees with the header");
      if (!reader.ReadIntoBuffer(reinterpret_cast<char*>(stored.data()), stored.size()))
        throw FormatError(slice.label, field, fmt::format("cannot be decoded (transfer syntax {})", header.transfer_syntax));
    } catch (const Error&) {
      throw;
    } catch (const std::exception& e) {
      throw FormatError(slice.label, field, fmt::format("GDCM cannot decode it: {}", e.what()));
    }
  }

  // Files can change between open and read (a folder being rewritten): the decoded layout must
  // still be the one the series was assembled from.
  void check_unchanged(const gdcm::Image& image, const Slice& slice) const {
    const unsigned* dims = image.GetDimensions();
    const gdcm::PixelFormat& format = image.GetPixelFormat();
    const bool same = dims[0] == series_.stored.columns && dims[1] == series_.stored.rows &&
                      (image.GetNumberOfDimensions() < 3 || std::int64_t(dims[2]) > slice.frame) &&
                      format.GetBitsAllocated() == series_.stored.bits_allocated && format.GetSamplesPerPixel() == 1;
    if (!same)
      throw FormatError(slice.label, "Rows/Columns/BitsAllocated", "differ from when the series was opened");
  }

  fs::path path_;
  Series series_;
};

std::unique_ptr<VolumeSource> open_dicom(const fs::path& path, const ReadOptions& options) {
  std::vector<Header> headers;
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    headers = folder_series_headers(path, options.dataset);
  } else {
    headers.push_back(read_header(path));
    if (!options.dataset.empty() && headers.front().series_uid != options.dataset)
      throw FormatError(path.string(), tags::kSeriesInstanceUID.text(),
                        fmt::format("is {}, not the series {} asked for", headers.front().series_uid, options.dataset));
  }
  return std::make_unique<DicomSource>(path, assemble_series(std::move(headers)));
}

// A folder of DICOM files: the first files looked at (up to 16, hidden ones skipped) all carry
// the signature. Looking at a few keeps detection cheap on folders of thousands of slices.
bool is_dicom_folder(const fs::path& dir) {
  constexpr int kFilesLookedAt = 16;
  int looked_at = 0;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end && looked_at < kFilesLookedAt; it.increment(ec)) {
    if (!it->is_regular_file(ec) || it->path().filename().string().starts_with(".")) continue;
    if (!file_has_dicom_magic(it->path())) return false;
    ++looked_at;
  }
  return looked_at > 0;
}

}  // namespace

VolumeFormat dicom_format() {
  return {
      .name = "dicom",
      .title = "DICOM",
      .description = "medical images (CT, MR, PET, micro-CT): a folder of one series' slice files, or one file of a "
                     "slice or of many frames",
      .extensions = {".dcm", ".dicom"},
      .magic_bytes = kMagicBytes,
      .sniff = has_dicom_magic,
      .directory = "a directory of DICOM slices",
      .sniff_directory = is_dicom_folder,
      .open = open_dicom,
      .capabilities = {.streaming = true, .spatial_metadata = true, .datasets = true},
      .read_dtypes = {DType::u8, DType::i8, DType::u16, DType::i16, DType::u32, DType::i32, DType::i64, DType::f32},
      .read_notes = "read only, through GDCM: slices grouped by SeriesInstanceUID (one chosen by `--dataset UID`), "
                    "sorted along the slice normal; spacing from PixelSpacing and the slice positions; LPS geometry in "
                    "mm; 8/16/32-bit samples rescaled (integer types kept when the slope is 1); multi-frame files; "
                    "native, RLE, JPEG, JPEG-LS and JPEG 2000 pixel data",
  };
}

}  // namespace strata::io::detail
