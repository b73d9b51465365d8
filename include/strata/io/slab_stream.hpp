#pragma once
#include <cstdint>
#include <functional>

#include "strata/core/progress.hpp"
#include "strata/io/volume_io.hpp"

namespace strata::io {

// Default slab budget: large enough for efficient I/O, small enough that a terabyte volume
// streams on a laptop.
inline constexpr std::uint64_t kDefaultSlabBytes = 64ull << 20;

// Number of z-slices per slab so one slab stays within `max_bytes` (at least one slice).
std::int64_t slices_per_slab(const VolumeInfo& info, std::uint64_t max_bytes = kDefaultSlabBytes);

// Visits the volume in z order, one slab at a time; `visit(slab, z0)` sees slices
// [z0, z0 + slab.dims().z). Progress counts voxels under the task name `task`.
void for_each_slab(VolumeSource& source, const std::function<void(const Volume& slab, std::int64_t z0)>& visit,
                   ProgressSink& progress, std::string_view task = "read",
                   std::uint64_t max_bytes = kDefaultSlabBytes);

/// @brief Slices [begin, end) of a volume.
struct SliceSpan {
  std::int64_t begin = 0, end = 0;
  std::int64_t size() const { return end > begin ? end - begin : 0; }
};

/// @brief Visits slices `span` of `source` in z order, `step` slices per slab (the last may be
/// shorter; step >= 1); `visit(slab, z0)` sees slices [z0, z0 + slab.dims().z). Progress counts
/// voxels under the task name `task`. The one slab loop every streamed pass goes through.
void for_each_slab(VolumeSource& source, SliceSpan span, std::int64_t step,
                   const std::function<void(const Volume& slab, std::int64_t z0)>& visit, ProgressSink& progress,
                   std::string_view task);

// Streams `source` into `writer` slab by slab (conversion between formats).
void copy_volume(VolumeSource& source, VolumeWriter& writer, ProgressSink& progress,
                 std::uint64_t max_bytes = kDefaultSlabBytes);

}  // namespace strata::io
