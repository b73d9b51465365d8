#include "strata/ta/level_source.hpp"

#include <string>

#include "strata/core/error.hpp"

namespace strata::ta {

LevelSource::LevelSource(const TaVolume& volume, int level, int rank, DType dtype, std::filesystem::path name)
    : volume_(volume), level_(level), rank_(rank), name_(std::move(name)) {
  volume.check_level(level);
  if (rank < 1 || rank > volume.rank())
    throw ParameterError("rank", name_.string() + ": rank " + std::to_string(rank) + " is not in 1.." +
                                     std::to_string(volume.rank()));
  const Extent dims = volume.geometry().level(level).dims;
  const double scale = double(std::int64_t(1) << level);
  const Spacing& s = volume.source_info().spacing;
  info_.dims = dims;
  info_.dtype = dtype;
  info_.spacing = {s.x * scale, s.y * scale, s.z * scale};
  info_.geometry = volume.level_geometry(level, Box::whole(dims));
}

Volume LevelSource::read_box(const Box& box) {
  Volume decoded = volume_.decode_box(level_, box, rank_);
  return decoded.dtype() == info_.dtype ? decoded : decoded.converted(info_.dtype);
}

}  // namespace strata::ta
