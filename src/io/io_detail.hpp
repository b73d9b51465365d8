#pragma once
// Shared building blocks of the io module (private to src/io): gzip streams, output that is
// gzip-compressed or not, gzip inputs decoded to a temporary file, and a source over a raw
// byte region of a memory-mapped file. Format readers/writers (raw, nrrd, nifti, tiff) are
// built from these; their registry entries are declared in builtin_formats.hpp. The plain-file
// classes (MappedFile, AtomicOutputFile, TempFile) are public in strata/io/files.hpp; code in
// this namespace names them unqualified.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
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

// What gzip-compressed files add to their name (".nii.gz", a detached NRRD's ".raw.gz").
inline constexpr std::string_view kGzipSuffix = ".gz";

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

// Overwrites `bytes` at `offset` of a file being written (what is known only at the end: MRC's
// statistics, a VTK block table) and returns to its end; throws Error naming the file and `what`.
void patch_output(AtomicOutputFile& out, std::uint64_t offset, std::span<const std::byte> bytes, std::string_view what);

// Decoding stops after this many bytes unless the caller gives a bound.
inline constexpr std::uint64_t kNoDecodeLimit = ~std::uint64_t(0);

// Decodes gzip data (one or more members) into memory, at most `limit` bytes: a stream that
// decodes to more is cut there without reading (or checking) the rest, so a caller that needs a
// header reads only the header. Throws FormatError(file, field, ...) on a corrupt stream and on
// one that ends before its end-of-member marker (a truncated file). With `accept_zlib` a zlib
// (RFC 1950) stream is decoded too (Zarr's "zlib" compressor).
std::vector<std::byte> gunzip_to_memory(const std::byte* data, std::uint64_t size, const std::string& file_for_errors,
                                        const std::string& field, std::uint64_t limit = kNoDecodeLimit,
                                        bool accept_zlib = false);
bool looks_gzipped(const std::byte* data, std::uint64_t size);
bool looks_zlib(const std::byte* data, std::uint64_t size);

// What the header of a gzip-compressed volume says its decoded data holds.
struct DeclaredSize {
  std::uint64_t bytes;     // the decoded size the header declares
  std::string declared_by;  // the header fields that say so, for the message ("sizes 4x4x4 of uint8")
};

// Decodes gzip data into an unnamed temporary file in options.temp_dir (default: the system temp
// dir; `stem` names it where the file system needs a name for an instant), reporting progress to
// options.progress, and maps it. Nothing is left in the folder whatever stops the process; the
// space is freed with the mapping. At most declared.bytes + 1 bytes are decoded: a stream that
// decodes to more (a gzip bomb, or the wrong header) throws FormatError(file, field, ...) before
// it can fill the disk. A shorter stream is returned as is; the caller reports the shortfall.
std::shared_ptr<MappedFile> gunzip_to_temp_file(const std::byte* data, std::uint64_t size, const ReadOptions& options,
                                                const std::string& stem, const std::string& file_for_errors,
                                                const std::string& field, const DeclaredSize& declared);

// info.byte_size(), or FormatError(file, field, ...) when the dims are not all positive or
// dims × sample size overflows 64 bits: every reader checks dims from a header with this
// before it computes anything from them.
std::uint64_t checked_volume_bytes(const VolumeInfo& info, const std::string& file, const std::string& field);

// Throws Error naming `path` unless `box` is non-empty and lies inside `dims` (VolumeSource::read_box).
void check_box_inside(const Box& box, const Extent& dims, const std::filesystem::path& path);

// Samples of several volumes stored interleaved (a NRRD vector axis first: component fastest):
// the source reads volume `index` of `count`.
struct Interleave {
  std::int64_t count = 1, index = 0;
};

// A VolumeSource over x-fastest samples at `offset` of a mapped file, optionally byte-swapped.
// Checks that offset + info.byte_size() (times the interleaved count) fits in the file (else
// FormatError naming `field`).
std::unique_ptr<VolumeSource> make_mapped_source(std::shared_ptr<MappedFile> file, std::uint64_t offset,
                                                 const VolumeInfo& info, bool big_endian,
                                                 std::filesystem::path path, const std::string& field,
                                                 Interleave interleave = {});

// Which of a file's `volumes` 3D volumes to read: 0 for a file of one; for several the caller's
// choice (ReadOptions::volume), which must exist. Errors name `file`, `field` (the header field
// that makes several) and, in the hint, what the volumes are (`what`, e.g. "dim[4..7]").
std::int64_t choose_volume(std::int64_t volumes, const Extent& dims, const ReadOptions& options,
                           const std::string& file, const std::string& field, const std::string& what);

// Swaps bytes of `count` samples of `sample_size` bytes in place (big endian <-> native).
void byte_swap(std::byte* data, std::size_t count, std::size_t sample_size);

}  // namespace strata::io::detail
