// convert_volume: `strata convert` as a library function.
#include "strata/io/convert.hpp"

#include "strata/core/error.hpp"
#include "strata/io/slab_stream.hpp"
#include "strata/io/touched_paths.hpp"

namespace strata::io {

VolumeInfo convert_volume(const std::filesystem::path& input, const std::filesystem::path& output,
                          const ReadOptions& read, const WriteOptions& write, ProgressSink& progress) {
  // Before anything is opened: no output file may be one the input reads (its data file, its
  // sidecar, the folder it lies in), by any path.
  if (const auto why = overwrite_conflict(files_written(output, write), files_read(input))) throw Error(*why);
  ReadOptions options = read;
  if (!options.progress) options.progress = &progress;
  auto source = open_volume(input, options);
  // The writer checks the output format against the sample type before anything is written.
  auto writer = create_volume_writer(output, source->info(), write);
  copy_volume(*source, *writer, progress);
  return source->info();
}

}  // namespace strata::io
