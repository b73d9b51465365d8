#pragma once
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include "strata/core/progress.hpp"
#include "strata/core/volume.hpp"

namespace strata::io {

// The formats themselves (names, extensions, detection, what each can do) are the entries of
// the registry in strata/io/formats.hpp; open_volume and create_volume_writer dispatch through it.

// Options for reading. Raw files need dims and dtype, from these fields or from a JSON
// sidecar `<file>.json` ({"dims":[x,y,z],"dtype":"u16","spacing":[sx,sy,sz]}); without
// either, opening throws ParameterError("ReadOptions::raw_dims" or "ReadOptions::raw_dtype").
struct ReadOptions {
  std::optional<Extent> raw_dims;
  std::optional<DType> raw_dtype;
  std::optional<Spacing> raw_spacing;
  bool raw_big_endian = false;
  std::uint64_t raw_header_bytes = 0;
  // Which 3D volume of a file that holds several (NIfTI dim[0] > 3: time points, components),
  // from 0. Required for such files; a file of one volume takes only 0.
  std::optional<std::int64_t> volume;
  // The array inside a container file: an HDF5 dataset ("/group/dataset"), the array of a Zarr
  // group. Also given in the path, `file.h5:/group/dataset` (open_volume splits it off). Formats
  // without FormatCapabilities::datasets refuse it.
  std::string dataset;
  // Which resolution level of a multiscale file (OME-Zarr `multiscales`, Neuroglancer precomputed
  // `scales`), from 0, the finest (the default). Formats without FormatCapabilities::multiscale
  // refuse any level but 0.
  std::optional<std::int64_t> level;
  // Where compressed inputs (gzip) are decoded for random access; default: the system temp dir
  // (TMPDIR). Reads in z order decode as they go and need no room there.
  std::optional<std::filesystem::path> temp_dir;
  ProgressSink* progress = nullptr;  // for decoding compressed inputs
};

struct WriteOptions {
  bool compress = true;  // gzip for NRRD (encoding gzip); .nii.gz follows the file name
  // A registered format's name (formats.hpp: "nrrd", "tiff", ...) that overrides detection by
  // the extension, e.g. for a new folder of TIFF slices; empty: from the path (output_format).
  std::string format;
  // The array to write inside a container file (an HDF5 dataset "/group/name"); also given in the
  // path, `file.h5:/group/name` (create_volume_writer splits it off). Formats without
  // FormatCapabilities::datasets refuse it; empty: the format's default.
  std::string dataset;
};

// Random access to a volume on disk without loading it whole. Raw and raw-encoded NRRD are
// memory-mapped; gzip inputs are decoded as reads in z order ask for them, and for other access
// once to an unnamed temporary file; TIFF stacks read the pages a request touches.
class VolumeSource {
 public:
  virtual ~VolumeSource() = default;
  virtual const VolumeInfo& info() const = 0;
  virtual const std::filesystem::path& path() const = 0;
  // Reads a box (must lie inside the volume) into a new Volume carrying the source spacing.
  virtual Volume read_box(const Box& box) = 0;
  // Convenience: slices [z0, z1).
  Volume read_slab(std::int64_t z0, std::int64_t z1);
  // Reads everything (only for volumes known to fit in memory).
  Volume read_all();
};

/// @brief Opens the volume at `path` with the reader of its format (detect_format): refuses an
/// empty file, a volume other than 0 of a format that holds one (FormatCapabilities::multi_volume),
/// a dataset or level the format has no notion of. A path `container:inner` whose `container`
/// exists and `path` does not (`scan.h5:/entry/data`) opens `inner` of `container`
/// (ReadOptions::dataset; giving both is an error unless they agree).
std::unique_ptr<VolumeSource> open_volume(const std::filesystem::path& path, const ReadOptions& options = {});
/// @brief A volume in memory served as a source (boxes are copied out), so code written for
/// streamed files takes it too; `volume` must outlive the source. `name` is shown in errors.
/// @brief `path` split into an existing container and the array inside it ("scan.h5:/a/b" ->
/// {"scan.h5", "/a/b"}); {path, ""} when `path` exists or has no such split.
std::pair<std::filesystem::path, std::string> split_container_path(const std::filesystem::path& path);
/// @brief An output path split into its container and the array inside it ("out.h5:/a/b" ->
/// {"out.h5", "/a/b"}): the last colon whose left part has the extension of a format with
/// FormatCapabilities::datasets (the container need not exist yet). {path, ""} when `path` itself
/// has a format's extension or there is no such split.
std::pair<std::filesystem::path, std::string> split_output_container(const std::filesystem::path& path);
std::unique_ptr<VolumeSource> memory_source(const Volume& volume, std::filesystem::path name = "<memory>");
Volume read_volume(const std::filesystem::path& path, const ReadOptions& options = {});

// Sequential writer: slabs are appended in z order; finish() flushes and renames
// `<path>.tmp` to `<path>`. Destroying an unfinished writer deletes the temporary, so a
// failed run never leaves a half-written output.
class VolumeWriter {
 public:
  virtual ~VolumeWriter() = default;
  virtual void write_slab(const Volume& slab) = 0;  // dims.x/y/dtype must match; z any
  virtual void finish() = 0;
};

/// @brief A writer of `info` in the format of output_format(path, options.format): throws Error
/// naming the path when the format has no writer or cannot store info.dtype, or dims are not positive.
/// A path `container:inner` whose `container` has the extension of a format with datasets
/// (`out.h5:/group/name`) writes `inner` of `container` (WriteOptions::dataset).
std::unique_ptr<VolumeWriter> create_volume_writer(const std::filesystem::path& path, const VolumeInfo& info,
                                                   const WriteOptions& options = {});
void write_volume(const std::filesystem::path& path, const Volume& volume, const WriteOptions& options = {});

}  // namespace strata::io
