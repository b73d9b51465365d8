// TIFF stacks through libtiff: one multi-page file (a page per slice) or a folder of
// single-page slices in natural file-name order. Reading opens only the pages a request
// touches; writing emits a page per slice as slabs arrive.
#include <tiffio.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdarg>
#include <cstring>
#include <mutex>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "io/builtin_formats.hpp"
#include "io/io_detail.hpp"
#include "strata/io/file_names.hpp"

namespace strata::io::detail {

namespace {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------------------------
// libtiff handle

// One open TIFF. libtiff reports problems through callbacks; each handle collects its own
// messages so they reach our exceptions (not stderr) and concurrent handles never mix them.
class TiffFile {
 public:
  TiffFile(const fs::path& path, const char* mode) : path_(path) {
    TIFFOpenOptions* options = TIFFOpenOptionsAlloc();
    TIFFOpenOptionsSetErrorHandlerExtR(options, &TiffFile::on_error, this);
    TIFFOpenOptionsSetWarningHandlerExtR(options, &TiffFile::on_warning, this);
    tif_ = TIFFOpenExt(path.c_str(), mode, options);
    TIFFOpenOptionsFree(options);
    if (!tif_) {
      const bool reading = mode[0] == 'r';
      throw FormatError(path.string(), reading ? "TIFF header" : "TIFF output",
                        fmt::format("cannot {}: {}", reading ? "open as TIFF" : "create", take_errors()));
    }
  }
  ~TiffFile() {
    if (tif_) TIFFClose(tif_);
  }
  TiffFile(const TiffFile&) = delete;
  TiffFile& operator=(const TiffFile&) = delete;

  TIFF* get() const { return tif_; }
  const fs::path& path() const { return path_; }

  // Messages libtiff reported since the last call (or "no details" when it said nothing).
  std::string take_errors() {
    std::string text = errors_.empty() ? "libtiff gave no details" : errors_;
    errors_.clear();
    return text;
  }
  bool has_errors() const { return !errors_.empty(); }

  // Writers: flushes, forces the bytes to disk (a full disk must fail here, not later) and closes.
  void close_written() {
    const bool flushed = TIFFFlush(tif_) == 1;
    const bool synced = flushed && ::fsync(TIFFFileno(tif_)) == 0;
    const std::string why = synced ? "" : (flushed ? std::string(std::strerror(errno)) : take_errors());
    TIFFClose(tif_);
    tif_ = nullptr;
    if (!synced) throw Error(fmt::format("{}: cannot finish writing: {}", path_.string(), why));
  }

 private:
  static int on_error(TIFF*, void* user, const char*, const char* format, va_list args) {
    auto* self = static_cast<TiffFile*>(user);
    char text[512];
    std::vsnprintf(text, sizeof text, format, args);
    if (!self->errors_.empty()) self->errors_ += "; ";
    self->errors_ += text;
    return 1;  // handled: do not also print to stderr
  }
  // Warnings (unknown private tags and the like) do not affect the samples we read.
  static int on_warning(TIFF*, void*, const char*, const char*, va_list) { return 1; }

  fs::path path_;
  std::string errors_;
  TIFF* tif_ = nullptr;
};

// ---------------------------------------------------------------------------------------------
// Page format

// The tags that must agree across all pages of a stack, and the channel a source reads.
struct PageFormat {
  std::uint32_t width = 0, height = 0;
  std::uint16_t bits = 0, sample_format = SAMPLEFORMAT_UINT, samples = 1;
  std::uint16_t planar = PLANARCONFIG_CONTIG;  // channels interleaved per pixel, or each in strips of its own
  std::uint16_t channel = 0;                   // of `samples`: the volume read (ReadOptions::volume)
};

std::uint16_t uint16_tag(TIFF* tif, ttag_t tag) {
  std::uint16_t value = 0;
  TIFFGetFieldDefaulted(tif, tag, &value);
  return value;
}

std::uint32_t required_uint32_tag(TiffFile& file, ttag_t tag, const std::string& where, const char* name) {
  std::uint32_t value = 0;
  if (TIFFGetField(file.get(), tag, &value) != 1 || value == 0)
    throw FormatError(where, name, "missing or zero");
  return value;
}

PageFormat read_page_format(TiffFile& file, const std::string& where) {
  PageFormat f;
  f.width = required_uint32_tag(file, TIFFTAG_IMAGEWIDTH, where, "ImageWidth");
  f.height = required_uint32_tag(file, TIFFTAG_IMAGELENGTH, where, "ImageLength");
  f.bits = uint16_tag(file.get(), TIFFTAG_BITSPERSAMPLE);
  f.sample_format = uint16_tag(file.get(), TIFFTAG_SAMPLEFORMAT);
  f.samples = uint16_tag(file.get(), TIFFTAG_SAMPLESPERPIXEL);
  if (f.samples == 0) throw FormatError(where, "SamplesPerPixel", "is 0; expected 1 or more channels");
  f.planar = uint16_tag(file.get(), TIFFTAG_PLANARCONFIG);
  if (f.planar != PLANARCONFIG_CONTIG && f.planar != PLANARCONFIG_SEPARATE)
    throw FormatError(where, "PlanarConfiguration", fmt::format("is {}; expected 1 (chunky) or 2 (planar)", f.planar));
  // Rows stored bottom-up or transposed would come out mirrored; refuse rather than guess.
  const std::uint16_t orientation = uint16_tag(file.get(), TIFFTAG_ORIENTATION);
  if (orientation != ORIENTATION_TOPLEFT)
    throw FormatError(where, "Orientation", fmt::format("is {}; only 1 (top-left) is supported", orientation));
  return f;
}

DType dtype_of_format(const PageFormat& f, const std::string& where) {
  const bool uint = f.sample_format == SAMPLEFORMAT_UINT, sint = f.sample_format == SAMPLEFORMAT_INT;
  const bool real = f.sample_format == SAMPLEFORMAT_IEEEFP;
  if (uint && f.bits == 8) return DType::u8;
  if (uint && f.bits == 16) return DType::u16;
  if (uint && f.bits == 32) return DType::u32;
  if (uint && f.bits == 64) return DType::u64;
  if (sint && f.bits == 8) return DType::i8;
  if (sint && f.bits == 16) return DType::i16;
  if (sint && f.bits == 32) return DType::i32;
  if (sint && f.bits == 64) return DType::i64;
  if (real && f.bits == 32) return DType::f32;
  if (real && f.bits == 64) return DType::f64;
  throw FormatError(where, "BitsPerSample/SampleFormat",
                    fmt::format("{} bits with SampleFormat {} is not supported; expected 8/16/32/64-bit unsigned (1) or "
                                "signed (2) integers, or 32/64-bit floats (3)",
                                f.bits, f.sample_format));
}

std::uint16_t sample_format_of(DType t) {
  if (dtype_is_float(t)) return SAMPLEFORMAT_IEEEFP;
  return dtype_is_signed(t) ? SAMPLEFORMAT_INT : SAMPLEFORMAT_UINT;
}

void check_same_format(const PageFormat& page, const PageFormat& first, const std::string& where) {
  auto check = [&](const char* field, std::uint64_t here, std::uint64_t expected) {
    if (here != expected)
      throw FormatError(where, field, fmt::format("is {}, but the first page has {}", here, expected));
  };
  check("ImageWidth", page.width, first.width);
  check("ImageLength", page.height, first.height);
  check("BitsPerSample", page.bits, first.bits);
  check("SampleFormat", page.sample_format, first.sample_format);
  check("SamplesPerPixel", page.samples, first.samples);
  check("PlanarConfiguration", page.planar, first.planar);
}

// Channels: a chunky page interleaves them per pixel (the channel's sample is every
// `samples`-th); a planar page stores each in strips or tiles of its own.
bool chunky(const PageFormat& f) { return f.planar == PLANARCONFIG_CONTIG && f.samples > 1; }

// Copies `count` samples of the format's channel from a decoded row starting at pixel 0 of `in`.
void copy_channel(const PageFormat& f, const std::byte* in, std::size_t count, std::byte* out) {
  const std::size_t sample = f.bits / 8;
  if (!chunky(f)) {
    std::memcpy(out, in, count * sample);
    return;
  }
  for (std::size_t x = 0; x < count; ++x) std::memcpy(out + x * sample, in + (x * f.samples + f.channel) * sample, sample);
}

// ---------------------------------------------------------------------------------------------
// Spacing in ImageDescription: {"spacing":[x,y,z]}

std::string spacing_description(const Spacing& s) {
  return nlohmann::json{{"spacing", {s.x, s.y, s.z}}}.dump();
}

// Descriptions written by other software (ImageJ, microscopes) are not JSON or lack
// "spacing"; those stacks get the default spacing. A "spacing" we cannot use is an error.
Spacing read_spacing(TiffFile& file, const std::string& where) {
  const char* text = nullptr;
  if (TIFFGetField(file.get(), TIFFTAG_IMAGEDESCRIPTION, &text) != 1 || !text) return {};
  const auto json = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (json.is_discarded() || !json.is_object() || !json.contains("spacing")) return {};
  const auto& s = json["spacing"];
  const auto usable = [](const nlohmann::json& v) {
    return v.is_number() && std::isfinite(v.get<double>()) && v.get<double>() > 0;
  };
  if (!s.is_array() || s.size() != 3 || !std::all_of(s.begin(), s.end(), usable))
    throw FormatError(where, "ImageDescription",
                      fmt::format("\"spacing\" is {}; expected [x,y,z] with positive numbers", s.dump()));
  return {s[0].get<double>(), s[1].get<double>(), s[2].get<double>()};
}

// ---------------------------------------------------------------------------------------------
// Reading a rectangle of one page

// The part of a page a request needs: columns [x0, x1), rows [y0, y1).
struct PageRegion {
  std::uint32_t x0, x1, y0, y1;
  std::size_t row_bytes(std::size_t sample) const { return std::size_t(x1 - x0) * sample; }
};

void copy_from_strips(TiffFile& file, const PageFormat& f, const PageRegion& r, std::byte* out,
                      const std::string& where) {
  TIFF* tif = file.get();
  const std::size_t sample = f.bits / 8, pixel = sample * (chunky(f) ? f.samples : 1);
  const std::size_t page_row = std::size_t(f.width) * pixel, out_row = r.row_bytes(sample);
  const tsample_t plane = f.planar == PLANARCONFIG_SEPARATE ? tsample_t(f.channel) : 0;
  std::uint32_t rows_per_strip = 0;
  TIFFGetFieldDefaulted(tif, TIFFTAG_ROWSPERSTRIP, &rows_per_strip);
  rows_per_strip = std::clamp<std::uint32_t>(rows_per_strip, 1, f.height);
  std::vector<std::byte> strip(std::size_t(std::max<tmsize_t>(TIFFStripSize(tif), 0)));
  for (std::uint32_t y = r.y0; y < r.y1;) {
    const std::uint32_t strip_y0 = y / rows_per_strip * rows_per_strip;
    const std::uint32_t strip_y1 = std::min(f.height, strip_y0 + rows_per_strip);
    const tmsize_t needed = tmsize_t(strip_y1 - strip_y0) * tmsize_t(page_row);
    const tmsize_t got = TIFFReadEncodedStrip(tif, TIFFComputeStrip(tif, y, plane), strip.data(), tmsize_t(strip.size()));
    if (got < needed)
      throw FormatError(where, "StripByteCounts",
                        fmt::format("rows {}..{} could not be decoded: {}", strip_y0, strip_y1, file.take_errors()));
    for (; y < std::min(strip_y1, r.y1); ++y)
      copy_channel(f, strip.data() + std::size_t(y - strip_y0) * page_row + r.x0 * pixel, r.x1 - r.x0,
                   out + std::size_t(y - r.y0) * out_row);
  }
}

void copy_from_tiles(TiffFile& file, const PageFormat& f, const PageRegion& r, std::byte* out,
                     const std::string& where) {
  TIFF* tif = file.get();
  const std::size_t sample = f.bits / 8, pixel = sample * (chunky(f) ? f.samples : 1), out_row = r.row_bytes(sample);
  const tsample_t plane = f.planar == PLANARCONFIG_SEPARATE ? tsample_t(f.channel) : 0;
  std::uint32_t tile_w = 0, tile_h = 0;
  if (TIFFGetField(tif, TIFFTAG_TILEWIDTH, &tile_w) != 1 || TIFFGetField(tif, TIFFTAG_TILELENGTH, &tile_h) != 1 ||
      tile_w == 0 || tile_h == 0)
    throw FormatError(where, "TileWidth/TileLength", "missing or zero in a tiled page");
  std::vector<std::byte> tile(std::size_t(std::max<tmsize_t>(TIFFTileSize(tif), 0)));
  const std::size_t tile_row = std::size_t(tile_w) * pixel;
  if (tile.size() < tile_row * tile_h) throw FormatError(where, "TileWidth/TileLength", file.take_errors());
  for (std::uint32_t ty = r.y0 / tile_h * tile_h; ty < r.y1; ty += tile_h) {
    for (std::uint32_t tx = r.x0 / tile_w * tile_w; tx < r.x1; tx += tile_w) {
      const tmsize_t got = TIFFReadEncodedTile(tif, TIFFComputeTile(tif, tx, ty, 0, plane), tile.data(), tmsize_t(tile.size()));
      if (got < tmsize_t(tile_row * tile_h))
        throw FormatError(where, "TileByteCounts",
                          fmt::format("tile at x {}, y {} could not be decoded: {}", tx, ty, file.take_errors()));
      const std::uint32_t x0 = std::max(r.x0, tx), x1 = std::min(r.x1, tx + tile_w);
      for (std::uint32_t y = std::max(r.y0, ty); y < std::min(r.y1, ty + tile_h); ++y)
        copy_channel(f, tile.data() + std::size_t(y - ty) * tile_row + std::size_t(x0 - tx) * pixel, x1 - x0,
                     out + std::size_t(y - r.y0) * out_row + std::size_t(x0 - r.x0) * sample);
    }
  }
}

void copy_region(TiffFile& file, const PageFormat& f, const PageRegion& r, std::byte* out, const std::string& where) {
  if (TIFFIsTiled(file.get()))
    copy_from_tiles(file, f, r, out, where);
  else
    copy_from_strips(file, f, r, out, where);
}

// ---------------------------------------------------------------------------------------------
// Natural file-name order: digit runs compare as numbers, so slice_2 < slice_10.

// Compares the digit runs starting at a[i] and b[j] by value; advances i and j past them.
int compare_numbers(const std::string& a, std::size_t& i, const std::string& b, std::size_t& j) {
  auto run = [](const std::string& s, std::size_t& k) {
    while (k < s.size() && s[k] == '0' && k + 1 < s.size() && std::isdigit(static_cast<unsigned char>(s[k + 1]))) ++k;
    const std::size_t start = k;
    while (k < s.size() && std::isdigit(static_cast<unsigned char>(s[k]))) ++k;
    return std::string_view(s).substr(start, k - start);
  };
  const std::string_view x = run(a, i), y = run(b, j);
  if (x.size() != y.size()) return x.size() < y.size() ? -1 : 1;
  return x.compare(y);
}

bool natural_less(const std::string& a, const std::string& b) {
  std::size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    const bool digit_a = std::isdigit(static_cast<unsigned char>(a[i])), digit_b = std::isdigit(static_cast<unsigned char>(b[j]));
    if (digit_a && digit_b) {
      if (int c = compare_numbers(a, i, b, j); c != 0) return c < 0;
      continue;
    }
    if (a[i] != b[j]) return static_cast<unsigned char>(a[i]) < static_cast<unsigned char>(b[j]);
    ++i, ++j;
  }
  if (a.size() - i != b.size() - j) return a.size() - i < b.size() - j;
  return a < b;  // equal by value ("slice_01" vs "slice_1"): any fixed order will do
}

// The entry's extensions: the names of multi-page files and of the slices in a folder (the
// first is what the folder writer names its slices).
const std::array<std::string_view, 2> kExtensions{".tif", ".tiff"};

bool has_tiff_extension(const fs::path& p) {
  const std::string ext = ascii_lower(p.extension().string());
  return std::find(kExtensions.begin(), kExtensions.end(), ext) != kExtensions.end();
}

// ".tif/.tiff", for messages.
std::string extensions_text() { return fmt::format("{}", fmt::join(kExtensions, "/")); }

// Slices of a folder: *.tif / *.tiff files, naturally sorted. Hidden files are skipped
// (macOS leaves "._slice_0001.tif" metadata files next to real slices).
std::vector<fs::path> list_slice_files(const fs::path& dir) {
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (entry.is_regular_file() && has_tiff_extension(entry.path()) && !name.starts_with(".")) files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end(),
            [](const fs::path& a, const fs::path& b) { return natural_less(a.filename().string(), b.filename().string()); });
  if (files.empty())
    throw FormatError(dir.string(), "slices", fmt::format("the folder has no {} files", extensions_text()));
  return files;
}

// ---------------------------------------------------------------------------------------------
// Source

// Where a slice lives: a file and, in a multi-page file, the byte offset of its directory
// (so any page is reached in one seek instead of walking the chain of directories).
struct Page {
  fs::path file;
  std::uint64_t directory_offset = 0;
  std::string label;  // names the page in errors: "<file> page <n>" or the slice file
};

class TiffSource final : public VolumeSource {
 public:
  // `shared_file` is the open multi-page file, or null for a folder (one file per page).
  TiffSource(fs::path path, VolumeInfo info, PageFormat format, std::vector<Page> pages,
             std::unique_ptr<TiffFile> shared_file)
      : path_(std::move(path)), info_(info), format_(format), pages_(std::move(pages)),
        shared_file_(std::move(shared_file)) {}

  const VolumeInfo& info() const override { return info_; }
  const fs::path& path() const override { return path_; }

  Volume read_box(const Box& box) override {
    check_box_inside(box, info_.dims, path_);
    Volume out(box.size(), info_.dtype, info_.spacing);
    const PageRegion region{std::uint32_t(box.lo.x), std::uint32_t(box.hi.x), std::uint32_t(box.lo.y),
                            std::uint32_t(box.hi.y)};
    const std::size_t slice_bytes = std::size_t(box.size().x * box.size().y) * dtype_size(info_.dtype);
    for (std::int64_t z = box.lo.z; z < box.hi.z; ++z)
      read_page(pages_[std::size_t(z)], region, out.bytes() + std::size_t(z - box.lo.z) * slice_bytes);
    return out;
  }

 private:
  void read_page(const Page& page, const PageRegion& region, std::byte* out) {
    if (!shared_file_) {
      TiffFile file(page.file, "r");
      copy_checked(file, page, region, out);
      return;
    }
    // One libtiff handle has one current directory: requests take turns.
    std::lock_guard lock(shared_mutex_);
    if (TIFFSetSubDirectory(shared_file_->get(), page.directory_offset) != 1)
      throw FormatError(page.label, "IFD", fmt::format("cannot read the page directory: {}", shared_file_->take_errors()));
    copy_checked(*shared_file_, page, region, out);
  }

  // Files can change between open and read (a folder being rewritten): re-check the page.
  void copy_checked(TiffFile& file, const Page& page, const PageRegion& region, std::byte* out) {
    check_same_format(read_page_format(file, page.label), format_, page.label);
    copy_region(file, format_, region, out, page.label);
  }

  fs::path path_;
  VolumeInfo info_;
  PageFormat format_;
  std::vector<Page> pages_;
  std::unique_ptr<TiffFile> shared_file_;
  std::mutex shared_mutex_;
};

VolumeInfo info_from(const PageFormat& f, std::int64_t pages, const Spacing& spacing, const std::string& where) {
  VolumeInfo info{{f.width, f.height, pages}, dtype_of_format(f, where), spacing};
  checked_volume_bytes(info, where, "ImageWidth/ImageLength");
  info.volumes = f.samples;
  return info;
}

// The channel to read of a stack of `format` pages (ReadOptions::volume; any of one).
void choose_channel(PageFormat& format, const VolumeInfo& info, const ReadOptions& options, const std::string& file) {
  format.channel = std::uint16_t(choose_volume(format.samples, info.dims, options, file, "SamplesPerPixel",
                                               format.planar == PLANARCONFIG_SEPARATE ? "channels, planar" : "channels"));
}

std::unique_ptr<VolumeSource> open_multi_page(const fs::path& path, const ReadOptions& options) {
  auto file = std::make_unique<TiffFile>(path, "r");
  const auto label = [&](std::size_t n) { return fmt::format("{} page {}", path.string(), n); };
  const PageFormat first = read_page_format(*file, label(0));
  const VolumeInfo info0 = info_from(first, 1, read_spacing(*file, label(0)), label(0));
  std::vector<Page> pages{{path, TIFFCurrentDirOffset(file->get()), label(0)}};
  while (TIFFReadDirectory(file->get()) == 1) {
    const std::string where = label(pages.size());
    check_same_format(read_page_format(*file, where), first, where);
    pages.push_back({path, TIFFCurrentDirOffset(file->get()), where});
  }
  // TIFFReadDirectory returns 0 both at the last page and on a broken directory.
  if (file->has_errors())
    throw FormatError(label(pages.size()), "IFD", fmt::format("cannot read the page directory: {}", file->take_errors()));
  VolumeInfo info = info0;
  info.dims.z = std::int64_t(pages.size());
  checked_volume_bytes(info, path.string(), "pages");
  PageFormat format = first;
  choose_channel(format, info, options, path.string());
  return std::make_unique<TiffSource>(path, info, format, std::move(pages), std::move(file));
}

std::unique_ptr<VolumeSource> open_folder(const fs::path& dir, const ReadOptions& options) {
  const std::vector<fs::path> files = list_slice_files(dir);
  std::vector<Page> pages;
  PageFormat first;
  Spacing spacing;
  for (const fs::path& slice : files) {
    TiffFile file(slice, "r");
    const std::string where = slice.string();
    const PageFormat format = read_page_format(file, where);
    if (pages.empty()) {
      first = format;
      spacing = read_spacing(file, where);
    }
    check_same_format(format, first, where);
    if (const auto count = TIFFNumberOfDirectories(file.get()); count != 1)
      throw FormatError(where, "pages", fmt::format("has {} pages; slices in a folder must be single-page", count));
    pages.push_back({slice, 0, where});
  }
  const VolumeInfo info = info_from(first, std::int64_t(pages.size()), spacing, files.front().string());
  choose_channel(first, info, options, dir.string());
  return std::make_unique<TiffSource>(dir, info, first, std::move(pages), nullptr);
}

// ---------------------------------------------------------------------------------------------
// Writing

// Above this many bytes a classic TIFF (32-bit offsets) could overflow, so BigTIFF is used.
// The margin covers directories and Deflate's worst-case growth on incompressible data.
constexpr std::uint64_t kClassicTiffLimit = (std::uint64_t(1) << 32) - (std::uint64_t(256) << 20);
// Strips of about this size keep reads of a few rows cheap without many tiny strips.
constexpr std::size_t kStripBytes = std::size_t(256) << 10;

const char* write_mode(std::uint64_t bytes) { return bytes > kClassicTiffLimit ? "w8" : "w"; }

template <class T>
void set_tag(TiffFile& file, ttag_t tag, T value, const char* name) {
  if (TIFFSetField(file.get(), tag, value) != 1)
    throw Error(fmt::format("{}: cannot set TIFF tag {}: {}", file.path().string(), name, file.take_errors()));
}

struct PageLayout {
  const VolumeInfo& info;
  bool compress;
  bool multi_page;
  std::string description;
};

void set_page_tags(TiffFile& file, const PageLayout& layout, std::uint32_t rows_per_strip) {
  const VolumeInfo& info = layout.info;
  set_tag(file, TIFFTAG_IMAGEWIDTH, std::uint32_t(info.dims.x), "ImageWidth");
  set_tag(file, TIFFTAG_IMAGELENGTH, std::uint32_t(info.dims.y), "ImageLength");
  set_tag(file, TIFFTAG_BITSPERSAMPLE, int(8 * dtype_size(info.dtype)), "BitsPerSample");
  set_tag(file, TIFFTAG_SAMPLESPERPIXEL, 1, "SamplesPerPixel");
  set_tag(file, TIFFTAG_SAMPLEFORMAT, int(sample_format_of(info.dtype)), "SampleFormat");
  set_tag(file, TIFFTAG_PHOTOMETRIC, int(PHOTOMETRIC_MINISBLACK), "PhotometricInterpretation");
  set_tag(file, TIFFTAG_PLANARCONFIG, int(PLANARCONFIG_CONTIG), "PlanarConfiguration");
  set_tag(file, TIFFTAG_COMPRESSION, int(layout.compress ? COMPRESSION_ADOBE_DEFLATE : COMPRESSION_NONE), "Compression");
  set_tag(file, TIFFTAG_ROWSPERSTRIP, rows_per_strip, "RowsPerStrip");
  set_tag(file, TIFFTAG_IMAGEDESCRIPTION, layout.description.c_str(), "ImageDescription");
  if (layout.multi_page) set_tag(file, TIFFTAG_SUBFILETYPE, std::uint32_t(FILETYPE_PAGE), "NewSubfileType");
}

// Writes one slice as the current page and closes its directory.
void write_page(TiffFile& file, const PageLayout& layout, const std::byte* slice) {
  const std::size_t row_bytes = std::size_t(layout.info.dims.x) * dtype_size(layout.info.dtype);
  const auto height = std::uint32_t(layout.info.dims.y);
  const auto rows_per_strip = std::uint32_t(std::clamp<std::size_t>(kStripBytes / row_bytes, 1, height));
  set_page_tags(file, layout, rows_per_strip);
  // libtiff may transform the buffer it is given in place (byte order, predictors); a copy
  // keeps the caller's slab untouched.
  std::vector<std::byte> strip(row_bytes * rows_per_strip);
  for (std::uint32_t y0 = 0, strip_index = 0; y0 < height; y0 += rows_per_strip, ++strip_index) {
    const std::size_t bytes = row_bytes * std::min(rows_per_strip, height - y0);
    std::memcpy(strip.data(), slice + row_bytes * y0, bytes);
    if (TIFFWriteEncodedStrip(file.get(), strip_index, strip.data(), tmsize_t(bytes)) < 0)
      throw Error(fmt::format("{}: cannot write rows {}..: {}", file.path().string(), y0, file.take_errors()));
  }
  if (TIFFWriteDirectory(file.get()) != 1)
    throw Error(fmt::format("{}: cannot write the page directory: {}", file.path().string(), file.take_errors()));
}

// Shared by both writers: hands out the slices of each slab, numbered in z order.
class SliceCounter {
 public:
  explicit SliceCounter(std::size_t slice_bytes) : slice_bytes_(slice_bytes) {}

  template <class WriteSlice>
  void accept(const Volume& slab, WriteSlice&& write_slice) {
    for (std::int64_t z = 0; z < slab.dims().z; ++z, ++written_)
      write_slice(written_, slab.bytes() + std::size_t(z) * slice_bytes_);
  }

 private:
  std::size_t slice_bytes_;
  std::int64_t written_ = 0;
};

fs::path with_suffix(fs::path p, std::string_view suffix) {
  p += suffix;
  return p;
}

void rename_or_throw(const fs::path& from, const fs::path& to) {
  std::error_code ec;
  fs::rename(from, to, ec);
  if (ec) throw Error(fmt::format("{}: cannot rename {} into place: {}", to.string(), from.string(), ec.message()));
}

// One multi-page file, built as `<path>.tmp` and renamed on finish().
class MultiPageWriter final : public VolumeWriter {
 public:
  MultiPageWriter(const fs::path& path, const VolumeInfo& info, bool compress)
      : path_(path), tmp_(with_suffix(path, kTemporarySuffix)), tmp_on_signal_(tmp_), info_(info),
        slices_(info.bytes_per_slice()), layout_{info_, compress, true, spacing_description(info.spacing)},
        file_(std::make_unique<TiffFile>(tmp_, write_mode(info.byte_size()))) {}

  ~MultiPageWriter() override {
    if (finished_) return;
    file_.reset();
    std::error_code ignored;
    fs::remove(tmp_, ignored);
  }

  void write_slab(const Volume& slab) override {
    slices_.accept(slab, [&](std::int64_t, const std::byte* slice) { write_page(*file_, layout_, slice); });
  }

  void finish() override {
    file_->close_written();
    rename_or_throw(tmp_, path_);
    tmp_on_signal_.release();
    finished_ = true;
  }

 private:
  fs::path path_, tmp_;
  RemovedOnSignal tmp_on_signal_;  // before file_: registered before the file is created
  VolumeInfo info_;
  SliceCounter slices_;
  PageLayout layout_;
  std::unique_ptr<TiffFile> file_;
  bool finished_ = false;
};

// A folder of slice_0000.tif ..., built in `<dir>.tmp` and renamed on finish(), so readers
// never see a mix of old and new slices.
class FolderWriter final : public VolumeWriter {
 public:
  FolderWriter(const fs::path& dir, const VolumeInfo& info, bool compress)
      : dir_(dir), staging_(with_suffix(dir, kTemporarySuffix)), staging_on_signal_(staging_), info_(info),
        slices_(info.bytes_per_slice()),
        layout_{info_, compress, false, spacing_description(info.spacing)},
        digits_(std::max<std::size_t>(4, std::to_string(std::max<std::int64_t>(info.dims.z - 1, 0)).size())) {
    check_replaceable(dir_);
    std::error_code ec;
    fs::remove_all(staging_, ec);  // a leftover of a crashed run
    if (!ec) fs::create_directories(staging_, ec);
    if (ec) throw Error(fmt::format("{}: cannot create the staging folder: {}", staging_.string(), ec.message()));
  }

  ~FolderWriter() override {
    if (finished_) return;
    std::error_code ignored;
    fs::remove_all(staging_, ignored);
  }

  void write_slab(const Volume& slab) override {
    slices_.accept(slab, [&](std::int64_t z, const std::byte* slice) {
      TiffFile file(staging_ / slice_name(z), write_mode(info_.bytes_per_slice()));
      write_page(file, layout_, slice);
      file.close_written();
    });
  }

  void finish() override {
    // Replacing is a delete then a rename: a crash between them leaves the complete new
    // slices in `<dir>.tmp`, never a half-written folder under the final name.
    if (fs::exists(dir_)) {
      check_replaceable(dir_);
      std::error_code ec;
      fs::remove_all(dir_, ec);
      if (ec) throw Error(fmt::format("{}: cannot replace the old folder: {}", dir_.string(), ec.message()));
    }
    rename_or_throw(staging_, dir_);
    staging_on_signal_.release();
    finished_ = true;
  }

 private:
  std::string slice_name(std::int64_t z) const { return fmt::format("slice_{:0{}}{}", z, digits_, kExtensions[0]); }

  // An existing output folder is replaced only if it holds nothing but TIFF files, so a
  // mistyped path never deletes unrelated data.
  static void check_replaceable(const fs::path& dir) {
    if (!fs::exists(dir)) return;
    if (!fs::is_directory(dir)) throw Error(fmt::format("{}: exists and is not a folder", dir.string()));
    for (const auto& entry : fs::directory_iterator(dir))
      if (!entry.is_regular_file() || !has_tiff_extension(entry.path()))
        throw Error(fmt::format("{}: the output folder already holds {}, which is not a TIFF slice; refusing to "
                                "replace it (choose an empty or new folder)",
                                dir.string(), entry.path().filename().string()));
  }

  fs::path dir_, staging_;
  RemovedOnSignal staging_on_signal_;
  VolumeInfo info_;
  SliceCounter slices_;
  PageLayout layout_;
  std::size_t digits_;
  bool finished_ = false;
};

void check_writable(const fs::path& path, const VolumeInfo& info) {
  const auto fits = [](std::int64_t n) { return n >= 1 && n <= std::int64_t(UINT32_MAX); };
  if (!fits(info.dims.x) || !fits(info.dims.y) || info.dims.z < 1)
    throw Error(fmt::format("{}: dims {}: TIFF pages need 1..{} columns and rows and at least one slice",
                            path.string(), info.dims.to_string(), UINT32_MAX));
}

// A folder when the path names one (existing, or with a trailing slash or no extension).
bool names_folder(const fs::path& path) {
  return fs::is_directory(path) || !path.has_filename() || !path.has_extension();
}

std::unique_ptr<VolumeSource> open_tiff(const std::filesystem::path& path, const ReadOptions& options) {
  if (fs::is_directory(path)) return open_folder(path, options);
  return open_multi_page(path, options);
}

std::unique_ptr<VolumeWriter> create_tiff_writer(const std::filesystem::path& path, const VolumeInfo& info,
                                                 const WriteOptions& options) {
  check_writable(path, info);
  if (names_folder(path)) {
    const fs::path dir = path.has_filename() ? path : path.parent_path();  // "out/" -> "out"
    return std::make_unique<FolderWriter>(dir, info, options.compress);
  }
  return std::make_unique<MultiPageWriter>(path, info, options.compress);
}

// A folder of slices is replaced whole; a multi-page file is a file and its temporary.
std::vector<TouchedPath> tiff_files_written(const std::filesystem::path& path, const WriteOptions&) {
  return names_folder(path) ? replaced_folder_written(path) : plain_file_written(path);
}

// The sniffer: the byte-order mark and 42 (classic TIFF) or 43 (BigTIFF) in that order.
bool has_tiff_magic(std::span<const std::byte> head) {
  if (head.size() < 4) return false;
  const auto byte = [&](std::size_t i) { return std::to_integer<unsigned char>(head[i]); };
  if (byte(0) == 'I' && byte(1) == 'I') return byte(3) == 0 && (byte(2) == 42 || byte(2) == 43);
  if (byte(0) == 'M' && byte(1) == 'M') return byte(2) == 0 && (byte(3) == 42 || byte(3) == 43);
  return false;
}

}  // namespace

VolumeFormat tiff_format() {
  return {
      .name = "tiff",
      .title = "TIFF",
      .description = "a stack of images: one multi-page file (a page per slice) or a folder of single-page slices",
      .extensions = {kExtensions.begin(), kExtensions.end()},
      .magic_bytes = 4,
      .sniff = has_tiff_magic,
      .directory = "a directory of TIFF slices",
      .open = open_tiff,
      .create_writer = create_tiff_writer,
      .files_written = tiff_files_written,
      .capabilities = {.streaming = true, .multi_volume = true, .spatial_metadata = true},
      .write_dtypes = DTypeSet::all(),
      .read_notes = "8/16/32-bit integer and 32/64-bit float pages, strips or tiles; a folder's slices in natural name "
                    "order; multi-channel pages (SamplesPerPixel > 1, chunky or planar) one channel at a time with "
                    "`--volume T` (alias `--component`)",
      .write_notes = "multi-page file, or a folder of slices for a name without extension; Deflate unless "
                     "`--uncompressed`",
  };
}

}  // namespace strata::io::detail
