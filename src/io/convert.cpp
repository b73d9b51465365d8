// convert_volume: `strata convert` as a library function.
#include "strata/io/convert.hpp"

#include "strata/io/slab_stream.hpp"

namespace strata::io {

VolumeInfo convert_volume(const std::filesystem::path& input, const std::filesystem::path& output,
                          const ReadOptions& read, const WriteOptions& write, ProgressSink& progress) {
  ReadOptions options = read;
  if (!options.progress) options.progress = &progress;
  auto source = open_volume(input, options);
  // The writer checks the output format against the sample type before anything is written.
  auto writer = create_volume_writer(output, source->info(), write);
  copy_volume(*source, *writer, progress);
  return source->info();
}

}  // namespace strata::io
