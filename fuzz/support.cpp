#include "support.hpp"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <system_error>

#include "strata/core/progress.hpp"
#include "strata/core/statistics.hpp"
#include "strata/core/threads.hpp"
#include "strata/io/slab_stream.hpp"

namespace strata::fuzz {

namespace {

struct TempDir {
  std::filesystem::path path;
  TempDir() {
    std::string pattern = (std::filesystem::temp_directory_path() / "strata-fuzz-XXXXXX").string();
    if (!::mkdtemp(pattern.data())) {
      std::perror("strata fuzz: mkdtemp");
      std::abort();
    }
    path = pattern;
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
};

}  // namespace

const std::filesystem::path& temp_dir() {
  static TempDir dir;
  return dir.path;
}

std::filesystem::path write_input(const std::string& name, std::span<const std::byte> bytes) {
  std::filesystem::path p = temp_dir() / name;
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  out.close();
  if (!out) {
    std::fprintf(stderr, "strata fuzz: cannot write %s\n", p.c_str());
    std::abort();
  }
  return p;
}

std::filesystem::path write_input(const std::string& name, std::string_view text) {
  return write_input(name, std::span<const std::byte>(reinterpret_cast<const std::byte*>(text.data()), text.size()));
}

void read_volume_file(const std::filesystem::path& path, const io::ReadOptions& options) {
  io::ReadOptions read = options;
  read.temp_dir = temp_dir();
  auto source = io::open_volume(path, read);
  const VolumeInfo& info = source->info();
  if (small_extent(info.dims.x, info.dims.y, info.dims.z, std::int64_t(64) << 20)) {
    StatisticsAccumulator stats;
    io::for_each_slab(*source, [&](const Volume& slab, std::int64_t) { stats.add(slab); }, silent_progress(), "fuzz");
    (void)stats.result();
    return;
  }
  const Extent d = info.dims;
  for (int corner = 0; corner < 8; ++corner) {
    const Extent lo{corner & 1 ? d.x - 1 : 0, corner & 2 ? d.y - 1 : 0, corner & 4 ? d.z - 1 : 0};
    (void)source->read_box(Box{lo, Extent{lo.x + 1, lo.y + 1, lo.z + 1}});
  }
}

void init() {
  set_thread_count(1);
  (void)temp_dir();
}

void unexpected_exception(const char* what, const char* type) {
  std::fprintf(stderr, "strata fuzz: an exception that is not strata::Error escaped: %s: %s\n", type, what);
  std::fflush(stderr);
  std::abort();
}

}  // namespace strata::fuzz
