#pragma once
// Shared building blocks of the io module (private to src/io): gzip streams, output that is
// gzip-compressed or not, gzip inputs decoded to a temporary file, and a source over a raw
// byte region of a memory-mapped file. Format readers/writers (raw, nrrd, nifti, tiff) are
// built from these; their registry entries are declared in builtin_formats.hpp. The plain-file
// classes (MappedFile, AtomicOutputFile, TempFile) are public in strata/io/files.hpp; code in
// this namespace names them unqualified.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "strata/io/file_names.hpp"
#include "strata/io/files.hpp"
#include "strata/io/touched_paths.hpp"
#include "strata/io/volume_io.hpp"

namespace strata::io::detail {

// strerror(errno), for the message after a failed system call.
std::string system_error_text();

// ASCII lower case, for file extensions and header field names.
std::string ascii_lower(std::string text);

// What gzip-compressed files add to their name (".nii.gz", a detached NRRD's ".raw.gz").
inline constexpr std::string_view kGzipSuffix = kGzSuffix;

// Writes `text` to `<path>.tmp` and renames it to `path` (a sidecar, a detached header).
void write_file_atomically(const std::filesystem::path& path, std::string_view text);

// Appends what writing `file` (as `<file>.tmp`, renamed into place) touches to `out`: the file
// and its temporary, as the `role` of the output `named` (no role: the output itself).
void add_written_file(std::vector<TouchedPath>& out, const std::filesystem::path& file,
                      const std::filesystem::path& named, const std::string& role = {});
// What a writer that builds `folder` in `<folder>.tmp` and renames it over the old one touches:
// both folders, each replaced whole (VolumeFormat::files_written of folder formats).
std::vector<TouchedPath> replaced_folder_written(const std::filesystem::path& folder);

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
// A gzip stream (one or more members back to back, as `gzip` and `cat a.gz b.gz` produce; with
// `accept_zlib` also a zlib stream) decoded on demand. Bytes after a finished member that do not
// start another member are padding and ignored, as gzip(1) does. Throws FormatError(file, field,
// ...) when the data does not start like a stream, is corrupt, or ends before its end-of-member
// marker (a truncated file); each member's CRC is checked as its end is decoded.
class GzipStream {
 public:
  GzipStream(const std::byte* data, std::uint64_t size, std::string file, std::string field, bool accept_zlib = false);
  ~GzipStream();
  GzipStream(const GzipStream&) = delete;
  GzipStream& operator=(const GzipStream&) = delete;
  // Decodes the next bytes into `out`, at most `n`; fewer only at the end of the stream, and
  // none once it has ended (its last member's trailer checked).
  std::size_t read(std::byte* out, std::size_t n);
  // Decodes and drops up to `n` bytes; returns how many (fewer only at the end).
  std::uint64_t skip(std::uint64_t n);
  // Compressed bytes decoded so far (for progress).
  std::uint64_t consumed() const;
  std::uint64_t produced() const { return produced_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::uint64_t produced_ = 0;
};

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

// The folder decoded temporaries go to: `temp_dir` (ReadOptions::temp_dir), else the system's
// (TMPDIR); an Error naming `file` (the input that needs one) when TMPDIR is not a folder.
std::filesystem::path temp_folder(const std::optional<std::filesystem::path>& temp_dir, const std::string& file);

// Throws Error naming `file`, `field`, the `bytes` that `what` needs and the space free in `dir`
// when that folder has less room than `bytes`: a temporary that cannot fit is refused before
// anything is written to it (a folder whose space cannot be queried is not refused here).
void check_temp_space(const std::filesystem::path& dir, std::uint64_t bytes, const std::string& file,
                      const std::string& field, const std::string& what);

// Decodes gzip data into an unnamed temporary file in options.temp_dir (default: the system temp
// dir; `stem` names it where the file system needs a name for an instant), reporting progress to
// options.progress, and maps it. Nothing is left in the folder whatever stops the process; the
// space is freed with the mapping. At most declared.bytes + 1 bytes are decoded: a stream that
// decodes to more (a gzip bomb, or the wrong header) throws FormatError(file, field, ...) before
// it can fill the disk, and a declared size the temporary folder has no room for is refused
// before decoding (check_temp_space). A shorter stream is returned as is; the caller reports the
// shortfall.
std::shared_ptr<MappedFile> gunzip_to_temp_file(const std::byte* data, std::uint64_t size, const ReadOptions& options,
                                                const std::string& stem, const std::string& file_for_errors,
                                                const std::string& field, const DeclaredSize& declared);

// Throws the FormatError of a gzip stream that decodes to more than `declared`.
[[noreturn]] void throw_decodes_to_more(const std::string& file, const std::string& field, const DeclaredSize& declared);

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

// Where one 3D volume's samples lie in a gzip stream (NRRD gzip data, a .nii.gz file).
struct GzipVolume {
  VolumeInfo info;           // of the one volume
  bool big_endian = false;
  std::uint64_t offset = 0;  // decoded bytes before its first sample (interleaved: before every volume's)
  Interleave interleave{};
  DeclaredSize declared;     // what the whole stream decodes to, as the header declares it
  std::string field;         // the header field errors name ("data", "gzip")
  // Throws the format's error for a stream that ends after `decoded` bytes, before the samples
  // a read needs.
  std::function<void(std::uint64_t decoded)> report_short;
};

// A source over the volume `volume` describes in the gzip data at `start` of `compressed`, decoded
// as reads ask for it, never more than they need. Reads in z order (every slab pass: info,
// convert, compress, labels encode) decode the stream as they go, holding only the slices of the
// last read, and a pass that starts again at slice 0 decodes the stream again (twice at most).
// Other access (a read before the slices held, a third pass) decodes the volume's samples once
// into an unnamed temporary file in temp_folder(options), after check_temp_space, and reads
// them mapped from then on. A read that reaches the declared end checks that the stream ends
// there (a stream that decodes to more is a FormatError naming the declared size).
std::unique_ptr<VolumeSource> make_gzip_source(std::shared_ptr<MappedFile> compressed, std::uint64_t start,
                                               GzipVolume volume, std::filesystem::path path,
                                               const ReadOptions& options);

// Swaps bytes of `count` samples of `sample_size` bytes in place (big endian <-> native).
void byte_swap(std::byte* data, std::size_t count, std::size_t sample_size);

}  // namespace strata::io::detail
