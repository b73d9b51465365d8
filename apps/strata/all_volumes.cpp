#include "all_volumes.hpp"

#include <cstdio>
#include <string_view>
#include <vector>

#include <fmt/format.h>

#include "cli_checks.hpp"
#include "report.hpp"
#include "strata/io/file_names.hpp"
#include "strata/io/signal_cleanup.hpp"
#include "strata/store/volume_set.hpp"

namespace strata::cli {

namespace {

namespace fs = std::filesystem;

// Member `index` of the set written to `output`: a hidden file beside it (same file system, so
// the set's writer copies it locally).
fs::path member_path(const fs::path& output, std::int64_t index) {
  return output.parent_path() / fmt::format(".{}.volume{}.part", output.filename().string(), index);
}

// Whether `name` is a member of a set written to `output`, or a member's temporary:
// ".<output>.volume<N>.part" or ".<output>.volume<N>.part.tmp".
bool is_member_name(const std::string& name, const fs::path& output) {
  const std::string prefix = "." + output.filename().string() + ".volume";
  if (!name.starts_with(prefix)) return false;
  std::string_view rest = std::string_view(name).substr(prefix.size());
  const std::size_t digits = rest.find_first_not_of("0123456789");
  if (digits == 0 || digits == std::string_view::npos) return false;
  rest.remove_prefix(digits);
  return rest == ".part" || rest == std::string(".part") + std::string(io::kTemporarySuffix);
}

// The members while they are made: removed however the command ends, a stop signal included
// (io::RemovedOnSignal). A run killed by SIGKILL leaves them; the next run writing the same
// output removes them first.
class MemberFiles {
 public:
  MemberFiles(const fs::path& output, std::vector<fs::path> paths) : paths_(std::move(paths)) {
    remove_stale(output);
    for (const fs::path& p : paths_) on_signal_.emplace_back(p);
  }
  ~MemberFiles() {
    std::error_code ignored;
    for (const fs::path& p : paths_) fs::remove(p, ignored);
  }
  MemberFiles(const MemberFiles&) = delete;
  MemberFiles& operator=(const MemberFiles&) = delete;
  const std::vector<fs::path>& paths() const { return paths_; }

 private:
  // Members of an earlier run that was killed (SIGKILL, a power cut), of any count.
  static void remove_stale(const fs::path& output) {
    const fs::path dir = output.parent_path().empty() ? fs::path(".") : output.parent_path();
    std::error_code ec;
    std::vector<fs::path> stale;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
      if (is_member_name(it->path().filename().string(), output)) stale.push_back(it->path());
    for (const fs::path& p : stale) fs::remove(p, ec);
  }

  std::vector<fs::path> paths_;
  std::vector<io::RemovedOnSignal> on_signal_;  // released after the destructor removed the files
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
  std::vector<fs::path> parts;
  for (std::int64_t i = 0; i < count; ++i) parts.push_back(member_path(output, i));
  check_spares_inputs(parts, "--output", {input});
  const MemberFiles members(output, std::move(parts));
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
