#pragma once
/// @file
/// @brief The volume file formats io reads and writes, in one registry: each format's name,
/// extensions, signature sniffer, reader and writer factories and what it can do. open_volume,
/// create_volume_writer, `strata convert --help`, `strata formats` (and from it the README's
/// format table), `strata serve`'s folder listing and the Python module take formats from here
/// and from nowhere else.
///
/// Built-in entries: raw (+ JSON sidecar), NRRD, NIfTI-1/2, TIFF, each defined in its own file
/// (src/io/raw.cpp, nrrd.cpp, nifti.cpp, tiff.cpp) and registered by one line in
/// src/io/format_registry.cpp. Adding a format: one file with its VolumeFormat, one line there,
/// its docs (docs/formats.md) and tests; a test may register its own with register_format
/// (docs/formats.md says how).
///
/// Thread safety: register formats before reading or writing; lookups may run concurrently.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <initializer_list>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "strata/core/dtype.hpp"
#include "strata/io/touched_paths.hpp"
#include "strata/io/volume_io.hpp"

namespace strata::io {

/// @brief A set of sample types, e.g. what a format can write.
class DTypeSet {
 public:
  constexpr DTypeSet() = default;
  constexpr DTypeSet(std::initializer_list<DType> types) {
    for (DType t : types) bits_ |= bit(t);
  }
  /// @brief All ten sample types.
  static constexpr DTypeSet all() {
    DTypeSet s;
    for (DType t : kAllDTypes) s.bits_ |= bit(t);
    return s;
  }
  constexpr bool contains(DType t) const { return (bits_ & bit(t)) != 0; }
  constexpr bool empty() const { return bits_ == 0; }
  /// @brief This set without `t`.
  constexpr DTypeSet without(DType t) const {
    DTypeSet s = *this;
    s.bits_ &= std::uint16_t(~bit(t));
    return s;
  }
  /// @brief The integer types of this set: the label (segmentation) volumes it can hold.
  constexpr DTypeSet integers() const {
    DTypeSet s = *this;
    s.bits_ &= std::uint16_t(~(bit(DType::f32) | bit(DType::f64)));
    return s;
  }
  /// @brief The members in DType order.
  std::vector<DType> list() const;
  constexpr bool operator==(const DTypeSet&) const = default;

 private:
  static constexpr std::uint16_t bit(DType t) { return std::uint16_t(1u << unsigned(t)); }
  std::uint16_t bits_ = 0;
};

/// @brief What a format can do beyond reading a 3D volume.
struct FormatCapabilities {
  /// Boxes are read without reading the whole file (memory-mapped samples, pages read on
  /// demand, or compressed data decoded as passes in z order read it and, for other access,
  /// once to a temporary file that is then mapped), so files larger than memory stream slab by
  /// slab.
  bool streaming = false;
  /// A file may hold several 3D volumes (time points, components, channels), read one at a time
  /// through ReadOptions::volume. Without it open_volume refuses any volume but 0 itself.
  bool multi_volume = false;
  /// The voxel spacing travels with the samples (read and written).
  bool spatial_metadata = false;
  /// A file holds named arrays, chosen by ReadOptions::dataset (HDF5 datasets, Zarr groups).
  bool datasets = false;
  /// A file holds several resolutions of one volume, chosen by ReadOptions::level (OME-Zarr,
  /// Neuroglancer precomputed).
  bool multiscale = false;
};

/// @brief Opens a volume file of the format for reading; throws FormatError(file, field, ...) on
/// malformed input.
using FormatReader = std::function<std::unique_ptr<VolumeSource>(const std::filesystem::path& path,
                                                                 const ReadOptions& options)>;
/// @brief Starts writing `info` to `path`. create_volume_writer has already checked the dtype
/// against VolumeFormat::write_dtypes and wraps the writer in the slab checks every format shares
/// (x/y/dtype of each slab, no more than dims.z slices, finish() after all of them).
using FormatWriter = std::function<std::unique_ptr<VolumeWriter>(const std::filesystem::path& path,
                                                                 const VolumeInfo& info, const WriteOptions& options)>;
/// @brief Whether the first bytes of a file (VolumeFormat::magic_bytes of them, fewer when the
/// file is shorter) are this format's signature.
using MagicSniffer = std::function<bool(std::span<const std::byte> head)>;
/// @brief A yes/no question about a path (a folder's contents, a file's sidecar).
using PathPredicate = std::function<bool(const std::filesystem::path& path)>;

/// @brief What reading `path` touches beside it: its data files, its sidecar (touched_paths.hpp).
using ReadPaths = std::function<std::vector<TouchedPath>(const std::filesystem::path& path)>;
/// @brief Everything writing `path` creates or replaces, `path` itself and temporaries included.
using WrittenPaths = std::function<std::vector<TouchedPath>(const std::filesystem::path& path,
                                                            const WriteOptions& options)>;

/// @brief One entry of the registry: everything io and the front ends know about a format.
/// Every member has a default, so an entry names only what it has (designated initializers).
struct VolumeFormat {
  /// What `strata info` prints as "format", WriteOptions::format names and `strata formats`
  /// lists: lower case, unique ("nifti").
  std::string name{};
  /// The format as people write it, for tables and messages ("NIfTI-1, NIfTI-2").
  std::string title{};
  /// One line: what a file of the format is.
  std::string description{};
  /// File name endings with their dot, lower case, unique across formats; matched
  /// case-insensitively, the longest first (".nii.gz" before a ".gz" of another format). The
  /// first is the one writers add to derived names.
  std::vector<std::string> extensions{};
  /// How many leading bytes `sniff` looks at (0 when there is no sniffer).
  std::size_t magic_bytes = 0;
  /// Optional: recognises the format by content, for files whose name has no registered extension.
  MagicSniffer sniff{};
  /// Non-empty when a folder can be a volume of this format: what such a folder is, for
  /// messages and tables ("a directory of TIFF slices").
  std::string directory{};
  /// Optional, with `directory`: whether a folder holds this format. A folder whose name has
  /// no extension of a folder format goes to the first format whose predicate accepts it, else
  /// to the first folder format without a predicate.
  PathPredicate sniff_directory{};
  /// Optional: whether an http:// or https:// URL is a volume of this format. Only formats
  /// with it read from web servers; a URL whose name ends with one of their extensions is
  /// theirs without asking.
  std::function<bool(const std::string& url)> sniff_url{};
  /// Optional: whether a file opens with default ReadOptions (raw: only beside its JSON
  /// sidecar). `strata serve` lists a folder's files of the format only when it holds. Unset:
  /// every file of the format does.
  PathPredicate opens_alone{};
  /// Required: the reader.
  FormatReader open{};
  /// Optional: the files the reader reads besides the path itself (a detached header's data
  /// files, a JSON sidecar), so that no output overwrites them (files_read). Unset: none.
  ReadPaths files_read{};
  /// Optional: the writer; a format without one is read-only.
  FormatWriter create_writer{};
  /// Optional, with a writer: everything it creates or replaces for `path` (the output, its
  /// data file or sidecar, each one's temporary, folders it replaces whole), for files_written.
  /// Unset: `path` and `<path>.tmp`.
  WrittenPaths files_written{};
  FormatCapabilities capabilities{};
  /// The sample types the reader returns and the writer stores (empty without a writer).
  DTypeSet read_dtypes = DTypeSet::all();
  DTypeSet write_dtypes{};
  /// Markdown for `strata formats --markdown` (the README table): what reading and writing
  /// support beyond the columns generated from the fields above. May be empty.
  std::string read_notes{}, write_notes{};

  /// @brief Whether create_volume_writer can write `t` samples in this format.
  bool writes(DType t) const { return create_writer && write_dtypes.contains(t); }
  /// @brief The integer types the format can write: label volumes it can hold.
  DTypeSet label_dtypes() const { return create_writer ? write_dtypes.integers() : DTypeSet{}; }
};

/// @brief Adds a format after the built-ins. Throws Error when the entry is incomplete (no
/// name, no reader, no extension and no folder form, an extension without its leading dot or
/// not lower case, a sniffer without magic_bytes, a writer without write_dtypes) or when its
/// name or one of its extensions is registered already.
void register_format(VolumeFormat format);
/// @brief Every format, built-ins first, in registration order.
std::vector<const VolumeFormat*> formats();
/// @brief The format of this name; nullptr when there is none.
const VolumeFormat* find_format(std::string_view name);
/// @brief The format whose extension `path`'s file name ends with (case-insensitive, the
/// longest match); nullptr when none does. Looks at the name only.
const VolumeFormat* format_by_extension(const std::filesystem::path& path);
/// @brief `path`'s file name without the extension of its format (the longest registered one,
/// or `.strata`): "ch2" for "ch2.nii.gz", "cells" for "cells.strata"; the whole name when none
/// matches.
std::string name_without_extension(const std::filesystem::path& path);
/// @brief The format of the volume to read at `path`: by the extension of its name (for an
/// existing folder, among the formats that take folders); else, for a folder, the format that
/// takes it (VolumeFormat::sniff_directory); else, for an existing file, the first format whose
/// sniffer recognises its first bytes. An http(s) URL goes to the formats that read from web
/// servers (VolumeFormat::sniff_url), by extension, then by asking the server. Throws Error naming the path and listing the registered
/// extensions (known_extensions_text) when none fits, and saying what the file is when it is a
/// .strata container.
const VolumeFormat& detect_format(const std::filesystem::path& path);
/// @brief Whether a format that reads from web servers takes the http(s) URL `url` (by the
/// extension of its name, else by VolumeFormat::sniff_url, which may ask the server).
bool is_remote_volume(const std::string& url);
/// @brief The format to write `path` in: the format called `name` when it is not empty (else
/// ParameterError("WriteOptions::format") listing the names), otherwise by the extension or
/// the folder as detect_format, never by content (an existing output is replaced, whatever it
/// holds). Throws Error naming the path and listing the registered extensions when none fits.
const VolumeFormat& output_format(const std::filesystem::path& path, std::string_view name = {});

/// @brief ".raw, .bin, .nrrd, ... or a directory of TIFF slices": every registered extension
/// and folder form, for messages and help texts.
std::string known_extensions_text();
/// @brief "raw, NRRD, NIfTI-1, NIfTI-2 and TIFF" (`conjunction` "and" or "or"): every
/// format's title.
std::string format_titles_text(std::string_view conjunction = "and");

}  // namespace strata::io
