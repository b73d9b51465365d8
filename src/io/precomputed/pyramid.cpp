#include "io/precomputed/pyramid.hpp"

#include <cmath>

#include <fmt/format.h>

#include "strata/core/error.hpp"

namespace strata::io::detail::precomputed {

namespace {

// Nanometres per unit of the geometry's length unit; spacing without a known unit is taken as nm.
double nanometres_per_unit(const std::string& unit) {
  const double metres = metres_per_unit(canonical_length_unit(unit));
  return metres > 0 ? metres * 1e9 : 1;
}

std::int64_t chunks_along(std::int64_t size, std::int64_t chunk) { return (size + chunk - 1) / chunk; }

}  // namespace

Scale written_scale(const VolumeInfo& info, std::size_t level, const PrecomputedEncoding& encoding) {
  Scale s;
  const double nm = nanometres_per_unit(info.geometry.unit);
  s.resolution = {info.spacing.x * nm, info.spacing.y * nm, info.spacing.z * nm};
  const Vector3& origin = info.geometry.origin;
  s.voxel_offset = {std::llround(origin[0] * nm / s.resolution[0]), std::llround(origin[1] * nm / s.resolution[1]),
                    std::llround(origin[2] * nm / s.resolution[2])};
  s.size = info.dims;
  s.chunk = {kWrittenChunkEdge, kWrittenChunkEdge, kWrittenChunkEdge};
  const bool labels = info.dtype == DType::u32 || info.dtype == DType::u64;
  s.encoding = labels                                                 ? ChunkEncoding::compressed_segmentation
               : info.dtype == DType::u8 && encoding.jpeg_quality > 0 ? ChunkEncoding::jpeg
                                                                      : ChunkEncoding::raw;
  s.jpeg_quality = encoding.jpeg_quality;
  s.block = {kWrittenBlockEdge, kWrittenBlockEdge, kWrittenBlockEdge};
  s.key = fmt::format("{}_{}_{}", s.resolution[0], s.resolution[1], s.resolution[2]);
  if (level > 0) s.key = fmt::format("s{}_{}", level, s.key);  // distinct even when resolutions repeat
  return s;
}

VolumeDescription written_description(const std::vector<VolumeInfo>& levels, const std::string& name,
                                      const PrecomputedEncoding& encoding) {
  if (encoding.jpeg_quality < 0 || encoding.jpeg_quality > 100)
    throw ParameterError("PrecomputedEncoding::jpeg_quality",
                         fmt::format("expected 0 (raw) or a JPEG quality 1..100, got {}", encoding.jpeg_quality));
  if (levels.empty()) throw Error(fmt::format("{}: a precomputed volume needs at least one scale", name));
  const DType dtype = levels[0].dtype;
  if (!data_type_name(dtype))
    throw Error(fmt::format("{}: Neuroglancer precomputed stores u8, i8, u16, i16, u32, i32, u64 or f32 samples, not {}",
                            name, dtype_name(dtype)));
  VolumeDescription d{.dtype = dtype, .segmentation = dtype == DType::u32 || dtype == DType::u64, .channels = 1, .scales = {}};
  for (std::size_t i = 0; i < levels.size(); ++i) {
    if (levels[i].dtype != dtype)
      throw Error(fmt::format("{}: scale {} is {}, scale 0 {}", name, i, dtype_name(levels[i].dtype), dtype_name(dtype)));
    d.scales.push_back(written_scale(levels[i], i, encoding));
  }
  return d;
}

std::string chunk_name(const Scale& scale, const Extent& position) {
  const Extent& o = scale.voxel_offset;
  const Extent lo{o.x + position.x * scale.chunk.x, o.y + position.y * scale.chunk.y, o.z + position.z * scale.chunk.z};
  const Extent hi{std::min(lo.x + scale.chunk.x, o.x + scale.size.x), std::min(lo.y + scale.chunk.y, o.y + scale.size.y),
                  std::min(lo.z + scale.chunk.z, o.z + scale.size.z)};
  return fmt::format("{}-{}_{}-{}_{}-{}", lo.x, hi.x, lo.y, hi.y, lo.z, hi.z);
}

Extent chunk_grid(const Scale& scale) {
  return {chunks_along(scale.size.x, scale.chunk.x), chunks_along(scale.size.y, scale.chunk.y),
          chunks_along(scale.size.z, scale.chunk.z)};
}

}  // namespace strata::io::detail::precomputed
