// Dispatch to the registered formats (formats.hpp); the checks every reader and writer shares.
#include "strata/io/volume_io.hpp"

#include <fmt/format.h>

#include "strata/io/formats.hpp"

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

namespace {

// The array a `container:inner` path names, reconciled with the one the options name: either may
// be empty, and when both are given they must agree.
std::string named_array(const std::string& from_path, const std::string& from_options, const char* field,
                        const std::filesystem::path& given_path) {
  if (from_path.empty()) return from_options;
  if (!from_options.empty() && from_options != from_path)
    throw ParameterError(field, fmt::format("{}: the path names the array '{}' and the options name '{}'",
                                            given_path.string(), from_path, from_options));
  return from_path;
}

}  // namespace

namespace {

// `path` split at its last colon whose left part `is_container` accepts, so "C:" style prefixes
// and colons inside folder names still resolve to the longest container; the whole path and no
// inner name when no part is one.
template <class IsContainer>
std::pair<std::filesystem::path, std::string> split_at_container(const std::filesystem::path& path,
                                                                 IsContainer&& is_container) {
  const std::string text = path.string();
  for (std::size_t colon = text.rfind(':'); colon != std::string::npos && colon > 0; colon = text.rfind(':', colon - 1)) {
    const std::filesystem::path container = text.substr(0, colon);
    if (is_container(container)) return {container, text.substr(colon + 1)};
  }
  return {path, {}};
}

}  // namespace

std::pair<std::filesystem::path, std::string> split_container_path(const std::filesystem::path& path) {
  std::error_code ec;
  if (std::filesystem::exists(path, ec)) return {path, {}};
  return split_at_container(path, [&](const std::filesystem::path& container) { return std::filesystem::exists(container, ec); });
}

std::unique_ptr<VolumeSource> open_volume(const std::filesystem::path& given_path, const ReadOptions& given_options) {
  const auto [path, inner] = split_container_path(given_path);
  ReadOptions options = given_options;
  options.dataset = named_array(inner, options.dataset, "ReadOptions::dataset", given_path);
  const VolumeFormat& format = detect_format(path);
  // Every format needs some bytes; an empty file is reported as such, not as a bad header.
  std::error_code ec;
  if (std::filesystem::is_regular_file(path, ec) && std::filesystem::file_size(path, ec) == 0 && !ec)
    throw FormatError(path.string(), "size", fmt::format("empty file (0 bytes), expected a {} volume", format.name));
  // Formats of several volumes check the choice against the file; in a format of one, a chosen
  // volume other than the only one would be silently ignored.
  if (!format.capabilities.multi_volume && options.volume.value_or(0) != 0)
    throw ParameterError("ReadOptions::volume", fmt::format("{}: volume {} does not exist; a {} file holds one volume (0)",
                                                            path.string(), *options.volume, format.name));
  if (!format.capabilities.datasets && !options.dataset.empty())
    throw ParameterError("ReadOptions::dataset", fmt::format("{}: a {} file holds no named arrays (asked for '{}')",
                                                             path.string(), format.name, options.dataset));
  if (!format.capabilities.multiscale && options.level.value_or(0) != 0)
    throw ParameterError("ReadOptions::level", fmt::format("{}: level {} does not exist; a {} file holds one "
                                                           "resolution (level 0)", path.string(), *options.level,
                                                           format.name));
  return format.open(path, options);
}

Volume read_volume(const std::filesystem::path& path, const ReadOptions& options) {
  return open_volume(path, options)->read_all();
}

std::pair<std::filesystem::path, std::string> split_output_container(const std::filesystem::path& path) {
  if (format_by_extension(path)) return {path, {}};
  return split_at_container(path, [](const std::filesystem::path& container) {
    const VolumeFormat* format = format_by_extension(container);
    return format && format->capabilities.datasets;
  });
}

std::unique_ptr<VolumeWriter> create_volume_writer(const std::filesystem::path& given_path, const VolumeInfo& info,
                                                   const WriteOptions& given_options) {
  const auto [path, inner] = split_output_container(given_path);
  WriteOptions options = given_options;
  options.dataset = named_array(inner, options.dataset, "WriteOptions::dataset", given_path);
  const VolumeFormat& format = output_format(path, options.format);
  if (!format.capabilities.datasets && !options.dataset.empty())
    throw ParameterError("WriteOptions::dataset", fmt::format("{}: a {} file holds no named arrays (asked for '{}')",
                                                              path.string(), format.name, options.dataset));
  if (!format.create_writer)
    throw Error(fmt::format("{}: the {} format is read-only here (no writer)", path.string(), format.name));
  if (!format.writes(info.dtype))
    throw Error(fmt::format("{}: the {} format cannot store {} samples", path.string(), format.name,
                            dtype_name(info.dtype)));
  if (info.dims.x <= 0 || info.dims.y <= 0 || info.dims.z <= 0)
    throw Error(fmt::format("{}: cannot write a volume of dims {}", path.string(), info.dims.to_string()));
  return std::make_unique<CheckedWriter>(format.create_writer(path, info, options), path, info);
}

void write_volume(const std::filesystem::path& path, const Volume& volume, const WriteOptions& options) {
  auto writer = create_volume_writer(path, volume.info(), options);
  writer->write_slab(volume);
  writer->finish();
}

}  // namespace strata::io
