// Format detection and dispatch; the checks every writer shares.
#include "strata/io/volume_io.hpp"

#include <fstream>
#include <string_view>

#include <fmt/format.h>

#include "io/io_detail.hpp"

namespace strata::io {

namespace {

// Wraps a format writer so that every format gets the same slab checks: a mismatched slab or
// a wrong slice count is an error, never a silently malformed file.
class CheckedWriter final : public VolumeWriter {
 public:
  CheckedWriter(std::unique_ptr<VolumeWriter> inner, std::filesystem::path path, const VolumeInfo& info)
      : inner_(std::move(inner)), path_(std::move(path)), info_(info) {}

  void write_slab(const Volume& slab) override {
    if (finished_) throw Error(fmt::format("{}: write_slab after finish", path_.string()));
    check_slab_shape(slab);
    if (slices_written_ + slab.dims().z > info_.dims.z)
      throw Error(fmt::format("{}: slab of {} slices after {} would exceed the {} slices of the volume",
                              path_.string(), slab.dims().z, slices_written_, info_.dims.z));
    inner_->write_slab(slab);
    slices_written_ += slab.dims().z;
  }

  void finish() override {
    if (finished_) return;
    if (slices_written_ != info_.dims.z)
      throw Error(fmt::format("{}: wrote {} slices, expected {}", path_.string(), slices_written_, info_.dims.z));
    inner_->finish();
    finished_ = true;
  }

 private:
  void check_slab_shape(const Volume& slab) const {
    if (slab.dtype() != info_.dtype)
      throw Error(fmt::format("{}: slab dtype {} does not match the volume dtype {}", path_.string(),
                              dtype_name(slab.dtype()), dtype_name(info_.dtype)));
    if (slab.dims().x != info_.dims.x || slab.dims().y != info_.dims.y)
      throw Error(fmt::format("{}: slab {} does not match the slice size {}x{}", path_.string(),
                              slab.dims().to_string(), info_.dims.x, info_.dims.y));
  }

  std::unique_ptr<VolumeWriter> inner_;
  std::filesystem::path path_;
  VolumeInfo info_;
  std::int64_t slices_written_ = 0;
  bool finished_ = false;
};

}  // namespace

namespace {

// The first bytes of a .strata container (docs/format.md).
constexpr std::string_view kStrataSignature{"\x89STRATA\n", 8};

// Why a file named .strata is not something this module reads: the caller asked for a volume
// (a .strata file that is one goes to the container reader), so say what the file is instead.
[[noreturn]] void throw_not_a_volume(const std::filesystem::path& path) {
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  if (ec) throw Error(fmt::format("{}: cannot open: {}", path.string(), ec.message()));
  if (size == 0) throw Error(fmt::format("{}: empty file (0 bytes), expected a .strata container", path.string()));
  std::string head(kStrataSignature.size(), '\0');
  std::ifstream in(path, std::ios::binary);
  in.read(head.data(), std::streamsize(head.size()));
  if (!in || head != kStrataSignature)
    throw Error(fmt::format("{}: not a .strata container: its {} bytes do not start with the .strata signature "
                            "(a damaged or mislabelled file)",
                            path.string(), size));
  throw Error(fmt::format("{}: a .strata container, not a volume in one of the formats raw, NRRD, NIfTI-1 or TIFF",
                          path.string()));
}

}  // namespace

FileFormat detect_format(const std::filesystem::path& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) return FileFormat::tiff;
  const std::string name = detail::ascii_lower(path.filename().string());
  if (name.ends_with(".raw") || name.ends_with(".bin")) return FileFormat::raw;
  if (name.ends_with(".nrrd") || name.ends_with(".nhdr")) return FileFormat::nrrd;
  if (name.ends_with(".nii") || name.ends_with(".nii.gz")) return FileFormat::nifti;
  if (name.ends_with(".tif") || name.ends_with(".tiff")) return FileFormat::tiff;
  if (name.ends_with(".strata") && std::filesystem::exists(path, ec)) throw_not_a_volume(path);
  throw Error(fmt::format("{}: unknown volume format (expected .raw, .bin, .nrrd, .nhdr, .nii, .nii.gz, .tif, "
                          ".tiff or a directory of TIFF slices)",
                          path.string()));
}

const char* format_name(FileFormat f) {
  switch (f) {
    case FileFormat::raw: return "raw";
    case FileFormat::nrrd: return "nrrd";
    case FileFormat::nifti: return "nifti";
    case FileFormat::tiff: return "tiff";
  }
  return "unknown";
}

bool format_supports(FileFormat f, DType t) {
  // NIfTI-1 has an int8 code, but many readers mishandle it, so we never write i8 there.
  if (f == FileFormat::nifti) return t != DType::i8;
  return true;
}

Volume VolumeSource::read_slab(std::int64_t z0, std::int64_t z1) {
  const Extent& dims = info().dims;
  return read_box({{0, 0, z0}, {dims.x, dims.y, z1}});
}

Volume VolumeSource::read_all() { return read_box(Box::whole(info().dims)); }

namespace {

class MemorySource final : public VolumeSource {
 public:
  MemorySource(const Volume& volume, std::filesystem::path name) : volume_(volume), name_(std::move(name)) {}
  const VolumeInfo& info() const override { return volume_.info(); }
  const std::filesystem::path& path() const override { return name_; }
  Volume read_box(const Box& box) override {
    if (box.empty() || !Box::whole(volume_.dims()).contains(box))
      throw Error(fmt::format("{}: box {} is not inside the volume {}", name_.string(), box.to_string(),
                              volume_.dims().to_string()));
    return volume_.crop(box);
  }

 private:
  const Volume& volume_;
  std::filesystem::path name_;
};

}  // namespace

std::unique_ptr<VolumeSource> memory_source(const Volume& volume, std::filesystem::path name) {
  return std::make_unique<MemorySource>(volume, std::move(name));
}

std::unique_ptr<VolumeSource> open_volume(const std::filesystem::path& path, const ReadOptions& options) {
  const FileFormat format = detect_format(path);
  // Every format needs some bytes; an empty file is reported as such, not as a bad header.
  std::error_code ec;
  if (std::filesystem::is_regular_file(path, ec) && std::filesystem::file_size(path, ec) == 0 && !ec)
    throw FormatError(path.string(), "size", fmt::format("empty file (0 bytes), expected a {} volume", format_name(format)));
  // NIfTI (dim[4..7]), NRRD (a fourth axis) and TIFF (channels) files hold several volumes; a
  // raw file's chosen volume other than the only one would be silently ignored.
  if (format == FileFormat::raw && options.volume.value_or(0) != 0)
    throw ParameterError("ReadOptions::volume", fmt::format("{}: volume {} does not exist; a {} file holds one volume (0)",
                                                            path.string(), *options.volume, format_name(format)));
  switch (format) {
    case FileFormat::raw: return detail::open_raw(path, options);
    case FileFormat::nrrd: return detail::open_nrrd(path, options);
    case FileFormat::nifti: return detail::open_nifti(path, options);
    case FileFormat::tiff: return detail::open_tiff(path, options);
  }
  throw Error(fmt::format("{}: unknown volume format", path.string()));
}

Volume read_volume(const std::filesystem::path& path, const ReadOptions& options) {
  return open_volume(path, options)->read_all();
}

std::unique_ptr<VolumeWriter> create_volume_writer(const std::filesystem::path& path, const VolumeInfo& info,
                                                   const WriteOptions& options) {
  const FileFormat format = options.format ? *options.format : detect_format(path);
  if (!format_supports(format, info.dtype))
    throw Error(fmt::format("{}: the {} format cannot store {} samples", path.string(), format_name(format),
                            dtype_name(info.dtype)));
  if (info.dims.x <= 0 || info.dims.y <= 0 || info.dims.z <= 0)
    throw Error(fmt::format("{}: cannot write a volume of dims {}", path.string(), info.dims.to_string()));
  std::unique_ptr<VolumeWriter> inner;
  switch (format) {
    case FileFormat::raw: inner = detail::create_raw_writer(path, info, options); break;
    case FileFormat::nrrd: inner = detail::create_nrrd_writer(path, info, options); break;
    case FileFormat::nifti: inner = detail::create_nifti_writer(path, info, options); break;
    case FileFormat::tiff: inner = detail::create_tiff_writer(path, info, options); break;
  }
  return std::make_unique<CheckedWriter>(std::move(inner), path, info);
}

void write_volume(const std::filesystem::path& path, const Volume& volume, const WriteOptions& options) {
  auto writer = create_volume_writer(path, volume.info(), options);
  writer->write_slab(volume);
  writer->finish();
}

}  // namespace strata::io
