// What reading and writing a volume path touches, and the check that an output spares every
// input (include/strata/io/touched_paths.hpp).
#include "strata/io/touched_paths.hpp"

#include <sys/stat.h>

#include <algorithm>

#include <fmt/format.h>

#include "strata/core/error.hpp"
#include "strata/io/formats.hpp"
#include "io/io_detail.hpp"

namespace strata::io {

namespace {

namespace fs = std::filesystem;

struct Identity {
  dev_t device;
  ino_t inode;
  bool folder;
  bool operator==(const Identity& o) const { return device == o.device && inode == o.inode; }
};

// What `path` is on disk, through symlinks; nullopt when it does not exist.
std::optional<Identity> identity_of(const fs::path& path) {
  struct stat st {};
  if (path.empty() || ::stat(path.c_str(), &st) != 0) return std::nullopt;
  return Identity{st.st_dev, st.st_ino, S_ISDIR(st.st_mode)};
}

// `path` with its existing part resolved (symlinks, `..`), so its parents are the real folders.
fs::path resolved_path(const fs::path& path) {
  std::error_code ec;
  fs::path p = fs::weakly_canonical(path, ec);
  if (ec) p = fs::absolute(path, ec).lexically_normal();
  return p;
}

// What the comparisons need of one touched path, looked up once: its identity, its resolved
// path and the identities of the folders it lies in.
struct Located {
  const TouchedPath* touched;
  std::optional<Identity> id;
  fs::path resolved;
  std::vector<Identity> folders;

  explicit Located(const TouchedPath& t) : touched(&t), id(identity_of(t.path)), resolved(resolved_path(t.path)) {
    for (fs::path up = resolved.parent_path(); !up.empty(); up = up.parent_path()) {
      if (const auto folder = identity_of(up)) folders.push_back(*folder);
      if (up == up.root_path()) break;
    }
  }
  bool inside(const Identity& folder) const { return std::find(folders.begin(), folders.end(), folder) != folders.end(); }
};

std::string quoted(const fs::path& path) { return "'" + path.string() + "'"; }

// "the input 'a.nhdr'", or "the data file 'a.raw' of the input 'a.nhdr' (its "data file" field)".
std::string input_text(const TouchedPath& in) {
  if (in.role.empty()) return "the input " + quoted(in.named);
  std::string text = fmt::format("the {} {} of the input {}", in.role, quoted(in.path), quoted(in.named));
  if (!in.field.empty()) text += fmt::format(" (its \"{}\" field names it)", in.field);
  return text;
}

// "'out.raw'", or "'out.nhdr' also writes its data file 'out.raw', which".
std::string output_text(const TouchedPath& out) {
  if (out.role.empty()) return quoted(out.named);
  return fmt::format("{} also writes its {} {}, which", quoted(out.named), out.role, quoted(out.path));
}

std::optional<std::string> conflict(const Located& o, const Located& i) {
  const TouchedPath &out = *o.touched, &in = *i.touched;
  const bool same = (o.id && i.id) ? *o.id == *i.id : o.resolved == i.resolved;
  if (same) {
    std::string how;
    if (in.role.empty() && out.role.empty() && out.path.lexically_normal() != in.path.lexically_normal())
      how = " (the same file by another path, a symlink or a hard link)";
    return fmt::format("{} is {}{}; writing it would destroy the input, choose another output", output_text(out),
                       input_text(in), how);
  }
  if (i.id && i.id->folder && o.inside(*i.id))
    return fmt::format("{} lies inside {}, a folder; writing there would change the input, choose an output outside "
                       "it",
                       output_text(out), input_text(in));
  if (out.replaced_folder && o.id && o.id->folder && i.inside(*o.id))
    return fmt::format("{} is a folder that writing replaces whole, and {} lies inside it; writing it would destroy "
                       "the input, choose another output",
                       output_text(out), input_text(in));
  return std::nullopt;
}

}  // namespace

TouchedPath touched_itself(const fs::path& path, bool replaced_folder) {
  return {.path = path, .named = path, .replaced_folder = replaced_folder};
}

std::vector<TouchedPath> files_read(const fs::path& given) {
  const fs::path path = split_container_path(given).first;
  std::vector<TouchedPath> files{touched_itself(path)};
  try {
    const VolumeFormat& format = detect_format(path);
    if (format.files_read)
      for (TouchedPath& t : format.files_read(path)) files.push_back(std::move(t));
  } catch (const Error&) {
    // not a volume (a .strata file, a colour map), or one its reader will refuse
  }
  return files;
}

std::vector<TouchedPath> plain_file_written(const fs::path& path) {
  std::vector<TouchedPath> files;
  detail::add_written_file(files, path, path);
  return files;
}

std::vector<TouchedPath> files_written(const fs::path& given, const WriteOptions& options) {
  const fs::path path = split_output_container(given).first;
  const VolumeFormat* format = nullptr;
  try {
    format = &output_format(path, options.format);
  } catch (const Error&) {
    return plain_file_written(path);  // its writer refuses it
  }
  if (!format->files_written) return plain_file_written(path);
  return format->files_written(path, options);
}

std::optional<std::string> overwrite_conflict(const std::vector<TouchedPath>& outputs,
                                              const std::vector<TouchedPath>& inputs) {
  const std::vector<Located> outs(outputs.begin(), outputs.end()), ins(inputs.begin(), inputs.end());
  for (const Located& out : outs)
    for (const Located& in : ins)
      if (auto why = conflict(out, in)) return why;
  return std::nullopt;
}

}  // namespace strata::io
