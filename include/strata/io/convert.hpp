#pragma once
/// @file
/// @brief Conversion of a volume file into another format, streamed slab by slab: what
/// `strata convert` runs, as a library function.
#include <filesystem>

#include "strata/core/progress.hpp"
#include "strata/core/volume.hpp"
#include "strata/io/volume_io.hpp"

namespace strata::io {

/// @brief Copies the volume at `input` (open_volume with `read`; its format from the path or
/// content) into `output` (create_volume_writer with `write`; its format from the extension or
/// WriteOptions::format), slab by slab, so volumes larger than memory convert. Progress goes to
/// `progress`, and decoding a compressed input to read.progress or else `progress` too.
/// Returns what was written. Throws Error naming both paths, before anything is read or written,
/// when writing `output` would overwrite a file the input reads (overwrite_conflict in
/// touched_paths.hpp). Throws Error naming the file when the input cannot be read, the
/// output format cannot store the input's sample type, or writing fails; no partial output is
/// left behind.
VolumeInfo convert_volume(const std::filesystem::path& input, const std::filesystem::path& output,
                          const ReadOptions& read, const WriteOptions& write, ProgressSink& progress);

}  // namespace strata::io
