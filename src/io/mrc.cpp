// MRC / MRCS / REC / CCP4 map volumes (cryo-EM, cryo-ET), as the MRC2014 standard defines them:
// a 1024-byte header, an extended header of `nsymbt` bytes (skipped), then x-fastest samples,
// memory-mapped. The voxel size is the cell length over the sampling (xlen / mx). Read: modes 0
// (int8), 1 (int16), 2 (float32) and 6 (uint16), either byte order (machine stamp), columns, rows
// and sections in x, y, z order. Written: the same four modes, little-endian, with the sample
// statistics (dmin, dmax, dmean, rms) patched into the header at the end; uint8 samples (most
// EM volumes) are widened to mode 6 (uint16), as the reference library mrcfile does, because
// MRC2014's mode 0 is signed.
//
// Header fields read or written (byte offset, type; MRC2014):
// | offset | type     | field                 | here                                            |
// | ------ | -------- | --------------------- | ----------------------------------------------- |
// | 0      | 3 x i32  | nx, ny, nz            | dims (columns, rows, sections)                  |
// | 12     | i32      | mode                  | 0 i8, 1 i16, 2 f32, 6 u16, 12 f16 (as f32)      |
// | 28     | 3 x i32  | mx, my, mz            | sampling of the cell                            |
// | 40     | 3 x f32  | xlen, ylen, zlen      | cell size in Å: spacing = xlen / mx             |
// | 64     | 3 x i32  | mapc, mapr, maps      | axis order; only 1, 2, 3 is read                |
// | 76     | 4 x f32  | dmin, dmax, dmean     | written from the samples (rms at 216)           |
// | 88     | i32      | ispg                  | written 1 (a volume)                            |
// | 92     | i32      | nsymbt                | extended header bytes, skipped                  |
// | 108    | i32      | nversion              | written 20140                                   |
// | 16     | 3 x i32  | nxstart, ny.., nz..   | origin in voxels when the origin field is 0     |
// | 196    | 3 x f32  | origin                | Å: the position of voxel 0 (geometry origin)    |
// | 208    | char[4]  | map                   | "MAP ": the signature sniffed                   |
// | 212    | u8[4]    | machst                | 0x44 0x44: little-endian, 0x11 0x11: big-endian |
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <optional>
#include <string_view>

#include <fmt/format.h>

#include "io/builtin_formats.hpp"
#include "io/io_detail.hpp"
#include "strata/core/bytes.hpp"
#include "strata/core/error.hpp"

namespace strata::io::detail {

namespace {

constexpr std::size_t kHeaderBytes = 1024;
constexpr std::size_t kMapOffset = 208, kStampOffset = 212;
constexpr std::string_view kMapSignature = "MAP ";
// The largest extended header a reader takes (FEI/EPU headers are a few MB).
constexpr std::int32_t kMaxExtendedHeader = 1 << 30;

constexpr double kAngstrom = 1e-10;  // metres

// The origin field (Å) places voxel 0; files that leave it 0 and set nxstart.. (older CCP4
// maps) are placed by those, in voxels. The axes are the map's: no rotation, no anatomy.
template <class I32, class F32>
Geometry geometry_of(const I32& i32, const F32& f32, const double (&spacing)[3]) {
  Geometry g;
  g.unit = "angstrom";
  bool origin_set = false;
  for (std::size_t a = 0; a < 3; ++a) {
    const float o = f32(196 + 4 * a);
    g.origin[a] = std::isfinite(o) ? double(o) : 0.0;
    origin_set = origin_set || g.origin[a] != 0.0;
  }
  if (!origin_set)
    for (std::size_t a = 0; a < 3; ++a) g.origin[a] = double(i32(16 + 4 * a)) * spacing[a];
  return g;
}

struct ModeType {
  std::int32_t mode;
  DType dtype;
};
// The modes whose samples are one of Strata's sample types.
constexpr std::array<ModeType, 4> kModes{{{0, DType::i8}, {1, DType::i16}, {2, DType::f32}, {6, DType::u16}}};
// IEEE half precision, read as float32 (no Strata sample type holds it).
constexpr std::int32_t kFloat16Mode = 12;

// The float32 of an IEEE binary16 value: exact for every half (normal, subnormal, zero, infinity
// and NaN).
float half_to_float(std::uint16_t h) {
  const std::uint32_t sign = std::uint32_t(h & 0x8000u) << 16;
  const std::uint32_t exponent = (h >> 10) & 0x1Fu, mantissa = h & 0x3FFu;
  if (exponent == 0x1F) return std::bit_cast<float>(sign | 0x7F800000u | (mantissa << 13));  // inf, NaN
  if (exponent != 0) return std::bit_cast<float>(sign | ((exponent + 112) << 23) | (mantissa << 13));
  // Zero and subnormals: mantissa * 2^-24, exact in float.
  const float magnitude = float(mantissa) * 0x1p-24f;
  return sign ? -magnitude : magnitude;
}

// Mode 12 samples served as float32: each box is converted from the mapped halves.
class Float16Source final : public VolumeSource {
 public:
  Float16Source(std::shared_ptr<MappedFile> file, std::uint64_t offset, VolumeInfo info, bool big_endian,
                std::filesystem::path path)
      : file_(std::move(file)), offset_(offset), info_(info), big_endian_(big_endian), path_(std::move(path)) {}
  const VolumeInfo& info() const override { return info_; }
  const std::filesystem::path& path() const override { return path_; }
  Volume read_box(const Box& box) override {
    check_box_inside(box, info_.dims, path_);
    Volume out(box.size(), DType::f32, info_.spacing);
    float* dst = out.samples<float>().data();
    const Extent& d = info_.dims;
    for (std::int64_t z = box.lo.z; z < box.hi.z; ++z)
      for (std::int64_t y = box.lo.y; y < box.hi.y; ++y) {
        const std::uint64_t first = std::uint64_t((z * d.y + y) * d.x + box.lo.x);
        const std::byte* src = file_->data() + offset_ + 2 * first;
        for (std::int64_t x = box.lo.x; x < box.hi.x; ++x, src += 2) {
          const auto lo = std::to_integer<std::uint16_t>(src[big_endian_ ? 1 : 0]);
          const auto hi = std::to_integer<std::uint16_t>(src[big_endian_ ? 0 : 1]);
          *dst++ = half_to_float(std::uint16_t(lo | (hi << 8)));
        }
      }
    // The pages read go back to the page cache, as the other mapped sources' do: a tomogram
    // larger than memory streams through.
    const auto first = std::uint64_t((box.lo.z * d.y + box.lo.y) * d.x + box.lo.x);
    const auto last = std::uint64_t(((box.hi.z - 1) * d.y + box.hi.y - 1) * d.x + box.hi.x);
    file_->release(offset_ + 2 * first, 2 * (last - first));
    return out;
  }

 private:
  std::shared_ptr<MappedFile> file_;
  std::uint64_t offset_;
  VolumeInfo info_;
  bool big_endian_;
  std::filesystem::path path_;
};

bool has_mrc_signature(std::span<const std::byte> head) {
  return head.size() >= kMapOffset + kMapSignature.size() &&
         std::memcmp(head.data() + kMapOffset, kMapSignature.data(), kMapSignature.size()) == 0;
}

std::string mode_problem(std::int32_t mode) {
  if (mode == 3 || mode == 4) return fmt::format("mode {} holds complex samples, which a volume cannot", mode);
  return fmt::format("unknown mode {} (expected 0 int8, 1 int16, 2 float32, 6 uint16 or 12 float16)", mode);
}

struct MrcLayout {
  VolumeInfo info;
  bool float16 = false;  // mode 12: info.dtype is f32, the file holds 2 bytes a sample
  std::uint64_t data_offset = kHeaderBytes;
  bool big_endian = false;
};

MrcLayout parse_header(const std::filesystem::path& path, std::span<const std::byte> header) {
  const std::string file = path.string();
  if (header.size() < kHeaderBytes)
    throw FormatError(file, "header", fmt::format("{} bytes, an MRC header has {}", header.size(), kHeaderBytes));
  MrcLayout layout;
  const auto stamp = std::to_integer<unsigned>(header[kStampOffset]);
  layout.big_endian = stamp == 0x11;
  const std::endian order = layout.big_endian ? std::endian::big : std::endian::little;
  const auto i32 = [&](std::size_t at) { return load_field<std::int32_t>(header, at, order); };
  const auto f32 = [&](std::size_t at) { return load_field<float>(header, at, order); };

  const std::int32_t n[3] = {i32(0), i32(4), i32(8)};
  for (int a = 0; a < 3; ++a)
    if (n[a] < 1) throw FormatError(file, "nx, ny, nz", fmt::format("must be positive, got {} {} {}", n[0], n[1], n[2]));
  layout.info.dims = {n[0], n[1], n[2]};
  const std::int32_t mode = i32(12);
  const auto type = std::find_if(kModes.begin(), kModes.end(), [&](const ModeType& m) { return m.mode == mode; });
  layout.float16 = mode == kFloat16Mode;
  if (type == kModes.end() && !layout.float16) throw FormatError(file, "mode", mode_problem(mode));
  layout.info.dtype = layout.float16 ? DType::f32 : type->dtype;
  if (i32(64) != 1 || i32(68) != 2 || i32(72) != 3)
    throw FormatError(file, "mapc, mapr, maps",
                      fmt::format("axis order {} {} {} is not read yet (expected 1 2 3: columns along x)", i32(64),
                                  i32(68), i32(72)));
  // Voxel size: the cell length over its sampling; 1 where the header leaves either at 0.
  double spacing[3] = {1, 1, 1};
  for (int a = 0; a < 3; ++a) {
    const std::int32_t m = i32(28 + 4 * std::size_t(a));
    const float length = f32(40 + 4 * std::size_t(a));
    if (m > 0 && std::isfinite(length) && length > 0) spacing[a] = double(length) / m;
  }
  layout.info.spacing = {spacing[0], spacing[1], spacing[2]};
  layout.info.geometry = geometry_of(i32, f32, spacing);
  const std::int32_t extended = i32(92);
  if (extended < 0 || extended > kMaxExtendedHeader)
    throw FormatError(file, "nsymbt", fmt::format("extended header of {} bytes (expected 0..{})", extended, kMaxExtendedHeader));
  layout.data_offset = kHeaderBytes + std::uint64_t(extended);
  return layout;
}

std::unique_ptr<VolumeSource> open_mrc(const std::filesystem::path& path, const ReadOptions&) {
  auto file = std::make_shared<MappedFile>(path);
  const MrcLayout layout = parse_header(path, {file->data(), std::min<std::uint64_t>(file->size(), kHeaderBytes)});
  // The dims come from the file: a product past 2^63 bytes is a damaged header, not a size.
  const std::optional<std::int64_t> voxels = layout.info.dims.checked_voxel_count();
  const std::uint64_t sample_size = layout.float16 ? 2 : dtype_size(layout.info.dtype);
  if (!voxels || std::uint64_t(*voxels) > (std::numeric_limits<std::uint64_t>::max() / 2 - layout.data_offset) / sample_size)
    throw FormatError(path.string(), "nx, ny, nz",
                      fmt::format("{} voxels do not fit in a file", layout.info.dims.to_string()));
  const std::uint64_t expected = layout.data_offset + std::uint64_t(*voxels) * sample_size;
  if (file->size() != expected)
    throw FormatError(path.string(), "size",
                      fmt::format("expected {} bytes ({}-byte headers, then {} {}), found {}", expected,
                                  layout.data_offset, layout.info.dims.to_string(),
                                  layout.float16 ? "f16" : dtype_name(layout.info.dtype), file->size()));
  if (layout.float16)
    return std::make_unique<Float16Source>(std::move(file), layout.data_offset, layout.info, layout.big_endian, path);
  return make_mapped_source(std::move(file), layout.data_offset, layout.info, layout.big_endian, path, "size");
}

// Writes the header with placeholder statistics, the slabs as they come, then the statistics.
class MrcWriter final : public VolumeWriter {
 public:
  MrcWriter(const std::filesystem::path& path, const VolumeInfo& info) : out_(path), info_(info) {
    widen_ = info.dtype == DType::u8;
    const DType stored = widen_ ? DType::u16 : info.dtype;
    const auto type = std::find_if(kModes.begin(), kModes.end(), [&](const ModeType& m) { return m.dtype == stored; });
    if (type == kModes.end())
      throw Error(fmt::format("{}: MRC stores uint8 (as uint16), int8, int16, uint16 or float32 samples, not {}",
                              path.string(), dtype_name(info.dtype)));
    mode_ = type->mode;
    const std::array<std::byte, kHeaderBytes> header = make_header();
    out_.write(header.data(), header.size());
  }

  void write_slab(const Volume& slab) override {
    visit_dtype(slab.dtype(), [&](auto tag) {
      using T = decltype(tag);
      for (T v : slab.samples<T>()) {
        const double d = double(v);
        if (!std::isfinite(d)) continue;
        lo_ = std::min(lo_, d);
        hi_ = std::max(hi_, d);
        sum_ += d;
        sum_squares_ += d * d;
        ++count_;
      }
    });
    if (widen_) {
      const Volume wide = slab.converted(DType::u16);
      out_.write(wide.bytes(), wide.byte_size());
    } else {
      out_.write(slab.bytes(), slab.byte_size());
    }
  }

  void finish() override {
    // The statistics of the finite samples; MRC2014 marks unknown ones with dmax < dmin.
    std::array<std::byte, 16> stats{};
    const double mean = count_ > 0 ? sum_ / double(count_) : 0;
    const double rms = count_ > 0 ? std::sqrt(std::max(0.0, sum_squares_ / double(count_) - mean * mean)) : -1;
    store_field(stats, 0, float(count_ > 0 ? lo_ : 0));
    store_field(stats, 4, float(count_ > 0 ? hi_ : -1));
    store_field(stats, 8, float(mean));
    std::array<std::byte, 4> rms_field{};
    store_field(rms_field, 0, float(rms));
    patch_output(out_, 76, stats, "the MRC header's statistics");
    patch_output(out_, 216, rms_field, "the MRC header's statistics");
    out_.commit();
  }

 private:
  std::array<std::byte, kHeaderBytes> make_header() const {
    std::array<std::byte, kHeaderBytes> h{};
    const std::int64_t n[3] = {info_.dims.x, info_.dims.y, info_.dims.z};
    // MRC lengths are Å: a known unit is converted, an unknown one written as it is.
    const double metres = metres_per_unit(info_.geometry.unit);
    const double scale = metres > 0 ? metres / kAngstrom : 1.0;
    const double s[3] = {info_.spacing.x * scale, info_.spacing.y * scale, info_.spacing.z * scale};
    for (std::size_t a = 0; a < 3; ++a) {
      store_field(h, 4 * a, std::int32_t(n[a]));
      store_field(h, 28 + 4 * a, std::int32_t(n[a]));           // mx, my, mz: one cell = the volume
      store_field(h, 40 + 4 * a, float(double(n[a]) * s[a]));  // xlen, ylen, zlen
      store_field(h, 52 + 4 * a, 90.0f);                       // cell angles
      store_field(h, 64 + 4 * a, std::int32_t(a + 1));         // mapc, mapr, maps
      store_field(h, 196 + 4 * a, float(info_.geometry.origin[a] * scale));
    }
    store_field(h, 12, mode_);
    store_field(h, 88, std::int32_t(1));  // ispg: a volume
    store_field(h, 108, std::int32_t(20140));
    std::memcpy(h.data() + kMapOffset, kMapSignature.data(), kMapSignature.size());
    h[kStampOffset] = h[kStampOffset + 1] = std::byte{0x44};  // little-endian
    store_field(h, 220, std::int32_t(1));                     // one label
    constexpr std::string_view label = "Strata";
    std::memcpy(h.data() + 224, label.data(), label.size());
    return h;
  }


  AtomicOutputFile out_;
  VolumeInfo info_;
  std::int32_t mode_ = 0;
  bool widen_ = false;  // uint8 samples stored as mode 6
  double lo_ = std::numeric_limits<double>::infinity(), hi_ = -std::numeric_limits<double>::infinity();
  double sum_ = 0, sum_squares_ = 0;
  std::uint64_t count_ = 0;
};

std::unique_ptr<VolumeWriter> create_mrc_writer(const std::filesystem::path& path, const VolumeInfo& info,
                                                const WriteOptions&) {
  return std::make_unique<MrcWriter>(path, info);
}

}  // namespace

VolumeFormat mrc_format() {
  return {
      .name = "mrc",
      .title = "MRC",
      .description = "cryo-EM and cryo-ET maps, stacks and tomograms (MRC2014): a 1024-byte header, then the samples",
      .extensions = {".mrc", ".mrcs", ".rec", ".map"},
      .magic_bytes = kMapOffset + kMapSignature.size(),
      .sniff = has_mrc_signature,
      .open = open_mrc,
      .create_writer = create_mrc_writer,
      .capabilities = {.streaming = true, .multi_volume = false, .spatial_metadata = true},
      .read_dtypes = {DType::i8, DType::i16, DType::u16, DType::f32},
      .write_dtypes = {DType::u8, DType::i8, DType::i16, DType::u16, DType::f32},
      .read_notes = "modes 0 (int8), 1 (int16), 2 (float32), 6 (uint16), 12 (float16, read as f32), either byte "
                    "order; voxel size from the cell (xlen / mx); extended headers skipped; memory-mapped",
      .write_notes = "the same modes, little-endian, with dmin/dmax/dmean/rms of the samples; u8 as mode 6 (u16), as "
                     "mrcfile writes it (mode 0 is signed)",
  };
}

}  // namespace strata::io::detail
