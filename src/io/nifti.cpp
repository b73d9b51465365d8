// NIfTI-1 and NIfTI-2 single-file volumes (.nii, .nii.gz): a 348- or 540-byte header, 4
// extension bytes, then the samples at vox_offset. Plain files are memory-mapped; gzip files are
// decoded once to a temporary file and mapped from there, so both give random access without
// loading the volume. A file of several 3D volumes (dim[0] > 3: time points, components) is
// read one volume at a time (ReadOptions::volume).
#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstring>
#include <optional>
#include <string_view>

#include <fmt/format.h>

#include "io/builtin_formats.hpp"
#include "io/io_detail.hpp"
#include "io/nifti_orientation.hpp"
#include "strata/core/bytes.hpp"
#include "strata/core/checked.hpp"

namespace strata::io::detail {

namespace {

namespace fs = std::filesystem;

// Samples are kept native little endian in memory (dtype.hpp); the writer relies on that.
static_assert(std::endian::native == std::endian::little, "the NIfTI writer assumes a little-endian host");

// The two header layouts (nifti1.h struct nifti_1_header, nifti2.h struct nifti_2_header): the
// byte offsets of the fields we use. NIfTI-2 widens dim and vox_offset to i64 and pixdim and
// the scaling to f64, and reorders the fields.
//
// | field      | NIfTI-1 offset, type | NIfTI-2 offset, type |
// | ---------- | -------------------- | -------------------- |
// | sizeof_hdr | 0, i32 (348)         | 0, i32 (540)         |
// | magic      | 344, "n+1\0"         | 4, "n+2\0\r\n\032\n"  |
// | datatype   | 70, i16              | 12, i16              |
// | bitpix     | 72, i16              | 14, i16              |
// | dim[8]     | 40, i16              | 16, i64              |
// | pixdim[8]  | 76, f32              | 104, f64             |
// | vox_offset | 108, f32             | 168, i64             |
// | scl_slope  | 112, f32             | 176, f64             |
// | scl_inter  | 116, f32             | 184, f64             |
// | xyzt_units | 123, u8              | 500, i32             |
// | qform_code | 252, i16             | 344, i32             |
// | sform_code | 254, i16             | 348, i32             |
// | quatern_b  | 256, f32 (c, d after) | 352, f64 (c, d after) |
// | qoffset_x  | 268, f32 (y, z after) | 376, f64 (y, z after) |
// | srow_x     | 280, 4 x f32 (srow_y, srow_z after) | 400, 4 x f64 (srow_y, srow_z after) |
struct OrientationLayout {
  std::size_t xyzt_units, qform_code, sform_code, quatern_b, qoffset_x, srow_x;
};
struct HeaderLayout {
  int version;
  std::uint64_t header_bytes;
  std::size_t magic, datatype, bitpix, dim, pixdim, vox_offset, scl_slope, scl_inter;
  std::string_view magic_single, magic_pair;  // "n+<v>" one file; "ni<v>" a .hdr/.img pair
  bool wide;                                  // 64-bit dim, vox_offset, pixdim and scaling
  OrientationLayout orientation;              // wide: i32 codes and units, f64 reals
  // The header plus the 4-byte extension flag: where single-file data starts when there are
  // no extensions, and what we write.
  std::uint64_t data_offset() const { return header_bytes + 4; }
};
constexpr HeaderLayout kNifti1{
    1, 348, 344, 70, 72, 40, 76, 108, 112, 116, {"n+1\0", 4}, {"ni1\0", 4}, false, {123, 252, 254, 256, 268, 280}};
constexpr HeaderLayout kNifti2{2,    540, 4, 12, 14, 16, 104, 168, 176, 184, {"n+2\0\r\n\032\n", 8}, {"ni2\0\r\n\032\n", 8},
                               true, {500, 344, 348, 352, 376, 400}};
constexpr std::uint64_t kLargestHeader = kNifti2.header_bytes;

// NIfTI-1 datatype codes (nifti1.h DT_*) of the sample types we read.
struct DatatypeCode {
  std::int16_t code;
  DType dtype;
};
constexpr std::array<DatatypeCode, 10> kDatatypeCodes{{{2, DType::u8},
                                                      {256, DType::i8},
                                                      {4, DType::i16},
                                                      {512, DType::u16},
                                                      {8, DType::i32},
                                                      {768, DType::u32},
                                                      {16, DType::f32},
                                                      {64, DType::f64},
                                                      {1024, DType::i64},
                                                      {1280, DType::u64}}};

std::int16_t datatype_code(DType t) {
  for (const auto& entry : kDatatypeCodes)
    if (entry.dtype == t) return entry.code;
  throw Error(fmt::format("NIfTI: no datatype code for {}", dtype_name(t)));
}

// value = stored * slope + inter, from scl_slope/scl_inter.
struct Scaling {
  double slope = 1.0, inter = 0.0;
};

struct NiftiHeader {
  const HeaderLayout* layout = &kNifti1;
  VolumeInfo stored;  // dims of one 3D volume, the stored sample type and spacing
  bool big_endian = false;
  std::uint64_t vox_offset = kNifti1.data_offset();
  std::int64_t volumes = 1;  // 3D volumes in the file: the product of dim[4..dim[0]]
  std::uint64_t data_bytes = 0;  // all volumes
  std::optional<Scaling> scaling;
};

// The header bytes, in the file's byte order and layout.
struct HeaderBytes {
  std::span<const std::byte> bytes;
  std::endian order;
  const HeaderLayout& layout;
  template <class T>
  T get(std::size_t offset) const {
    return load_field<T>(bytes, offset, order);
  }
  std::int64_t dim(std::size_t i) const { return layout.wide ? get<std::int64_t>(layout.dim + 8 * i) : get<std::int16_t>(layout.dim + 2 * i); }
  // pixdim, scl_slope, scl_inter: f32 in NIfTI-1, f64 in NIfTI-2.
  double real(std::size_t offset) const { return layout.wide ? get<double>(offset) : double(get<float>(offset)); }
};

// NIfTI has no byte-order flag: sizeof_hdr is 348 (NIfTI-1) or 540 (NIfTI-2) when read in
// the file's order, so reading it both ways tells the version and the order (the method
// nifti1.h and nifti2.h recommend).
std::pair<const HeaderLayout*, bool> detect_layout(const std::byte* data, std::uint64_t size, const std::string& file) {
  if (size < 4) throw FormatError(file, "sizeof_hdr", fmt::format("file has {} bytes, no NIfTI header", size));
  const std::span<const std::byte> field(data, 4);
  for (const std::endian order : {std::endian::little, std::endian::big})
    for (const HeaderLayout* layout : {&kNifti1, &kNifti2})
      if (load_field<std::int32_t>(field, 0, order) == std::int32_t(layout->header_bytes)) {
        if (size < layout->header_bytes)
          throw FormatError(file, "sizeof_hdr",
                            fmt::format("file has {} bytes, shorter than the {}-byte NIfTI-{} header", size,
                                        layout->header_bytes, layout->version));
        return {layout, order == std::endian::big};
      }
  throw FormatError(file, "sizeof_hdr",
                    fmt::format("is {} (read little endian); expected 348 (NIfTI-1) or 540 (NIfTI-2)",
                                load_field<std::int32_t>(field, 0, std::endian::little)));
}

std::string shown_magic(std::span<const std::byte> magic) {
  std::string shown;
  for (std::byte b : magic) {
    const auto c = std::to_integer<unsigned char>(b);
    shown += std::isprint(c) ? std::string(1, char(c)) : fmt::format("\\x{:02x}", c);
  }
  return shown;
}

void check_magic(const std::byte* data, const HeaderLayout& layout, const std::string& file) {
  const std::span<const std::byte> magic(data + layout.magic, layout.magic_single.size());
  const auto is = [&](std::string_view expected) { return std::memcmp(magic.data(), expected.data(), expected.size()) == 0; };
  if (is(layout.magic_single)) return;
  if (is(layout.magic_pair))
    throw FormatError(file, "magic",
                      fmt::format("is \"ni{}\" (separate .hdr/.img pair); only single-file \"n+{}\" is supported",
                                  layout.version, layout.version));
  throw FormatError(file, "magic", fmt::format("is \"{}\"; expected \"n+{}\" (NIfTI-{})", shown_magic(magic),
                                               layout.version, layout.version));
}

// dim[1..3] are the 3D volume; dim[4..dim[0]] (time points, components, ...) multiply into the
// number of such volumes, stored one after the other.
std::pair<Extent, std::int64_t> read_dims(const HeaderBytes& h, const std::string& file) {
  const std::int64_t rank = h.dim(0);
  if (rank < 3 || rank > 7)
    throw FormatError(file, "dim[0]", fmt::format("is {}; expected 3 to 7 (a 3D volume, or several)", rank));
  std::array<std::int64_t, 8> dim{};
  for (std::size_t i = 1; i <= std::size_t(rank); ++i) {
    dim[i] = h.dim(i);
    if (dim[i] < 1) throw FormatError(file, fmt::format("dim[{}]", i), fmt::format("is {}; expected >= 1", dim[i]));
  }
  std::int64_t volumes = 1;
  for (std::size_t i = 4; i <= std::size_t(rank); ++i) {
    const auto next = checked_mul(volumes, dim[i]);
    if (!next) throw FormatError(file, "dim", "the volumes of dim[4..7] overflow a 64-bit count (corrupt or hostile header)");
    volumes = *next;
  }
  return {{dim[1], dim[2], dim[3]}, volumes};
}

DType read_dtype(const HeaderBytes& h, const std::string& file) {
  const auto code = h.get<std::int16_t>(h.layout.datatype);
  const auto it = std::find_if(kDatatypeCodes.begin(), kDatatypeCodes.end(), [&](const auto& e) { return e.code == code; });
  if (it == kDatatypeCodes.end())
    throw FormatError(file, "datatype",
                      fmt::format("code {} is not supported; expected one of 2 (u8), 256 (i8), 4 (i16), 512 (u16), "
                                  "8 (i32), 768 (u32), 16 (f32), 64 (f64), 1024 (i64), 1280 (u64)",
                                  code));
  const auto bitpix = h.get<std::int16_t>(h.layout.bitpix);
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
    const double v = h.real(h.layout.pixdim + (h.layout.wide ? 8 : 4) * std::size_t(axis));
    if (v == 0) return 1.0;
    if (!(v > 0) || !std::isfinite(v))
      throw FormatError(file, fmt::format("pixdim[{}]", axis),
                        fmt::format("is {}; expected a positive voxel size (or 0 for unknown, read as 1)", v));
    return v;
  };
  return {size_at(1), size_at(2), size_at(3)};
}

std::uint64_t read_vox_offset(const HeaderBytes& h, const std::string& file) {
  // The upper bound keeps the conversion below defined; no real file is anywhere near it.
  constexpr double kLargest = 0x1p62;
  const double offset = h.layout.wide ? double(h.get<std::int64_t>(h.layout.vox_offset)) : h.get<float>(h.layout.vox_offset);
  if (!std::isfinite(offset) || offset < double(h.layout.header_bytes) || offset != std::floor(offset) || offset > kLargest)
    throw FormatError(file, "vox_offset",
                      fmt::format("is {}; expected a whole number from {} to 2^62", offset, h.layout.header_bytes));
  return std::uint64_t(offset);
}

// Scaling is "set" only when it changes values: slope 0 means unused (nifti1.h), and 1/0 is
// the identity many writers store by default. Non-finite values count as unset, like 0.
std::optional<Scaling> read_scaling(const HeaderBytes& h) {
  const double slope = h.real(h.layout.scl_slope);
  double inter = h.real(h.layout.scl_inter);
  if (!std::isfinite(slope) || slope == 0.0) return std::nullopt;
  if (!std::isfinite(inter)) inter = 0.0;
  if (slope == 1.0 && inter == 0.0) return std::nullopt;
  return Scaling{slope, inter};
}

// qform, sform, their codes and the units, in either layout.
NiftiTransforms read_transforms(const HeaderBytes& h) {
  const OrientationLayout& o = h.layout.orientation;
  const std::size_t real = h.layout.wide ? 8 : 4;
  const auto code = [&](std::size_t offset) {
    return h.layout.wide ? h.get<std::int32_t>(offset) : std::int32_t(h.get<std::int16_t>(offset));
  };
  NiftiTransforms t;
  t.qform_code = code(o.qform_code);
  t.sform_code = code(o.sform_code);
  t.xyzt_units = h.layout.wide ? h.get<std::int32_t>(o.xyzt_units) : std::int32_t(h.get<std::uint8_t>(o.xyzt_units));
  for (std::size_t i = 0; i < 3; ++i) {
    t.quatern[i] = h.real(o.quatern_b + real * i);
    t.qoffset[i] = h.real(o.qoffset_x + real * i);
    for (std::size_t c = 0; c < 4; ++c) t.srow[i][c] = h.real(o.srow_x + real * (4 * i + c));
  }
  t.qfac = h.real(h.layout.pixdim);  // pixdim[0]
  return t;
}

NiftiHeader parse_header(const std::byte* data, std::uint64_t size, const std::string& file) {
  NiftiHeader header;
  std::tie(header.layout, header.big_endian) = detect_layout(data, size, file);
  const HeaderBytes h{{data, header.layout->header_bytes}, header.big_endian ? std::endian::big : std::endian::little,
                      *header.layout};
  check_magic(data, *header.layout, file);
  std::tie(header.stored.dims, header.volumes) = read_dims(h, file);
  header.stored.dtype = read_dtype(h, file);
  header.stored.spacing = read_spacing(h, file);
  header.stored.geometry = nifti_geometry(read_transforms(h), header.stored.spacing, file);
  header.vox_offset = read_vox_offset(h, file);
  header.scaling = read_scaling(h);
  const auto total = checked_mul(checked_volume_bytes(header.stored, file, "dim"), std::uint64_t(header.volumes));
  if (!total || *total > (std::uint64_t(1) << 62))
    throw FormatError(file, "dim", fmt::format("{} volumes of {} do not fit in a 64-bit byte count (corrupt or hostile header)",
                                               header.volumes, header.stored.dims.to_string()));
  header.data_bytes = *total;
  return header;
}

// Where the chosen volume starts: a file of one volume needs no choice; of several, the
// caller's (ReadOptions::volume), which must exist.
std::uint64_t volume_offset(const NiftiHeader& header, const ReadOptions& options, const std::string& file) {
  const std::int64_t t = choose_volume(header.volumes, header.stored.dims, options, file, "dim", "dim[4..7]");
  return header.vox_offset + std::uint64_t(t) * header.stored.byte_size();
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

bool has_gz_name(const fs::path& path) { return ascii_lower(path.filename().string()).ends_with(kGzipSuffix); }

// `file` holds a whole uncompressed NIfTI file; `shown_path` is what the user named.
std::unique_ptr<VolumeSource> source_over(std::shared_ptr<MappedFile> file, const fs::path& shown_path,
                                          const ReadOptions& options) {
  const NiftiHeader header = parse_header(file->data(), file->size(), shown_path.string());
  VolumeInfo info = header.stored;
  info.volumes = header.volumes;
  auto stored = make_mapped_source(std::move(file), volume_offset(header, options, shown_path.string()), info,
                                   header.big_endian, shown_path, "dim");
  if (!header.scaling) return stored;
  return std::make_unique<ScaledSource>(std::move(stored), *header.scaling);
}

// The header is decoded first: its dims, datatype and vox_offset bound what the whole stream
// may decode to, so a stream that inflates to more stops there instead of filling the disk. The
// samples are decoded as reads need them (make_gzip_source).
std::unique_ptr<VolumeSource> open_gzipped(const fs::path& path, std::shared_ptr<MappedFile> compressed,
                                           const ReadOptions& options) {
  const std::string file = path.string();
  const auto head = gunzip_to_memory(compressed->data(), compressed->size(), file, "gzip", kLargestHeader);
  const NiftiHeader header = parse_header(head.data(), head.size(), file);
  VolumeInfo info = header.stored;
  info.volumes = header.volumes;
  const std::uint64_t declared = header.vox_offset + header.data_bytes;  // both below 2^62
  GzipVolume volume{
      .info = info,
      .big_endian = header.big_endian,
      .offset = volume_offset(header, options, file),  // a missing or wrong volume fails before the decode
      .declared = {declared, fmt::format("the header (vox_offset {} + {} x dim {} of {})", header.vox_offset,
                                         header.volumes, header.stored.dims.to_string(), dtype_name(header.stored.dtype))},
      .field = "gzip",
      .report_short = [file, declared](std::uint64_t decoded) {
        throw FormatError(file, "gzip", fmt::format("the decoded stream ends after {} bytes, but the header needs {} "
                                                    "(vox_offset and dim; a truncated file or a wrong header)",
                                                    decoded, declared));
      },
  };
  auto stored = make_gzip_source(std::move(compressed), 0, std::move(volume), path, options);
  if (!header.scaling) return stored;
  return std::make_unique<ScaledSource>(std::move(stored), *header.scaling);
}

// NIfTI-1 when every dimension fits its 16-bit dim (what every reader takes), else NIfTI-2.
const HeaderLayout& layout_for(const VolumeInfo& info) {
  const auto fits = [](std::int64_t n) { return n <= 32767; };
  return fits(info.dims.x) && fits(info.dims.y) && fits(info.dims.z) ? kNifti1 : kNifti2;
}

// The orientation fields of `t` through the header writers of make_header.
template <class Put, class PutReal>
void put_transforms(const HeaderLayout& layout, const NiftiTransforms& t, const Put& put, const PutReal& put_real) {
  const OrientationLayout& o = layout.orientation;
  const std::size_t real = layout.wide ? 8 : 4;
  const auto put_code = [&](std::size_t offset, std::int32_t v) {
    if (layout.wide) put(offset, v);
    else put(offset, std::int16_t(v));
  };
  put_code(o.qform_code, t.qform_code);
  put_code(o.sform_code, t.sform_code);
  if (layout.wide) put(o.xyzt_units, std::int32_t(t.xyzt_units));
  else put(o.xyzt_units, std::uint8_t(t.xyzt_units));
  for (std::size_t i = 0; i < 3; ++i) {
    put_real(o.quatern_b + real * i, t.quatern[i]);
    put_real(o.qoffset_x + real * i, t.qoffset[i]);
    for (std::size_t c = 0; c < 4; ++c) put_real(o.srow_x + real * (4 * i + c), t.srow[i][c]);
  }
}

// The header and the empty extension flag for one 3D volume of `info`, little endian.
std::vector<std::byte> make_header(const VolumeInfo& info) {
  const HeaderLayout& layout = layout_for(info);
  std::vector<std::byte> bytes(layout.data_offset());
  const auto put = [&](std::size_t offset, auto value) { store_field(std::span(bytes), offset, value); };
  // Wide fields (NIfTI-2) are i64 and f64, NIfTI-1's i16 and f32.
  const auto put_dim = [&](std::size_t i, std::int64_t v) {
    if (layout.wide) put(layout.dim + 8 * i, v);
    else put(layout.dim + 2 * i, std::int16_t(v));
  };
  const auto put_real = [&](std::size_t offset, double v) {
    if (layout.wide) put(offset, v);
    else put(offset, float(v));
  };
  put(0, std::int32_t(layout.header_bytes));
  std::memcpy(bytes.data() + layout.magic, layout.magic_single.data(), layout.magic_single.size());
  const std::array<std::int64_t, 8> dim{3, info.dims.x, info.dims.y, info.dims.z, 1, 1, 1, 1};
  for (std::size_t i = 0; i < dim.size(); ++i) put_dim(i, dim[i]);
  put(layout.datatype, datatype_code(info.dtype));
  put(layout.bitpix, std::int16_t(8 * dtype_size(info.dtype)));
  const NiftiTransforms t = nifti_transforms_for(info.geometry, info.spacing);
  // pixdim[0] is qfac (orientation handedness); unused axes get 1.
  const std::array<double, 8> pixdim{t.qfac, info.spacing.x, info.spacing.y, info.spacing.z, 1.0, 1.0, 1.0, 1.0};
  for (std::size_t i = 0; i < pixdim.size(); ++i) put_real(layout.pixdim + (layout.wide ? 8 : 4) * i, pixdim[i]);
  if (layout.wide) put(layout.vox_offset, std::int64_t(layout.data_offset()));
  else put(layout.vox_offset, float(layout.data_offset()));
  put_real(layout.scl_slope, 0.0);  // 0: samples are the values (no scaling)
  put_real(layout.scl_inter, 0.0);
  put_transforms(layout, t, put, put_real);
  return bytes;
}

void check_writable(const fs::path& path, const VolumeInfo& info) {
  if (info.dtype == DType::i8)
    throw Error(fmt::format("{}: NIfTI writing does not support i8 (many readers reject it); convert to i16",
                            path.string()));
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

std::unique_ptr<VolumeSource> open_nifti(const std::filesystem::path& path, const ReadOptions& options) {
  auto file = std::make_shared<MappedFile>(path);
  // Content decides, so a compressed file named .nii still opens; a .gz name that is not gzip
  // is reported by the decoder as a bad gzip stream rather than as a bad NIfTI header.
  if (has_gz_name(path) || looks_gzipped(file->data(), file->size())) return open_gzipped(path, std::move(file), options);
  return source_over(std::move(file), path, options);
}

std::unique_ptr<VolumeWriter> create_nifti_writer(const std::filesystem::path& path, const VolumeInfo& info,
                                                  const WriteOptions&) {
  check_writable(path, info);
  return std::make_unique<NiftiWriter>(path, info);
}

// The sniffer: sizeof_hdr of either version in either byte order (as detect_layout reads it)
// and that version's magic, of a single file or of a .hdr/.img pair (which the reader then
// refuses by name).
bool has_nifti_magic(std::span<const std::byte> head) {
  if (head.size() < 4) return false;
  for (const std::endian order : {std::endian::little, std::endian::big})
    for (const HeaderLayout* layout : {&kNifti1, &kNifti2}) {
      if (load_field<std::int32_t>(head.first(4), 0, order) != std::int32_t(layout->header_bytes)) continue;
      for (const std::string_view magic : {layout->magic_single, layout->magic_pair})
        if (head.size() >= layout->magic + magic.size() &&
            std::memcmp(head.data() + layout->magic, magic.data(), magic.size()) == 0)
          return true;
    }
  return false;
}

}  // namespace

VolumeFormat nifti_format() {
  return {
      .name = "nifti",
      .title = "NIfTI-1, NIfTI-2",
      .description = "neuroimaging volumes: a 348- or 540-byte header and the samples in one file, plain or gzip",
      .extensions = {".nii", ".nii.gz"},
      .magic_bytes = kNifti1.magic + kNifti1.magic_single.size(),
      .sniff = has_nifti_magic,
      .open = open_nifti,
      .create_writer = create_nifti_writer,
      .capabilities = {.streaming = true, .multi_volume = true, .spatial_metadata = true},
      // NIfTI-1 has an int8 code, but many readers mishandle it, so we never write i8 there.
      .write_dtypes = DTypeSet::all().without(DType::i8),
      .read_notes = "either byte order; scl_slope/scl_inter applied (to float) when set; files of several volumes "
                    "(dim[0] > 3: time series, components) one volume at a time with `--volume T`, alias "
                    "`--component N` or `--time T` (`info`, `convert`, `compress`, `labels encode`, `render`, "
                    "`serve`, `eval`; `info` describes volume 0 and says how many there are; `--all-volumes` stores "
                    "them all in one `.strata`)",
      .write_notes = "NIfTI-2 only when a dimension exceeds NIfTI-1's 32767; gzip for a `.nii.gz` name",
  };
}

}  // namespace strata::io::detail
