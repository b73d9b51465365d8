#pragma once
// Shared building blocks of the io module (private to src/io): memory-mapped files, atomic
// output, gzip streams, and a source over a raw byte region. Format readers/writers
// (raw, nrrd, nifti, tiff) are built from these.
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "strata/io/volume_io.hpp"

namespace strata::io::detail {

// Read-only mmap of a whole file. release() drops pages already consumed so streaming a
// file larger than memory keeps the resident set small.
class MappedFile {
 public:
  explicit MappedFile(const std::filesystem::path& path);  // throws Error naming the path
  ~MappedFile();
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;
  const std::byte* data() const { return data_; }
  std::uint64_t size() const { return size_; }
  void release(std::uint64_t offset, std::uint64_t length) const;  // madvise(DONTNEED)
 private:
  const std::byte* data_ = nullptr;
  std::uint64_t size_ = 0;
};

// A file written as `<path>.tmp` and renamed to `<path>` by commit(); removed if never committed.
class AtomicOutputFile {
 public:
  explicit AtomicOutputFile(std::filesystem::path path);
  ~AtomicOutputFile();
  void write(const void* data, std::size_t bytes);  // throws Error on short write (disk full)
  void commit();
  std::FILE* handle() { return file_; }
  const std::filesystem::path& path() const { return path_; }
 private:
  std::filesystem::path path_, tmp_;
  std::FILE* file_ = nullptr;
};

// Streaming gzip (RFC 1952) compression into an AtomicOutputFile.
class GzipWriter {
 public:
  explicit GzipWriter(AtomicOutputFile& out, int level = 6);
  ~GzipWriter();
  void write(const void* data, std::size_t bytes);
  void finish();  // flushes the deflate stream; call before out.commit()
 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// A temporary file removed when the object dies (for decoded gzip inputs).
class TempFile {
 public:
  explicit TempFile(const std::filesystem::path& dir, const std::string& stem);
  ~TempFile();
  const std::filesystem::path& path() const { return path_; }
 private:
  std::filesystem::path path_;
};

// Decodes gzip data (one or more members) to a raw file, reporting progress in input bytes.
// Throws FormatError(file, field, ...) on a corrupt or truncated stream.
void gunzip_to_file(const std::byte* data, std::uint64_t size, const std::filesystem::path& out,
                    const std::string& file_for_errors, const std::string& field, ProgressSink& progress);
// Decodes a whole gzip buffer into memory (small headers, tests).
std::vector<std::byte> gunzip_to_memory(const std::byte* data, std::uint64_t size, const std::string& file_for_errors,
                                        const std::string& field);
bool looks_gzipped(const std::byte* data, std::uint64_t size);

// A VolumeSource over x-fastest samples at `offset` of a mapped file, optionally byte-swapped.
// Checks that offset + info.byte_size() fits in the file (else FormatError naming `field`).
std::unique_ptr<VolumeSource> make_mapped_source(std::shared_ptr<MappedFile> file, std::uint64_t offset,
                                                 const VolumeInfo& info, bool big_endian,
                                                 std::filesystem::path path, const std::string& field,
                                                 std::shared_ptr<TempFile> keep_alive = nullptr);

// Swaps bytes of `count` samples of `sample_size` bytes in place (big endian <-> native).
void byte_swap(std::byte* data, std::size_t count, std::size_t sample_size);

// Format entry points, dispatched from volume_io.cpp.
std::unique_ptr<VolumeSource> open_raw(const std::filesystem::path& path, const ReadOptions& options);
std::unique_ptr<VolumeWriter> create_raw_writer(const std::filesystem::path& path, const VolumeInfo& info,
                                                const WriteOptions& options);
std::unique_ptr<VolumeSource> open_nrrd(const std::filesystem::path& path, const ReadOptions& options);
std::unique_ptr<VolumeWriter> create_nrrd_writer(const std::filesystem::path& path, const VolumeInfo& info,
                                                 const WriteOptions& options);
std::unique_ptr<VolumeSource> open_nifti(const std::filesystem::path& path, const ReadOptions& options);
std::unique_ptr<VolumeWriter> create_nifti_writer(const std::filesystem::path& path, const VolumeInfo& info,
                                                  const WriteOptions& options);
std::unique_ptr<VolumeSource> open_tiff(const std::filesystem::path& path, const ReadOptions& options);
std::unique_ptr<VolumeWriter> create_tiff_writer(const std::filesystem::path& path, const VolumeInfo& info,
                                                 const WriteOptions& options);

}  // namespace strata::io::detail
