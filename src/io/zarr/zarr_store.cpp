// The folder store (one file per key, read with pread) and the choice between folder and zip.
#include "io/zarr/zarr_store.hpp"

#include <algorithm>

#include <fcntl.h>
#include <unistd.h>

#include <fmt/format.h>

#include "io/io_detail.hpp"
#include "io/zarr/http_store.hpp"
#include "io/zarr/zip_store.hpp"
#include "strata/core/checked.hpp"
#include "strata/core/error.hpp"
#include "strata/io/byte_source.hpp"

namespace strata::io::detail {

namespace {

namespace fs = std::filesystem;

class FolderStore final : public ZarrStore {
 public:
  explicit FolderStore(fs::path root) : root_(std::move(root)) {}

  std::optional<std::uint64_t> size(const std::string& key) const override {
    std::error_code ec;
    const fs::path file = path(key);
    if (!fs::is_regular_file(file, ec)) return std::nullopt;
    const std::uintmax_t n = fs::file_size(file, ec);
    if (ec) throw FormatError(file.string(), "metadata", fmt::format("cannot read: {}", ec.message()));
    return n;
  }

  std::vector<std::byte> read(const std::string& key, std::uint64_t offset, std::uint64_t length,
                              const std::string& field) const override {
    const std::string file = name(key);
    const int fd = ::open(path(key).c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) throw FormatError(file, field, fmt::format("cannot open: {}", system_error_text()));
    struct Close { int fd; ~Close() { ::close(fd); } } close_guard{fd};
    const off_t end = ::lseek(fd, 0, SEEK_END);
    const auto range_end = checked_add(offset, length);
    if (end < 0 || !range_end || *range_end > std::uint64_t(end))
      throw FormatError(file, field, fmt::format("bytes {}..+{} are outside the file of {} bytes", offset, length,
                                                 std::int64_t(end)));
    std::vector<std::byte> out(length);
    std::uint64_t done = 0;
    while (done < length) {
      const ssize_t n = ::pread(fd, out.data() + done, length - done, off_t(offset + done));
      if (n <= 0) throw FormatError(file, field, fmt::format("cannot read: {}", n < 0 ? system_error_text() : "short file"));
      done += std::uint64_t(n);
    }
    return out;
  }

  std::vector<std::string> children(const std::string& prefix) const override {
    std::vector<std::string> names;
    std::error_code ec;
    for (const auto& entry : fs::directory_iterator(path(prefix), ec))
      if (entry.is_directory(ec)) names.push_back(entry.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  }

  std::string name(const std::string& key) const override { return path(key).string(); }

 private:
  fs::path path(const std::string& key) const { return key.empty() ? root_ : root_ / key; }
  fs::path root_;
};

}  // namespace

std::string join_key(const std::string& prefix, const std::string& name) {
  return prefix.empty() ? name : name.empty() ? prefix : prefix + "/" + name;
}

bool is_zip_store_name(const fs::path& path) { return ascii_lower(path.filename().string()).ends_with(".zip"); }

std::shared_ptr<const ZarrStore> open_zarr_store(const fs::path& path) {
  if (is_url(path.string())) return open_http_store(path.string());
  std::error_code ec;
  if (fs::is_directory(path, ec)) return std::make_shared<FolderStore>(path);
  if (fs::is_regular_file(path, ec)) return open_zip_store(path);
  return std::make_shared<FolderStore>(path);  // missing: the reader reports what it lacks
}

}  // namespace strata::io::detail
