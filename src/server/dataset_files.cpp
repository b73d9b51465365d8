// Which files `strata serve A B DIR ...` serves.
#include <algorithm>
#include <string>

#include <fmt/format.h>

#include "strata/core/error.hpp"
#include "strata/io/byte_source.hpp"
#include "strata/io/file_names.hpp"
#include "strata/io/formats.hpp"
#include "strata/server/api.hpp"

namespace strata::server {

namespace fs = std::filesystem;

namespace {

// A volume file as docs/viewer.md lists them: a .strata file, or a file of a registered format
// that opens without options (not a raw file without its JSON sidecar: its dims and dtype are
// unknown). Hidden files are skipped.
bool is_volume_file(const fs::path& file) {
  const std::string name = file.filename().string();
  if (name.empty() || name[0] == '.') return false;
  if (name.size() > io::kStrataExtension.size() && name.ends_with(io::kStrataExtension)) return true;
  const io::VolumeFormat* format = io::format_by_extension(file);
  return format && (!format->opens_alone || format->opens_alone(file));
}

// ".strata, .raw, .bin, ...; raw files only when they open without options": what a folder
// needs, for the message when it has none.
std::string volume_names() {
  std::string names(io::kStrataExtension), conditions;
  for (const io::VolumeFormat* f : io::formats()) {
    for (const std::string& ext : f->extensions) names += ", " + ext;
    if (f->opens_alone) conditions += fmt::format("; {} files only when they open without options", f->title);
  }
  return names + conditions;
}

}  // namespace

std::vector<DatasetFile> dataset_files(const std::vector<std::string>& arguments) {
  std::vector<DatasetFile> files;
  for (const std::string& argument : arguments) {
    const fs::path path(argument);
    if (io::is_url(argument)) {  // a remote .strata file: opening it checks it
      files.push_back({path, {}});
      continue;
    }
    if (!fs::exists(path)) throw Error(argument + ": no such file or folder");
    if (!fs::is_directory(path)) {
      files.push_back({path, {}});
      continue;
    }
    std::vector<fs::path> inside;
    for (const fs::directory_entry& e : fs::directory_iterator(path))
      if (e.is_regular_file() && is_volume_file(e.path())) inside.push_back(e.path());
    if (inside.empty())
      throw Error(argument + ": no volume files inside (" + volume_names() + ")");
    std::sort(inside.begin(), inside.end());
    for (const fs::path& file : inside) files.push_back({file, path});
  }
  return files;
}

}  // namespace strata::server
