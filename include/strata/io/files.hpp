#pragma once
// Plain files, as every module that reads or writes one needs them: a read-only memory map,
// output written as `<name>.tmp` and renamed into place, a self-deleting temporary file and a
// whole JSON document. All throw strata::Error naming the path and the system's reason.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <string>
#include <string_view>

#include <nlohmann/json_fwd.hpp>

#include "strata/io/signal_cleanup.hpp"

namespace strata::io {

// Read-only mmap of a whole file. release() drops pages already consumed so streaming a
// file larger than memory keeps the resident set small. Only regular files are mapped: a folder,
// FIFO or device is refused with an Error naming the path (a FIFO never blocks the open).
class MappedFile {
 public:
  explicit MappedFile(const std::filesystem::path& path);  // throws Error naming the path
  // Maps the file open as `fd` (not closed, not owned: the mapping outlives it); `name` is
  // what errors call the file.
  MappedFile(int fd, const std::string& name);
  ~MappedFile();
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;
  const std::byte* data() const { return data_; }
  std::uint64_t size() const { return size_; }
  void release(std::uint64_t offset, std::uint64_t length) const;  // madvise(DONTNEED)
 private:
  void map(int fd, const std::string& name);
  const std::byte* data_ = nullptr;
  std::uint64_t size_ = 0;
};

// A file written as `<path>.tmp` and renamed to `<path>` by commit(); removed if never committed,
// and by a stop signal (signal_cleanup.hpp) while it is being written.
class AtomicOutputFile {
 public:
  explicit AtomicOutputFile(std::filesystem::path path);
  ~AtomicOutputFile();
  AtomicOutputFile(const AtomicOutputFile&) = delete;
  AtomicOutputFile& operator=(const AtomicOutputFile&) = delete;
  void write(const void* data, std::size_t bytes);  // throws Error on short write (disk full)
  void commit();  // flushes, fsyncs and renames; throws Error (and removes the temporary) on failure
  std::FILE* handle() { return file_; }  // for seeking back to patch a header before commit()
  const std::filesystem::path& path() const { return path_; }
 private:
  std::filesystem::path path_, tmp_;
  RemovedOnSignal tmp_on_signal_;
  std::FILE* file_ = nullptr;
};

// A temporary file `<dir>/<stem>-XXXXXX` (created empty), removed when the object dies or a stop
// signal ends the process (signal_cleanup.hpp).
class TempFile {
 public:
  explicit TempFile(const std::filesystem::path& dir, const std::string& stem);
  ~TempFile();
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
  const std::filesystem::path& path() const { return path_; }
 private:
  std::filesystem::path path_;
  RemovedOnSignal on_signal_;
};

// A temporary file with no name: opened with O_TMPFILE in `dir` where the file system supports
// it, else created by mkstemp as `<dir>/<stem>-XXXXXX` and unlinked at once. Whatever stops the
// process (SIGKILL included), nothing is left in `dir`; the space is freed when the descriptor
// and every mapping of it (MappedFile(descriptor(), ...)) are gone.
class UnnamedTempFile {
 public:
  UnnamedTempFile(const std::filesystem::path& dir, const std::string& stem);
  ~UnnamedTempFile();
  UnnamedTempFile(const UnnamedTempFile&) = delete;
  UnnamedTempFile& operator=(const UnnamedTempFile&) = delete;
  int descriptor() const { return fd_; }
  const std::filesystem::path& dir() const { return dir_; }
  // Appends `bytes` bytes; throws Error naming the folder (disk full) on failure.
  void write(const void* data, std::size_t bytes);
 private:
  std::filesystem::path dir_;
  int fd_ = -1;
};

// Parses the whole file at `path` as JSON. Throws Error "<path>: cannot open" if it cannot be
// opened and FormatError(path, field, "invalid JSON: ...") if it does not parse; `field` is what
// the caller's messages call the document.
nlohmann::json read_json_file(const std::filesystem::path& path, std::string_view field);

/// @brief What a JSON parse error means, in Strata's words: its position and the kind of problem
/// ("no JSON value starts at line 1, column 9 (expected an object, ...)"), never the library's
/// text, which quotes the bytes it read last.
std::string json_error_reason(const std::exception& error);

}  // namespace strata::io
