// MappedFile, AtomicOutputFile, TempFile and read_json_file (include/strata/io/files.hpp): the
// POSIX side of reading and writing whole files.
#include "strata/io/files.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "io/io_detail.hpp"
#include "strata/core/error.hpp"
#include "strata/io/file_names.hpp"

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
  // O_NONBLOCK: opening a FIFO must not wait for a writer; it is refused below like any
  // other file that is not a regular file.
  int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) throw Error(fmt::format("{}: cannot open: {}", path.string(), system_error_text()));
  struct Close { int fd; ~Close() { ::close(fd); } } closer{fd};
  map(fd, path.string());
}

MappedFile::MappedFile(int fd, const std::string& name) { map(fd, name); }

void MappedFile::map(int fd, const std::string& name) {
  struct stat st {};
  if (::fstat(fd, &st) != 0) throw Error(fmt::format("{}: cannot stat: {}", name, system_error_text()));
  if (S_ISDIR(st.st_mode)) throw Error(fmt::format("{}: is a folder, expected a file", name));
  if (!S_ISREG(st.st_mode)) throw Error(fmt::format("{}: is not a regular file (a device, FIFO or socket)", name));
  size_ = std::uint64_t(st.st_size);
  // mmap rejects a zero length; an empty file simply has no bytes to map.
  if (size_ > 0) {
    // MAP_SHARED so that pages dropped by release() are refilled from the file if touched again.
    void* p = ::mmap(nullptr, size_, PROT_READ, MAP_SHARED, fd, 0);
    if (p == MAP_FAILED) throw Error(fmt::format("{}: cannot memory-map {} bytes: {}", name, size_, system_error_text()));
    data_ = static_cast<const std::byte*>(p);
  }
  // The caller closes `fd`: the mapping keeps the file alive.
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
  tmp_ += kTemporarySuffix;
  tmp_on_signal_ = RemovedOnSignal(tmp_);  // before the file exists: no instant leaves it behind
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
  if (flushed && !ec) tmp_on_signal_.release();
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
  on_signal_ = RemovedOnSignal(path_);
}

TempFile::~TempFile() {
  std::error_code ignored;
  std::filesystem::remove(path_, ignored);
}

// ---------------------------------------------------------------------------------------------
// UnnamedTempFile

UnnamedTempFile::UnnamedTempFile(const std::filesystem::path& dir, const std::string& stem) : dir_(dir) {
#ifdef O_TMPFILE
  fd_ = ::open(dir.c_str(), O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);
#endif
  if (fd_ >= 0) return;
  // No O_TMPFILE here (some file systems lack it): a named file, unlinked before anything is
  // written, so at most an empty file can outlive a kill in the instant between the two calls.
  std::string pattern = (dir / (stem + "-XXXXXX")).string();
  std::vector<char> name(pattern.begin(), pattern.end());
  name.push_back('\0');
  fd_ = ::mkostemp(name.data(), O_CLOEXEC);
  if (fd_ < 0) throw Error(fmt::format("{}: cannot create a temporary file: {}", dir.string(), system_error_text()));
  ::unlink(name.data());
}

UnnamedTempFile::~UnnamedTempFile() {
  if (fd_ >= 0) ::close(fd_);
}

void UnnamedTempFile::write(const void* data, std::size_t bytes) {
  const auto* p = static_cast<const char*>(data);
  while (bytes > 0) {
    const ssize_t n = ::write(fd_, p, bytes);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0)
      throw Error(fmt::format("{}: cannot write a temporary file: {}", dir_.string(),
                              n < 0 ? system_error_text() : std::string("no space written")));
    p += n;
    bytes -= std::size_t(n);
  }
}

// ---------------------------------------------------------------------------------------------
// read_json_file

// Strata's own words for a JSON library error: the library's text quotes the bytes it read last
// ("last read: '...'"), which may be anything the file holds, so only the position and the kind
// of problem are kept.
std::string json_error_reason(const std::exception& error) {
  const std::string_view text = error.what();
  const auto has = [&](std::string_view part) { return text.find(part) != std::string_view::npos; };
  if (const auto* range = dynamic_cast<const nlohmann::json::out_of_range*>(&error); range && range->id == 406)
    return "a number is too large (expected numbers within the range of a 64-bit float, about 1.8e308)";
  const auto* parse = dynamic_cast<const nlohmann::json::parse_error*>(&error);
  if (!parse) {
    const auto* json = dynamic_cast<const nlohmann::json::exception*>(&error);
    return json ? fmt::format("not readable as JSON (JSON library error {})", json->id) : "not readable as JSON";
  }
  std::string where = fmt::format("at byte {}", parse->byte);
  unsigned long line = 0, column = 0;  // the library's "parse error at line L, column C: ..."
  const std::size_t at = text.find("at line ");
  if (at != std::string_view::npos && std::sscanf(text.data() + at, "at line %lu, column %lu", &line, &column) == 2)
    where = fmt::format("at line {}, column {}", line, column);
  if (has("empty input")) return "the text is empty, expected a JSON document";
  if (has("unexpected end of input")) return "the text ends " + where + ", before the JSON document is complete";
  if (has("invalid string"))
    return "the string " + where + " is not valid (expected UTF-8 text with JSON escapes and no control characters)";
  if (has("invalid number")) return "the number " + where + " is not a valid JSON number";
  if (has("invalid literal"))
    return "no JSON value starts " + where + " (expected an object, array, string, number, true, false or null)";
  if (has("expected end of input")) return "more text follows the JSON document " + where;
  return "a syntax error " + where + " (expected JSON: an object, array, string, number, true, false or null)";
}

nlohmann::json read_json_file(const std::filesystem::path& path, std::string_view field) {
  std::ifstream in(path);
  if (!in) throw Error(fmt::format("{}: cannot open", path.string()));
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw FormatError(path.string(), std::string(field), "invalid JSON: " + json_error_reason(e));
  }
}

}  // namespace strata::io
