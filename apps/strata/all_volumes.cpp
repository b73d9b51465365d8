#include "all_volumes.hpp"

#include <cstdio>
#include <vector>

#include <fmt/format.h>

#include "report.hpp"
#include "strata/store/volume_set.hpp"

namespace strata::cli {

namespace {

namespace fs = std::filesystem;

// The members while they are made: hidden files beside the output (same file system, so the
// set's writer copies them locally), removed however the command ends.
class MemberFiles {
 public:
  MemberFiles(const fs::path& output, std::int64_t count) {
    for (std::int64_t i = 0; i < count; ++i)
      paths_.push_back(output.parent_path() / fmt::format(".{}.volume{}.part", output.filename().string(), i));
  }
  ~MemberFiles() {
    std::error_code ignored;
    for (const fs::path& p : paths_) fs::remove(p, ignored);
  }
  MemberFiles(const MemberFiles&) = delete;
  MemberFiles& operator=(const MemberFiles&) = delete;
  const std::vector<fs::path>& paths() const { return paths_; }

 private:
  std::vector<fs::path> paths_;
};

}  // namespace

std::int64_t encode_all_volumes(const std::string& input, io::ReadOptions read, const std::string& output,
                                const EncodeVolume& encode) {
  read.volume = 0;
  auto first = io::open_volume(input, read);
  const std::int64_t count = first->info().volumes;
  if (count == 1) {
    encode(*first, output, output);
    return 1;
  }
  first.reset();
  const MemberFiles members(output, count);
  for (std::int64_t i = 0; i < count; ++i) {
    read.volume = i;
    auto source = io::open_volume(input, read);
    encode(*source, members.paths()[std::size_t(i)], fmt::format("{} (volume {})", output, i));
  }
  store::write_volume_set(output, members.paths(),
                          {{"file", fs::path(input).filename().string()}, {"volume_count", count}});
  std::printf("%s: a volume set of %lld volumes, %s\n", output.c_str(), (long long)count,
              human_bytes(fs::file_size(output)).c_str());
  return count;
}

CLI::Option* add_all_volumes_flag(CLI::App& cmd, bool& all_volumes) {
  CLI::Option* flag = cmd.add_flag("--all-volumes", all_volumes,
                      "Store every volume of a file that holds several (time points, components, channels) as one "
                      ".strata volume set; open one later with --volume T");
  if (CLI::Option* volume = cmd.get_option_no_throw("--volume")) flag->excludes(volume);
  return flag;
}

}  // namespace strata::cli
