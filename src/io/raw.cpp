// Raw volumes: bare x-fastest samples whose dims and dtype come from ReadOptions or from a JSON
// sidecar (`<file>.json`, or `<stem>.json` beside the file).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "io/builtin_formats.hpp"
#include "io/io_detail.hpp"
#include "strata/core/checked.hpp"
#include "strata/io/file_names.hpp"

namespace strata::io::detail {

namespace {

// What a sidecar says; every field optional so ReadOptions can supply the rest.
struct RawDescription {
  std::optional<Extent> dims;
  std::optional<DType> dtype;
  std::optional<Spacing> spacing;
  std::optional<bool> big_endian;
  std::optional<std::uint64_t> header_bytes;
};

std::optional<std::filesystem::path> find_sidecar(const std::filesystem::path& path) {
  std::filesystem::path beside = path;
  beside += kJsonExtension;  // volume.raw.json
  std::filesystem::path stem_json = path;
  stem_json.replace_extension(kJsonExtension);  // volume.json
  for (const auto& candidate : {beside, stem_json}) {
    std::error_code ec;
    if (std::filesystem::is_regular_file(candidate, ec)) return candidate;
  }
  return std::nullopt;
}

// Every element of a sidecar field must be what `accept` takes; the message shows what was found.
bool all_three(const nlohmann::json& j, bool (*accept)(const nlohmann::json&)) {
  return j.is_array() && j.size() == 3 && std::all_of(j.begin(), j.end(), accept);
}

Extent read_dims(const nlohmann::json& j, const std::filesystem::path& sidecar) {
  // Unsigned JSON integers above 2^63 would wrap to negative counts: number_unsigned values
  // are checked against the int64 range before they are read.
  const auto positive_count = [](const nlohmann::json& v) {
    if (v.is_number_unsigned()) return v.get<std::uint64_t>() >= 1 && v.get<std::uint64_t>() <= INT64_MAX;
    return v.is_number_integer() && v.get<std::int64_t>() > 0;
  };
  if (!all_three(j, +positive_count))
    throw FormatError(sidecar.string(), "dims", fmt::format("expected 3 positive integers [x,y,z], found {}", j.dump()));
  return {j[0].get<std::int64_t>(), j[1].get<std::int64_t>(), j[2].get<std::int64_t>()};
}

Spacing read_spacing(const nlohmann::json& j, const std::filesystem::path& sidecar) {
  const auto positive = [](const nlohmann::json& v) {
    return v.is_number() && std::isfinite(v.get<double>()) && v.get<double>() > 0;
  };
  if (!all_three(j, +positive))
    throw FormatError(sidecar.string(), "spacing",
                      fmt::format("expected 3 positive numbers [x,y,z] (voxel sizes), found {}", j.dump()));
  return {j[0].get<double>(), j[1].get<double>(), j[2].get<double>()};
}

DType read_dtype(const nlohmann::json& j, const std::filesystem::path& sidecar) {
  if (!j.is_string()) throw FormatError(sidecar.string(), "dtype", fmt::format("expected a string, found {}", j.dump()));
  try {
    return parse_dtype(j.get<std::string>(), "dtype");
  } catch (const Error&) {
    throw FormatError(sidecar.string(), "dtype",
                      fmt::format("unknown dtype \"{}\" (expected u8, i8, u16, i16, u32, i32, f32 or f64)",
                                  j.get<std::string>()));
  }
}

bool read_endian(const nlohmann::json& j, const std::filesystem::path& sidecar) {
  if (j == "little") return false;
  if (j == "big") return true;
  throw FormatError(sidecar.string(), "endian", fmt::format("expected \"little\" or \"big\", found {}", j.dump()));
}

std::uint64_t read_header_bytes(const nlohmann::json& j, const std::filesystem::path& sidecar) {
  // A non-negative integer arrives as number_unsigned; 0 may arrive as number_integer too.
  if (!(j.is_number_unsigned() || (j.is_number_integer() && j.get<std::int64_t>() >= 0)))
    throw FormatError(sidecar.string(), "header_bytes", fmt::format("expected a non-negative integer, found {}", j.dump()));
  return j.get<std::uint64_t>();
}

RawDescription parse_sidecar(const std::filesystem::path& sidecar) {
  const nlohmann::json j = read_json_file(sidecar, "json");
  if (!j.is_object()) throw FormatError(sidecar.string(), "json", "expected an object {\"dims\": ..., \"dtype\": ...}");
  RawDescription d;
  if (j.contains("dims")) d.dims = read_dims(j["dims"], sidecar);
  if (j.contains("dtype")) d.dtype = read_dtype(j["dtype"], sidecar);
  if (j.contains("spacing")) d.spacing = read_spacing(j["spacing"], sidecar);
  if (j.contains("endian")) d.big_endian = read_endian(j["endian"], sidecar);
  if (j.contains("header_bytes")) d.header_bytes = read_header_bytes(j["header_bytes"], sidecar);
  return d;
}

// Explicit options win over the sidecar, field by field.
struct RawLayout {
  VolumeInfo info;
  bool big_endian = false;
  std::uint64_t header_bytes = 0;
  std::uint64_t file_bytes = 0;  // header_bytes + the samples
};

// Values from ReadOptions are the caller's (ParameterError); values from a sidecar are the
// sidecar's (FormatError naming it).
void check_option_values(const ReadOptions& options) {
  if (const auto& d = options.raw_dims; d && (d->x <= 0 || d->y <= 0 || d->z <= 0))
    throw ParameterError("ReadOptions::raw_dims", fmt::format("{} must all be positive", d->to_string()));
  if (const auto& s = options.raw_spacing) {
    for (double v : {s->x, s->y, s->z})
      if (!(v > 0) || !std::isfinite(v))
        throw ParameterError("ReadOptions::raw_spacing",
                             fmt::format("{},{},{}: every voxel size must be a positive number", s->x, s->y, s->z));
  }
}

RawLayout resolve_layout(const std::filesystem::path& path, const ReadOptions& options) {
  check_option_values(options);
  RawDescription d;
  std::optional<std::filesystem::path> sidecar;
  if (!(options.raw_dims && options.raw_dtype)) {
    sidecar = find_sidecar(path);
    if (sidecar) d = parse_sidecar(*sidecar);
  }
  if (options.raw_dims) d.dims = options.raw_dims;
  if (options.raw_dtype) d.dtype = options.raw_dtype;
  if (options.raw_spacing) d.spacing = options.raw_spacing;
  if (!d.dims || !d.dtype)  // names the first missing one
    throw ParameterError(d.dims ? "ReadOptions::raw_dtype" : "ReadOptions::raw_dims",
                         fmt::format("{}: a raw file needs its dims and dtype (e.g. 256,256,128 and u16): set them "
                                     "or write a sidecar {}.json like "
                                     "{{\"dims\":[256,256,128],\"dtype\":\"u16\",\"spacing\":[1,1,1]}}",
                                     path.string(), path.filename().string()));
  RawLayout layout;
  layout.info = VolumeInfo{*d.dims, *d.dtype, d.spacing.value_or(Spacing{})};
  layout.big_endian = options.raw_big_endian || d.big_endian.value_or(false);
  layout.header_bytes = options.raw_header_bytes != 0 ? options.raw_header_bytes : d.header_bytes.value_or(0);
  const bool dims_from_sidecar = !options.raw_dims;
  const auto sample_bytes = layout.info.checked_byte_size();
  const auto file_bytes = sample_bytes ? checked_add(*sample_bytes, layout.header_bytes) : std::nullopt;
  if (!file_bytes) {
    const std::string problem =
        fmt::format("{} samples of {}{} do not fit in a 64-bit byte count", layout.info.dims.to_string(),
                    dtype_name(layout.info.dtype),
                    layout.header_bytes ? fmt::format(" after a {}-byte header", layout.header_bytes) : "");
    if (dims_from_sidecar) throw FormatError(sidecar->string(), "dims", problem);
    throw ParameterError("ReadOptions::raw_dims", fmt::format("{}: {}", path.string(), problem));
  }
  layout.file_bytes = *file_bytes;
  return layout;
}

// ---------------------------------------------------------------------------------------------

class RawWriter final : public VolumeWriter {
 public:
  RawWriter(const std::filesystem::path& path, const VolumeInfo& info)
      : data_(path), info_(info), sidecar_path_(std::filesystem::path(path) += kJsonExtension) {}

  void write_slab(const Volume& slab) override { data_.write(slab.bytes(), slab.byte_size()); }

  void finish() override {
    // Both files are complete as temporaries before either is renamed, so a failure while
    // writing leaves neither; the sidecar goes first so a visible .raw always has its dims.
    write_file_atomically(sidecar_path_, sidecar_text());
    data_.commit();
  }

 private:
  std::string sidecar_text() const {
    nlohmann::json j;
    j["dims"] = {info_.dims.x, info_.dims.y, info_.dims.z};
    j["dtype"] = std::string(dtype_name(info_.dtype));
    j["spacing"] = {info_.spacing.x, info_.spacing.y, info_.spacing.z};
    j["endian"] = std::endian::native == std::endian::big ? "big" : "little";
    return j.dump(2) + "\n";
  }

  AtomicOutputFile data_;
  VolumeInfo info_;
  std::filesystem::path sidecar_path_;
};

std::unique_ptr<VolumeSource> open_raw(const std::filesystem::path& path, const ReadOptions& options) {
  const RawLayout layout = resolve_layout(path, options);
  auto file = std::make_shared<MappedFile>(path);
  const std::uint64_t expected = layout.file_bytes;
  if (file->size() != expected)
    throw FormatError(path.string(), "size",
                      fmt::format("expected {} bytes for {} {}{}, found {}", expected, layout.info.dims.to_string(),
                                  dtype_name(layout.info.dtype),
                                  layout.header_bytes ? fmt::format(" after a {}-byte header", layout.header_bytes) : "",
                                  file->size()));
  return make_mapped_source(std::move(file), layout.header_bytes, layout.info, layout.big_endian, path, "size");
}

std::unique_ptr<VolumeWriter> create_raw_writer(const std::filesystem::path& path, const VolumeInfo& info,
                                                const WriteOptions&) {
  return std::make_unique<RawWriter>(path, info);
}

std::vector<TouchedPath> raw_files_read(const std::filesystem::path& path) {
  if (const auto sidecar = find_sidecar(path)) return {{.path = *sidecar, .named = path, .role = "JSON sidecar"}};
  return {};
}

// The samples and the sidecar RawWriter adds, each with its temporary.
std::vector<TouchedPath> raw_files_written(const std::filesystem::path& path, const WriteOptions&) {
  std::vector<TouchedPath> files;
  add_written_file(files, path, path);
  add_written_file(files, std::filesystem::path(path) += kJsonExtension, path, "JSON sidecar");
  return files;
}

}  // namespace

VolumeFormat raw_format() {
  return {
      .name = "raw",
      .title = "raw",
      .description = "bare x-fastest samples; dims, dtype and spacing from a JSON sidecar or the command line",
      .extensions = {".raw", ".bin"},
      .opens_alone = [](const std::filesystem::path& path) { return find_sidecar(path).has_value(); },
      .open = open_raw,
      .files_read = raw_files_read,
      .create_writer = create_raw_writer,
      .files_written = raw_files_written,
      .capabilities = {.streaming = true, .multi_volume = false, .spatial_metadata = true},
      .write_dtypes = DTypeSet::all(),
      .read_notes = "dims and dtype from `FILE.raw.json` or `FILE.json`, else `--dims`/`--dtype` (`--spacing`, "
                    "`--big-endian`); memory-mapped",
      .write_notes = "with a `FILE.raw.json` sidecar",
  };
}

}  // namespace strata::io::detail
