#include "strata/io/slab_stream.hpp"

#include <algorithm>

namespace strata::io {

std::int64_t slices_per_slab(const VolumeInfo& info, std::uint64_t max_bytes) {
  const std::uint64_t slice = std::max<std::uint64_t>(1, info.bytes_per_slice());
  return std::max<std::int64_t>(1, std::int64_t(max_bytes / slice));
}

void for_each_slab(VolumeSource& source, SliceSpan span, std::int64_t step,
                   const std::function<void(const Volume&, std::int64_t)>& visit, ProgressSink& progress,
                   std::string_view task) {
  const VolumeInfo& info = source.info();
  span = {std::clamp<std::int64_t>(span.begin, 0, info.dims.z), std::clamp<std::int64_t>(span.end, 0, info.dims.z)};
  step = std::max<std::int64_t>(1, step);
  ProgressTask bar(progress, task, std::uint64_t(span.size() * info.dims.x * info.dims.y), "vox");
  for (std::int64_t z0 = span.begin; z0 < span.end; z0 += step) {
    const std::int64_t z1 = z0 + std::min(step, span.end - z0);  // never past the span, never overflowing
    Volume slab = source.read_slab(z0, z1);
    visit(slab, z0);
    bar.advance(std::uint64_t(slab.voxel_count()));
  }
}

void for_each_slab(VolumeSource& source, const std::function<void(const Volume&, std::int64_t)>& visit,
                   ProgressSink& progress, std::string_view task, std::uint64_t max_bytes) {
  const VolumeInfo& info = source.info();
  for_each_slab(source, {0, info.dims.z}, slices_per_slab(info, max_bytes), visit, progress, task);
}

void copy_volume(VolumeSource& source, VolumeWriter& writer, ProgressSink& progress, std::uint64_t max_bytes) {
  for_each_slab(source, [&](const Volume& slab, std::int64_t) { writer.write_slab(slab); }, progress, "convert",
                max_bytes);
  writer.finish();
}

}  // namespace strata::io
