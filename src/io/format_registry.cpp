// The registry of volume formats and the detection of a path's format.
#include "strata/io/formats.hpp"

#include <algorithm>
#include <fstream>
#include <mutex>

#include <fmt/format.h>

#include "io/builtin_formats.hpp"
#include "io/io_detail.hpp"
#include "strata/core/text.hpp"
#include "strata/io/byte_source.hpp"
#include "strata/io/file_names.hpp"

namespace strata::io {

namespace {

namespace fs = std::filesystem;

// Entries live behind unique_ptr so the references lookups hand out stay valid while later
// formats are registered.
using Entries = std::vector<std::unique_ptr<const VolumeFormat>>;

void check_complete(const VolumeFormat& f) {
  const auto fail = [&](const std::string& problem) {
    throw Error(fmt::format("register_format: format \"{}\": {}", f.name, problem));
  };
  if (f.name.empty()) throw Error("register_format: a format needs a name");
  if (!f.open) fail("no reader (VolumeFormat::open)");
  if (f.extensions.empty() && f.directory.empty()) fail("neither an extension nor a folder form");
  for (const std::string& ext : f.extensions)
    if (ext.size() < 2 || ext[0] != '.' || detail::ascii_lower(ext) != ext)
      fail(fmt::format("extension \"{}\" must be a dot and lower-case letters", ext));
  if (f.sniff && f.magic_bytes == 0) fail("a sniffer needs magic_bytes > 0");
  if (f.sniff_directory && f.directory.empty()) fail("a folder predicate needs the folder form (directory)");
  if (f.create_writer && f.write_dtypes.empty()) fail("a writer needs write_dtypes");
}

void add(Entries& entries, VolumeFormat format) {
  check_complete(format);
  for (const auto& e : entries) {
    if (e->name == format.name)
      throw Error(fmt::format("register_format: a format named \"{}\" is registered already", format.name));
    for (const std::string& ext : format.extensions)
      if (std::find(e->extensions.begin(), e->extensions.end(), ext) != e->extensions.end())
        throw Error(fmt::format("register_format: extension {} of \"{}\" belongs to \"{}\" already", ext, format.name,
                                e->name));
  }
  entries.push_back(std::make_unique<const VolumeFormat>(std::move(format)));
}

// The built-in formats, one line each, registered on first use (the libraries are static
// archives: a registration in an object nothing references would be dropped by the linker).
Entries builtin_formats() {
  Entries entries;
  add(entries, detail::raw_format());
  add(entries, detail::nrrd_format());
  add(entries, detail::nifti_format());
  add(entries, detail::tiff_format());
  add(entries, detail::mrc_format());
  add(entries, detail::vtk_format());
  add(entries, detail::precomputed_format());
  add(entries, detail::dicom_format());
  add(entries, detail::zarr_format());
  add(entries, detail::hdf5_format());
  return entries;
}

struct Registry {
  std::mutex mutex;
  Entries entries = builtin_formats();
};

Registry& registry() {
  static Registry r;
  return r;
}

bool is_folder(const fs::path& path) {
  std::error_code ec;
  return fs::is_directory(path, ec);
}

// The longest extension of a format that `path`'s name ends with; for a folder only the
// formats that take folders count.
// The format with the longest extension `path`'s name ends with (only folder formats when
// `folder`), and that extension's length.
std::pair<const VolumeFormat*, std::size_t> longest_extension(const fs::path& path, bool folder) {
  const std::string name = detail::ascii_lower(path.filename().string());
  const VolumeFormat* best = nullptr;
  std::size_t best_size = 0;
  for (const VolumeFormat* f : formats()) {
    if (folder && f->directory.empty()) continue;
    for (const std::string& ext : f->extensions)
      if (ext.size() > best_size && name.ends_with(ext)) {
        best = f;
        best_size = ext.size();
      }
  }
  return {best, best_size};
}

const VolumeFormat* by_extension(const fs::path& path, bool folder) { return longest_extension(path, folder).first; }

// A folder's format: the first whose predicate takes it, else the first folder format that
// takes every folder (no predicate; its reader reports what the folder lacks).
const VolumeFormat* by_folder(const fs::path& dir) {
  const VolumeFormat* fallback = nullptr;
  for (const VolumeFormat* f : formats()) {
    if (f->directory.empty()) continue;
    if (f->sniff_directory) {
      if (f->sniff_directory(dir)) return f;
    } else if (!fallback) {
      fallback = f;
    }
  }
  return fallback;
}

// The first format whose sniffer recognises the file's first bytes.
const VolumeFormat* by_content(const fs::path& path) {
  const std::vector<const VolumeFormat*> all = formats();
  std::size_t needed = 0;
  for (const VolumeFormat* f : all)
    if (f->sniff) needed = std::max(needed, f->magic_bytes);
  if (needed == 0) return nullptr;
  std::vector<char> head(needed);
  std::ifstream in(path, std::ios::binary);
  in.read(head.data(), std::streamsize(needed));
  const auto* bytes = reinterpret_cast<const std::byte*>(head.data());
  const auto got = std::size_t(in.gcount());
  for (const VolumeFormat* f : all)
    if (f->sniff && f->sniff(std::span<const std::byte>(bytes, std::min(got, f->magic_bytes)))) return f;
  return nullptr;
}

// `url`'s path without its query or fragment (a presigned URL's signature is not a name).
fs::path url_name(const std::string& url) { return fs::path(url.substr(0, url.find_first_of("?#"))); }

// The format of a volume on a web server: the extension of a format that reads URLs, else the
// first whose sniff_url takes it.
const VolumeFormat* remote_format(const std::string& url) {
  const fs::path name = url_name(url);
  for (const VolumeFormat* f : formats())
    if (f->sniff_url && by_extension(name, false) == f) return f;
  if (detail::ascii_lower(name.filename().string()).ends_with(kStrataExtension)) return nullptr;
  for (const VolumeFormat* f : formats())
    if (f->sniff_url && f->sniff_url(url)) return f;
  return nullptr;
}

[[noreturn]] void throw_not_remote(const std::string& url) {
  std::vector<std::string> names;
  for (const VolumeFormat* f : formats())
    if (f->sniff_url) names.push_back(f->title);
  throw Error(fmt::format("{}: not a volume that can be read from a web server (expected {}; a remote {} file is read "
                          "by the commands that take .strata files)",
                          url, joined_list(names, "or"), kStrataExtension));
}

[[noreturn]] void throw_unknown(const fs::path& path) {
  throw Error(fmt::format("{}: unknown volume format (expected {})", path.string(), known_extensions_text()));
}

// The first bytes of a .strata container (docs/format.md).
constexpr std::string_view kStrataSignature{"\x89STRATA\n", 8};

// Why a file named .strata is not something this module reads: the caller asked for a volume
// (a .strata file that is one goes to the container reader), so say what the file is instead.
[[noreturn]] void throw_not_a_volume(const fs::path& path) {
  std::error_code ec;
  const auto size = fs::file_size(path, ec);
  if (ec) throw Error(fmt::format("{}: cannot open: {}", path.string(), ec.message()));
  if (size == 0)
    throw Error(fmt::format("{}: empty file (0 bytes), expected a {} container", path.string(), kStrataExtension));
  std::string head(kStrataSignature.size(), '\0');
  std::ifstream in(path, std::ios::binary);
  in.read(head.data(), std::streamsize(head.size()));
  if (!in || head != kStrataSignature)
    throw Error(fmt::format("{}: not a {} container: its {} bytes do not start with the {} signature "
                            "(a damaged or mislabelled file)",
                            path.string(), kStrataExtension, size, kStrataExtension));
  throw Error(fmt::format("{}: a {} container, not a volume in one of the formats {}", path.string(), kStrataExtension,
                          format_titles_text("or")));
}

}  // namespace

std::vector<DType> DTypeSet::list() const {
  std::vector<DType> types;
  for (DType t : kAllDTypes)
    if (contains(t)) types.push_back(t);
  return types;
}

void register_format(VolumeFormat format) {
  Registry& r = registry();
  std::lock_guard lock(r.mutex);
  add(r.entries, std::move(format));
}

std::vector<const VolumeFormat*> formats() {
  Registry& r = registry();
  std::lock_guard lock(r.mutex);
  std::vector<const VolumeFormat*> all;
  for (const auto& e : r.entries) all.push_back(e.get());
  return all;
}

const VolumeFormat* find_format(std::string_view name) {
  for (const VolumeFormat* f : formats())
    if (f->name == name) return f;
  return nullptr;
}

const VolumeFormat* format_by_extension(const fs::path& path) { return by_extension(path, false); }

std::string name_without_extension(const fs::path& path) {
  const std::string name = path.filename().string();
  std::size_t cut = longest_extension(path, false).second;
  if (detail::ascii_lower(name).ends_with(kStrataExtension)) cut = std::max(cut, kStrataExtension.size());
  return name.substr(0, name.size() - std::min(cut, name.size()));
}

bool is_remote_volume(const std::string& url) { return remote_format(url) != nullptr; }

const VolumeFormat& detect_format(const fs::path& path) {
  if (is_url(path.string())) {
    if (const VolumeFormat* f = remote_format(path.string())) return *f;
    throw_not_remote(path.string());
  }
  const bool folder = is_folder(path);
  if (const VolumeFormat* f = by_extension(path, folder)) return *f;
  if (folder) {
    if (const VolumeFormat* f = by_folder(path)) return *f;
    throw_unknown(path);
  }
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw_unknown(path);
  if (detail::ascii_lower(path.filename().string()).ends_with(kStrataExtension)) throw_not_a_volume(path);
  if (const VolumeFormat* f = by_content(path)) return *f;
  throw_unknown(path);
}

const VolumeFormat& output_format(const fs::path& path, std::string_view name) {
  if (!name.empty()) {
    if (const VolumeFormat* f = find_format(name)) return *f;
    std::vector<std::string> names;
    for (const VolumeFormat* f : formats()) names.push_back(f->name);
    throw ParameterError("WriteOptions::format",
                         fmt::format("unknown format \"{}\" (expected {})", name, joined_list(names, "or")));
  }
  const bool folder = is_folder(path);
  if (const VolumeFormat* f = by_extension(path, folder)) return *f;
  if (folder)
    if (const VolumeFormat* f = by_folder(path)) return *f;
  throw_unknown(path);
}

std::string known_extensions_text() {
  std::vector<std::string> names;
  for (const VolumeFormat* f : formats()) {
    names.insert(names.end(), f->extensions.begin(), f->extensions.end());
    if (!f->directory.empty()) names.push_back(f->directory);
  }
  return joined_list(names, "or");
}

std::string format_titles_text(std::string_view conjunction) {
  std::vector<std::string> titles;
  for (const VolumeFormat* f : formats()) titles.push_back(f->title);
  return joined_list(titles, conjunction);
}

}  // namespace strata::io
