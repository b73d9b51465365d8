// Which files `strata serve A B DIR ...` serves.
#include <algorithm>
#include <array>
#include <string_view>

#include "strata/core/error.hpp"
#include "strata/server/api.hpp"

namespace strata::server {

namespace fs = std::filesystem;

namespace {

bool ends_with(const std::string& name, std::string_view suffix) {
  return name.size() > suffix.size() && name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// A volume file as docs/viewer.md lists them: raw files only with their JSON sidecar, since
// without it their dims and dtype are unknown.
bool is_volume_file(const fs::path& file) {
  const std::string name = file.filename().string();
  if (name.empty() || name[0] == '.') return false;
  static constexpr std::array<std::string_view, 7> kExtensions{".strata", ".nrrd", ".nhdr", ".nii", ".nii.gz", ".tif", ".tiff"};
  for (std::string_view ext : kExtensions)
    if (ends_with(name, ext)) return true;
  if (ends_with(name, ".raw")) {
    fs::path sidecar = file;
    sidecar.replace_extension(".json");
    return fs::is_regular_file(file.string() + ".json") || fs::is_regular_file(sidecar);
  }
  return false;
}

}  // namespace

std::vector<fs::path> dataset_files(const std::vector<std::string>& arguments) {
  std::vector<fs::path> files;
  for (const std::string& argument : arguments) {
    const fs::path path(argument);
    if (!fs::exists(path)) throw Error(argument + ": no such file or folder");
    if (!fs::is_directory(path)) {
      files.push_back(path);
      continue;
    }
    std::vector<fs::path> inside;
    for (const fs::directory_entry& e : fs::directory_iterator(path))
      if (e.is_regular_file() && is_volume_file(e.path())) inside.push_back(e.path());
    if (inside.empty())
      throw Error(argument + ": no volume files inside (.strata, .nrrd, .nhdr, .nii, .nii.gz, .tif, .tiff, .raw + .json)");
    std::sort(inside.begin(), inside.end());
    files.insert(files.end(), inside.begin(), inside.end());
  }
  return files;
}

}  // namespace strata::server
