#pragma once
// Shared building blocks of the io module (private to src/io): gzip streams, output that is
// gzip-compressed or not, gzip inputs decoded to a temporary file, and a source over a raw
// byte region of a memory-mapped file. Format readers/writers (raw, nrrd, nifti, tiff) are
// built from these. The plain-file classes (MappedFile, AtomicOutputFile, TempFile) are public
// in strata/io/files.hpp; code in this namespace names them unqualified.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "strata/io/files.hpp"
#include "strata/io/volume_io.hpp"

namespace strata::io::detail {

// strerror(errno), for the message after a failed system call.
std::string system_error_text();

// ASCII lower case, for file extensions and header field names.
std::string ascii_lower(std::string text);

// Writes `text` to `<path>.tmp` and renames it to `path` (a sidecar, a detached header).
void write_file_atomically(const std::filesystem::path& path, std::string_view text);

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

// An AtomicOutputFile that starts with `prefix` as is (a header) and gzip-compresses everything
// written after it when `gzip` is set. commit() ends the gzip stream, then renames the file.
class OutputStream {
 public:
  OutputStream(const std::filesystem::path& path, bool gzip, std::string_view prefix = {});
  void write(const void* data, std::size_t bytes);
  void commit();
 private:
  AtomicOutputFile file_;
  std::unique_ptr<GzipWriter> gzip_;  // declared after file_: destroyed first, it refers to file_
};

// Decodes gzip data (one or more members) to a raw file, reporting progress in input bytes.
// Throws FormatError(file, field, ...) on a corrupt or truncated stream.
void gunzip_to_file(const std::byte* data, std::uint64_t size, const std::filesystem::path& out,
                    const std::string& file_for_errors, const std::string& field, ProgressSink& progress);
// Decodes a whole gzip buffer into memory (small headers, tests).
std::vector<std::byte> gunzip_to_memory(const std::byte* data, std::uint64_t size, const std::string& file_for_errors,
                                        const std::string& field);
bool looks_gzipped(const std::byte* data, std::uint64_t size);
// Decodes gzip data into a new temporary file `<stem>-XXXXXX` in options.temp_dir (default: the
// system temp dir), reporting progress to options.progress; the file goes when the result dies.
std::shared_ptr<TempFile> gunzip_to_temp_file(const std::byte* data, std::uint64_t size, const ReadOptions& options,
                                              const std::string& stem, const std::string& file_for_errors,
                                              const std::string& field);

// Throws Error naming `path` unless `box` is non-empty and lies inside `dims` (VolumeSource::read_box).
void check_box_inside(const Box& box, const Extent& dims, const std::filesystem::path& path);

// A VolumeSource over x-fastest samples at `offset` of a mapped file, optionally byte-swapped.
// Checks that offset + info.byte_size() fits in the file (else FormatError naming `field`).
std::unique_ptr<VolumeSource> make_mapped_source(std::shared_ptr<MappedFile> file, std::uint64_t offset,
                                                 const VolumeInfo& info, bool big_endian,
                                                 std::filesystem::path path, const std::string& field,
                                                 std::shared_ptr<TempFile> keep_alive = nullptr);

// Swaps bytes of `count` samples of `sample_size` bytes in place (big endian <-> native).
void byte_swap(std::byte* data, std::size_t count, std::size_t sample_size);

// Format entry points, dispatched from volume_io.cpp. create_volume_writer() wraps every writer
// in the slab checks all formats share (x/y/dtype match the volume, no more than dims.z slices,
// finish() only after all of them), so the format writers do not repeat them.
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
