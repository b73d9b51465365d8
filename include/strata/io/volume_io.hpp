#pragma once
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>

#include "strata/core/progress.hpp"
#include "strata/core/volume.hpp"

namespace strata::io {

enum class FileFormat { raw, nrrd, nifti, tiff };

// By extension: .raw/.bin -> raw, .nrrd/.nhdr -> nrrd, .nii/.nii.gz -> nifti,
// .tif/.tiff or a directory -> tiff. Throws Error naming the path when unknown.
FileFormat detect_format(const std::filesystem::path& path);
const char* format_name(FileFormat f);

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
  // Where compressed inputs (gzip) are decoded for random access; default: the system temp dir.
  std::optional<std::filesystem::path> temp_dir;
  ProgressSink* progress = nullptr;  // for decoding compressed inputs
};

struct WriteOptions {
  bool compress = true;  // gzip for NRRD (encoding gzip); .nii.gz follows the file name
  std::optional<FileFormat> format;  // override detection by extension
};

// Random access to a volume on disk without loading it whole. Raw and raw-encoded NRRD are
// memory-mapped; gzip inputs are decoded once to a temporary raw file (deleted on close);
// TIFF stacks read the pages a request touches.
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

std::unique_ptr<VolumeSource> open_volume(const std::filesystem::path& path, const ReadOptions& options = {});
/// @brief A volume in memory served as a source (boxes are copied out), so code written for
/// streamed files takes it too; `volume` must outlive the source. `name` is shown in errors.
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

std::unique_ptr<VolumeWriter> create_volume_writer(const std::filesystem::path& path, const VolumeInfo& info,
                                                   const WriteOptions& options = {});
void write_volume(const std::filesystem::path& path, const Volume& volume, const WriteOptions& options = {});

// Which dtypes a format can store (NIfTI-1: no i8 writing is supported by all readers, etc.).
bool format_supports(FileFormat f, DType t);

}  // namespace strata::io
