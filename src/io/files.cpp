// MappedFile, AtomicOutputFile, TempFile and read_json_file (include/strata/io/files.hpp): the
// POSIX side of reading and writing whole files.
#include "strata/io/files.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "io/io_detail.hpp"
#include "strata/core/error.hpp"

namespace strata::io {

std::string detail::system_error_text() { return std::strerror(errno); }

namespace {

using detail::system_error_text;

std::uint64_t page_size() {
  static const std::uint64_t size = std::uint64_t(sysconf(_SC_PAGESIZE));
  return size;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// MappedFile

MappedFile::MappedFile(const std::filesystem::path& path) {
  int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw Error(fmt::format("{}: cannot open: {}", path.string(), system_error_text()));
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    std::string why = system_error_text();
    ::close(fd);
    throw Error(fmt::format("{}: cannot stat: {}", path.string(), why));
  }
  size_ = std::uint64_t(st.st_size);
  // mmap rejects a zero length; an empty file simply has no bytes to map.
  if (size_ > 0) {
    // MAP_SHARED so that pages dropped by release() are refilled from the file if touched again.
    void* p = ::mmap(nullptr, size_, PROT_READ, MAP_SHARED, fd, 0);
    if (p == MAP_FAILED) {
      std::string why = system_error_text();
      ::close(fd);
      throw Error(fmt::format("{}: cannot memory-map {} bytes: {}", path.string(), size_, why));
    }
    data_ = static_cast<const std::byte*>(p);
  }
  ::close(fd);  // the mapping keeps the file alive
}

MappedFile::~MappedFile() {
  if (data_) ::munmap(const_cast<std::byte*>(data_), size_);
}

void MappedFile::release(std::uint64_t offset, std::uint64_t length) const {
  if (!data_ || length == 0 || offset >= size_) return;
  // Rounding outward is safe: a dropped page of a read-only shared mapping is re-read from the
  // page cache on the next touch, so a neighbour's data is never lost, only re-faulted.
  std::uint64_t end = std::min(size_, offset + length);
  std::uint64_t first = offset / page_size() * page_size();
  std::uint64_t last = (end + page_size() - 1) / page_size() * page_size();
  ::madvise(const_cast<std::byte*>(data_) + first, last - first, MADV_DONTNEED);
}

// ---------------------------------------------------------------------------------------------
// AtomicOutputFile

AtomicOutputFile::AtomicOutputFile(std::filesystem::path path) : path_(std::move(path)) {
  tmp_ = path_;
  tmp_ += ".tmp";
  file_ = std::fopen(tmp_.c_str(), "wb");
  if (!file_) throw Error(fmt::format("{}: cannot create: {}", tmp_.string(), system_error_text()));
}

AtomicOutputFile::~AtomicOutputFile() {
  if (!file_) return;  // committed (or failed in commit, which cleaned up)
  std::fclose(file_);
  std::error_code ignored;
  std::filesystem::remove(tmp_, ignored);
}

void AtomicOutputFile::write(const void* data, std::size_t bytes) {
  if (!file_) throw Error(fmt::format("{}: write after commit", path_.string()));
  if (bytes == 0) return;
  if (std::fwrite(data, 1, bytes, file_) != bytes)
    throw Error(fmt::format("{}: write failed: {}", tmp_.string(), system_error_text()));
}

void AtomicOutputFile::commit() {
  if (!file_) throw Error(fmt::format("{}: committed twice", path_.string()));
  std::FILE* f = file_;
  file_ = nullptr;
  // fclose flushes the buffer; a full disk shows up here, so its result decides the commit.
  bool flushed = std::fflush(f) == 0 && ::fsync(::fileno(f)) == 0;
  std::string why = flushed ? "" : system_error_text();
  if (std::fclose(f) != 0 && flushed) {
    flushed = false;
    why = system_error_text();
  }
  std::error_code ec;
  if (flushed) std::filesystem::rename(tmp_, path_, ec);
  if (!flushed || ec) {
    std::error_code ignored;
    std::filesystem::remove(tmp_, ignored);
    throw Error(fmt::format("{}: cannot finish writing: {}", path_.string(), flushed ? ec.message() : why));
  }
}

// ---------------------------------------------------------------------------------------------
// TempFile

TempFile::TempFile(const std::filesystem::path& dir, const std::string& stem) {
  std::string pattern = (dir / (stem + "-XXXXXX")).string();
  std::vector<char> name(pattern.begin(), pattern.end());
  name.push_back('\0');
  int fd = ::mkstemp(name.data());
  if (fd < 0) throw Error(fmt::format("{}: cannot create a temporary file: {}", dir.string(), system_error_text()));
  ::close(fd);
  path_ = name.data();
}

TempFile::~TempFile() {
  std::error_code ignored;
  std::filesystem::remove(path_, ignored);
}

// ---------------------------------------------------------------------------------------------
// read_json_file

nlohmann::json read_json_file(const std::filesystem::path& path, std::string_view field) {
  std::ifstream in(path);
  if (!in) throw Error(fmt::format("{}: cannot open", path.string()));
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw FormatError(path.string(), std::string(field), std::string("invalid JSON: ") + e.what());
  }
}

}  // namespace strata::io
