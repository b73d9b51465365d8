#pragma once
// What the precomputed writer stores for a pyramid of levels, computed in one place for the
// writer (files in a folder) and the served view (PrecomputedView, the same bytes over HTTP).
#include <filesystem>
#include <string>
#include <vector>

#include "io/precomputed/info.hpp"
#include "strata/core/volume.hpp"
#include "strata/io/precomputed.hpp"

namespace strata::io::detail::precomputed {

inline constexpr std::int64_t kWrittenChunkEdge = 64;
inline constexpr std::int64_t kWrittenBlockEdge = 8;

// Scale `level` of a written pyramid: resolution in nm (from the geometry's unit; none = nm), the
// origin as voxel_offset, 64^3 chunks, compressed_segmentation for u32/u64, jpeg for u8 when
// `encoding` asks and raw otherwise, and the key `<rx>_<ry>_<rz>` (prefixed `s<level>_` after
// the first scale).
Scale written_scale(const VolumeInfo& level_info, std::size_t level, const PrecomputedEncoding& encoding);
// The description of a written pyramid of `levels` (finest first); Error naming `name` when
// there is no level, the levels' dtypes differ or the format has no such data_type,
// ParameterError when the jpeg quality is outside 0..100.
VolumeDescription written_description(const std::vector<VolumeInfo>& levels, const std::string& name,
                                      const PrecomputedEncoding& encoding);
// The unsharded chunk file name `<x0>-<x1>_<y0>-<y1>_<z0>-<z1>` (voxel space: offset included,
// clipped to the scale) of the chunk at grid `position`.
std::string chunk_name(const Scale& scale, const Extent& position);
// The chunk grid's size along each axis.
Extent chunk_grid(const Scale& scale);

}  // namespace strata::io::detail::precomputed
