// NIfTI-1 single-file volumes (.nii, .nii.gz): a 348-byte header, 4 extension bytes, then the
// samples at vox_offset. Plain files are memory-mapped; gzip files are decoded once to a
// temporary file and mapped from there, so both give random access without loading the volume.
#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstring>
#include <optional>

#include <fmt/format.h>

#include "io/io_detail.hpp"
#include "strata/core/bytes.hpp"

namespace strata::io::detail {

namespace {

namespace fs = std::filesystem;

// Samples are kept native little endian in memory (dtype.hpp); the writer relies on that.
static_assert(std::endian::native == std::endian::little, "the NIfTI writer assumes a little-endian host");

constexpr std::uint64_t kHeaderBytes = 348;
// The header plus the 4-byte extension flag: where single-file data starts when there are no
// extensions, and what we write.
constexpr std::uint64_t kDataOffset = 352;

// Byte offsets of the header fields we use (nifti1.h, struct nifti_1_header).
namespace field_at {
constexpr std::size_t sizeof_hdr = 0;
constexpr std::size_t dim = 40;  // int16[8]
constexpr std::size_t datatype = 70;
constexpr std::size_t bitpix = 72;
constexpr std::size_t pixdim = 76;  // float[8]
constexpr std::size_t vox_offset = 108;
constexpr std::size_t scl_slope = 112;
constexpr std::size_t scl_inter = 116;
constexpr std::size_t magic = 344;
}  // namespace field_at

// NIfTI-1 datatype codes (nifti1.h DT_*) of the sample types we read.
struct DatatypeCode {
  std::int16_t code;
  DType dtype;
};
constexpr std::array<DatatypeCode, 8> kDatatypeCodes{{{2, DType::u8},
                                                      {256, DType::i8},
                                                      {4, DType::i16},
                                                      {512, DType::u16},
                                                      {8, DType::i32},
                                                      {768, DType::u32},
                                                      {16, DType::f32},
                                                      {64, DType::f64}}};

std::int16_t datatype_code(DType t) {
  for (const auto& entry : kDatatypeCodes)
    if (entry.dtype == t) return entry.code;
  throw Error(fmt::format("NIfTI-1: no datatype code for {}", dtype_name(t)));
}

// value = stored * slope + inter, from scl_slope/scl_inter.
struct Scaling {
  double slope = 1.0, inter = 0.0;
};

struct NiftiHeader {
  VolumeInfo stored;  // dims, the stored sample type and spacing
  bool big_endian = false;
  std::uint64_t vox_offset = kDataOffset;
  std::optional<Scaling> scaling;
};

// The 348 header bytes, in the file's byte order.
struct HeaderBytes {
  std::span<const std::byte> bytes;
  std::endian order;
  template <class T>
  T get(std::size_t offset) const {
    return load_field<T>(bytes, offset, order);
  }
};

// NIfTI has no byte-order flag: sizeof_hdr is 348 when read in the file's order, so reading
// it both ways tells the order (the method nifti1.h recommends).
bool detect_big_endian(const std::byte* data, std::uint64_t size, const std::string& file) {
  if (size < kHeaderBytes)
    throw FormatError(file, "sizeof_hdr",
                      fmt::format("file has {} bytes, shorter than the 348-byte NIfTI-1 header", size));
  const std::span<const std::byte> header(data, kHeaderBytes);
  const auto as_little = load_field<std::int32_t>(header, field_at::sizeof_hdr, std::endian::little);
  const auto as_big = load_field<std::int32_t>(header, field_at::sizeof_hdr, std::endian::big);
  if (as_little == std::int32_t(kHeaderBytes)) return false;
  if (as_big == std::int32_t(kHeaderBytes)) return true;
  throw FormatError(file, "sizeof_hdr",
                    fmt::format("is {} (read little endian); expected 348 (NIfTI-1; NIfTI-2 is not supported)", as_little));
}

void check_magic(const std::byte* data, const std::string& file) {
  char magic[4];
  std::memcpy(magic, data + field_at::magic, 4);
  if (std::memcmp(magic, "n+1\0", 4) == 0) return;
  if (std::memcmp(magic, "ni1\0", 4) == 0)
    throw FormatError(file, "magic", "is \"ni1\" (separate .hdr/.img pair); only single-file \"n+1\" is supported");
  std::string shown;
  for (char c : magic) shown += std::isprint(static_cast<unsigned char>(c)) ? std::string(1, c) : fmt::format("\\x{:02x}", static_cast<unsigned char>(c));
  throw FormatError(file, "magic", fmt::format("is \"{}\"; expected \"n+1\"", shown));
}

Extent read_dims(const HeaderBytes& h, const std::string& file) {
  std::array<std::int16_t, 8> dim{};
  for (std::size_t i = 0; i < dim.size(); ++i) dim[i] = h.get<std::int16_t>(field_at::dim + 2 * i);
  // A 4D file with a single time point is still one 3D volume; anything else is not.
  const bool single_volume = dim[0] == 3 || (dim[0] == 4 && dim[4] == 1);
  if (!single_volume)
    throw FormatError(file, "dim[0]",
                      fmt::format("is {} (dim[4] = {}); expected 3, or 4 with dim[4] == 1: only single 3D volumes "
                                  "are supported",
                                  dim[0], dim[4]));
  for (int i = 1; i <= 3; ++i)
    if (dim[i] < 1) throw FormatError(file, fmt::format("dim[{}]", i), fmt::format("is {}; expected >= 1", dim[i]));
  return {dim[1], dim[2], dim[3]};
}

DType read_dtype(const HeaderBytes& h, const std::string& file) {
  const auto code = h.get<std::int16_t>(field_at::datatype);
  const auto it = std::find_if(kDatatypeCodes.begin(), kDatatypeCodes.end(), [&](const auto& e) { return e.code == code; });
  if (it == kDatatypeCodes.end())
    throw FormatError(file, "datatype",
                      fmt::format("code {} is not supported; expected one of 2 (u8), 256 (i8), 4 (i16), 512 (u16), "
                                  "8 (i32), 768 (u32), 16 (f32), 64 (f64)",
                                  code));
  const auto bitpix = h.get<std::int16_t>(field_at::bitpix);
  const auto expected_bits = std::int16_t(8 * dtype_size(it->dtype));
  if (bitpix != expected_bits)
    throw FormatError(file, "bitpix",
                      fmt::format("is {}; datatype {} ({}) has {} bits", bitpix, code, dtype_name(it->dtype), expected_bits));
  return it->dtype;
}

// Spacing from pixdim[1..3]. Many writers store 0 for "unknown", so 0 reads as 1; a negative,
// NaN or infinite size is not a voxel size and is refused (an orientation flip belongs in
// qform/sform, and the magnitude of a negative size would be a guess).
Spacing read_spacing(const HeaderBytes& h, const std::string& file) {
  auto size_at = [&](int axis) {
    const double v = double(h.get<float>(field_at::pixdim + 4 * std::size_t(axis)));
    if (v == 0) return 1.0;
    if (!(v > 0) || !std::isfinite(v))
      throw FormatError(file, fmt::format("pixdim[{}]", axis),
                        fmt::format("is {}; expected a positive voxel size (or 0 for unknown, read as 1)", v));
    return v;
  };
  return {size_at(1), size_at(2), size_at(3)};
}

std::uint64_t read_vox_offset(const HeaderBytes& h, const std::string& file) {
  const double offset = h.get<float>(field_at::vox_offset);
  // The upper bound keeps the conversion below defined; no real file is anywhere near it.
  constexpr double kLargest = 0x1p62;
  if (!std::isfinite(offset) || offset < double(kHeaderBytes) || offset != std::floor(offset) || offset > kLargest)
    throw FormatError(file, "vox_offset", fmt::format("is {}; expected a whole number from 348 to 2^62", offset));
  return std::uint64_t(offset);
}

// Scaling is "set" only when it changes values: slope 0 means unused (nifti1.h), and 1/0 is
// the identity many writers store by default. Non-finite values count as unset, like 0.
std::optional<Scaling> read_scaling(const HeaderBytes& h) {
  const double slope = h.get<float>(field_at::scl_slope);
  double inter = h.get<float>(field_at::scl_inter);
  if (!std::isfinite(slope) || slope == 0.0) return std::nullopt;
  if (!std::isfinite(inter)) inter = 0.0;
  if (slope == 1.0 && inter == 0.0) return std::nullopt;
  return Scaling{slope, inter};
}

NiftiHeader parse_header(const std::byte* data, std::uint64_t size, const std::string& file) {
  NiftiHeader header;
  header.big_endian = detect_big_endian(data, size, file);
  const HeaderBytes h{{data, kHeaderBytes}, header.big_endian ? std::endian::big : std::endian::little};
  check_magic(data, file);
  header.stored.dims = read_dims(h, file);
  header.stored.dtype = read_dtype(h, file);
  header.stored.spacing = read_spacing(h, file);
  header.vox_offset = read_vox_offset(h, file);
  header.scaling = read_scaling(h);
  checked_volume_bytes(header.stored, file, "dim");
  return header;
}

// The type scaled values are returned in: f32, or f64 when the stored samples are f64 so no
// precision is lost.
DType scaled_dtype(DType stored) { return stored == DType::f64 ? DType::f64 : DType::f32; }

template <class Out>
void scale_samples(const Volume& stored, const Scaling& s, Volume& out) {
  auto dst = out.samples<Out>();
  visit_dtype(stored.dtype(), [&](auto tag) {
    using In = decltype(tag);
    auto src = stored.samples<In>();
    for (std::size_t i = 0; i < src.size(); ++i) dst[i] = Out(double(src[i]) * s.slope + s.inter);
  });
}

// Applies scl_slope/scl_inter to boxes read from the stored samples.
class ScaledSource final : public VolumeSource {
 public:
  ScaledSource(std::unique_ptr<VolumeSource> stored, const Scaling& scaling)
      : stored_(std::move(stored)), scaling_(scaling), info_(stored_->info()) {
    info_.dtype = scaled_dtype(stored_->info().dtype);
  }
  const VolumeInfo& info() const override { return info_; }
  const fs::path& path() const override { return stored_->path(); }

  Volume read_box(const Box& box) override {
    const Volume stored = stored_->read_box(box);
    Volume out(stored.dims(), info_.dtype, stored.spacing());
    if (info_.dtype == DType::f64)
      scale_samples<double>(stored, scaling_, out);
    else
      scale_samples<float>(stored, scaling_, out);
    return out;
  }

 private:
  std::unique_ptr<VolumeSource> stored_;
  Scaling scaling_;
  VolumeInfo info_;
};

bool has_gz_name(const fs::path& path) { return ascii_lower(path.filename().string()).ends_with(".gz"); }

// `file` holds a whole uncompressed NIfTI-1 file; `shown_path` is what the user named.
std::unique_ptr<VolumeSource> source_over(std::shared_ptr<MappedFile> file, const fs::path& shown_path) {
  const NiftiHeader header = parse_header(file->data(), file->size(), shown_path.string());
  auto stored = make_mapped_source(std::move(file), header.vox_offset, header.stored, header.big_endian, shown_path,
                                   "dim");
  if (!header.scaling) return stored;
  return std::make_unique<ScaledSource>(std::move(stored), *header.scaling);
}

// The header is decoded first: its dims, datatype and vox_offset bound what the whole stream
// may decode to, so a stream that inflates to more stops there instead of filling the disk.
std::unique_ptr<VolumeSource> open_gzipped(const fs::path& path, const MappedFile& compressed,
                                           const ReadOptions& options) {
  const std::string file = path.string();
  const auto head = gunzip_to_memory(compressed.data(), compressed.size(), file, "gzip", kHeaderBytes);
  const NiftiHeader header = parse_header(head.data(), head.size(), file);
  const std::uint64_t declared = header.vox_offset + header.stored.byte_size();  // both far below 2^63
  auto decoded = gunzip_to_temp_file(
      compressed.data(), compressed.size(), options, "strata-" + path.filename().string(), file, "gzip",
      {declared, fmt::format("the header (vox_offset {} + dim {} of {})", header.vox_offset,
                             header.stored.dims.to_string(), dtype_name(header.stored.dtype))});
  return source_over(std::move(decoded), path);
}

// Writes the 352-byte prefix (header + empty extension flag) for `info`, little endian.
std::array<std::byte, kDataOffset> make_header(const VolumeInfo& info) {
  std::array<std::byte, kDataOffset> bytes{};
  auto put = [&](std::size_t offset, auto value) { store_field(bytes, offset, value); };
  put(field_at::sizeof_hdr, std::int32_t(kHeaderBytes));
  const std::array<std::int16_t, 8> dim{3, std::int16_t(info.dims.x), std::int16_t(info.dims.y),
                                        std::int16_t(info.dims.z), 1, 1, 1, 1};
  for (std::size_t i = 0; i < dim.size(); ++i) put(field_at::dim + 2 * i, dim[i]);
  put(field_at::datatype, datatype_code(info.dtype));
  put(field_at::bitpix, std::int16_t(8 * dtype_size(info.dtype)));
  // pixdim[0] is qfac (orientation handedness); 1 is the neutral value, unused axes get 1.
  const std::array<float, 8> pixdim{1.0f, float(info.spacing.x), float(info.spacing.y), float(info.spacing.z),
                                    1.0f, 1.0f, 1.0f, 1.0f};
  for (std::size_t i = 0; i < pixdim.size(); ++i) put(field_at::pixdim + 4 * i, pixdim[i]);
  put(field_at::vox_offset, float(kDataOffset));
  put(field_at::scl_slope, 0.0f);  // 0: samples are the values (no scaling)
  put(field_at::scl_inter, 0.0f);
  // qform_code and sform_code stay 0: no orientation is claimed.
  std::memcpy(bytes.data() + field_at::magic, "n+1\0", 4);
  return bytes;
}

void check_writable(const fs::path& path, const VolumeInfo& info) {
  if (info.dtype == DType::i8)
    throw Error(fmt::format("{}: NIfTI-1 writing does not support i8 (many readers reject it); convert to i16",
                            path.string()));
  const auto fits = [](std::int64_t n) { return n >= 1 && n <= 32767; };
  if (!fits(info.dims.x) || !fits(info.dims.y) || !fits(info.dims.z))
    throw Error(fmt::format("{}: dims {}: NIfTI-1 stores each dimension as a 16-bit count (1..32767)", path.string(),
                            info.dims.to_string()));
}

// Streams slabs after the header into `<path>.tmp`, gzip-compressed for *.gz names, and
// renames on finish(); an unfinished writer leaves nothing behind.
class NiftiWriter final : public VolumeWriter {
 public:
  NiftiWriter(const fs::path& path, const VolumeInfo& info) : out_(path, has_gz_name(path)) {
    const auto header = make_header(info);
    out_.write(header.data(), header.size());
  }

  void write_slab(const Volume& slab) override { out_.write(slab.bytes(), slab.byte_size()); }
  void finish() override { out_.commit(); }

 private:
  OutputStream out_;
};

}  // namespace

std::unique_ptr<VolumeSource> open_nifti(const std::filesystem::path& path, const ReadOptions& options) {
  auto file = std::make_shared<MappedFile>(path);
  // Content decides, so a compressed file named .nii still opens; a .gz name that is not gzip
  // is reported by the decoder as a bad gzip stream rather than as a bad NIfTI header.
  if (has_gz_name(path) || looks_gzipped(file->data(), file->size())) return open_gzipped(path, *file, options);
  return source_over(std::move(file), path);
}

std::unique_ptr<VolumeWriter> create_nifti_writer(const std::filesystem::path& path, const VolumeInfo& info,
                                                  const WriteOptions& options) {
  check_writable(path, info);
  return std::make_unique<NiftiWriter>(path, info);
}

}  // namespace strata::io::detail
