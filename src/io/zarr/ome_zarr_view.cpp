// OmeZarrView (include/strata/io/ome_zarr.hpp): the writer's documents and chunk encoding,
// answered per request instead of written to a folder.
#include <fmt/format.h>

#include "io/zarr/ome_zarr_writer.hpp"
#include "strata/core/error.hpp"
#include "strata/io/ome_zarr.hpp"

namespace strata::io {

OmeZarrView::OmeZarrView(std::vector<VolumeInfo> levels, const std::string& name, bool compress)
    : levels_(std::move(levels)), compress_(compress), group_({{"zarr_format", 2}}) {
  if (levels_.empty()) throw ParameterError("levels", "an OME-Zarr image needs at least one level");
  for (const VolumeInfo& level : levels_) {
    if (level.dtype != levels_.front().dtype)
      throw ParameterError("levels", "every level must be of the same sample type");
    arrays_.push_back(detail::ome_zarr_array_metadata(level, compress_));
  }
  attributes_ = detail::multiscales_attributes(name, levels_);
}

std::optional<Box> OmeZarrView::chunk_box(std::size_t level, const Extent& index) const {
  if (level >= levels_.size()) return std::nullopt;
  const Extent& dims = levels_[level].dims;
  const Extent chunk = detail::ome_zarr_chunk_shape(levels_[level]);
  const auto inside = [](std::int64_t i, std::int64_t size, std::int64_t edge) { return i >= 0 && i < (size + edge - 1) / edge; };
  if (!inside(index.x, dims.x, chunk.x) || !inside(index.y, dims.y, chunk.y) || !inside(index.z, dims.z, chunk.z))
    return std::nullopt;
  const Extent lo{index.x * chunk.x, index.y * chunk.y, index.z * chunk.z};
  return Box{lo, {std::min(lo.x + chunk.x, dims.x), std::min(lo.y + chunk.y, dims.y), std::min(lo.z + chunk.z, dims.z)}};
}

std::vector<std::byte> OmeZarrView::encode(std::size_t level, const Volume& samples) const {
  if (level >= levels_.size() || samples.dtype() != levels_[level].dtype)
    throw Error(fmt::format("OME-Zarr level {}: {} samples do not belong to it", level, dtype_name(samples.dtype())));
  return detail::ome_zarr_stored_chunk(samples, detail::ome_zarr_chunk_shape(levels_[level]), compress_);
}

}  // namespace strata::io
