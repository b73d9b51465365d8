#include "strata/io/slab_stream.hpp"

#include <algorithm>

namespace strata::io {

std::int64_t slices_per_slab(const VolumeInfo& info, std::uint64_t max_bytes) {
  const std::uint64_t slice = std::max<std::uint64_t>(1, info.bytes_per_slice());
  return std::max<std::int64_t>(1, std::int64_t(max_bytes / slice));
}

void for_each_slab(VolumeSource& source, const std::function<void(const Volume&, std::int64_t)>& visit,
                   ProgressSink& progress, std::string_view task, std::uint64_t max_bytes) {
  const VolumeInfo& info = source.info();
  const std::int64_t step = slices_per_slab(info, max_bytes);
  ProgressTask bar(progress, task, std::uint64_t(info.dims.voxel_count()), "vox");
  for (std::int64_t z0 = 0; z0 < info.dims.z; z0 += step) {
    const std::int64_t z1 = z0 + std::min(step, info.dims.z - z0);  // never past dims.z, never overflowing
    Volume slab = source.read_slab(z0, z1);
    visit(slab, z0);
    bar.advance(std::uint64_t(slab.voxel_count()));
  }
}

void copy_volume(VolumeSource& source, VolumeWriter& writer, ProgressSink& progress, std::uint64_t max_bytes) {
  for_each_slab(source, [&](const Volume& slab, std::int64_t) { writer.write_slab(slab); }, progress, "convert",
                max_bytes);
  writer.finish();
}

}  // namespace strata::io
