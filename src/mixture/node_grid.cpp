#include "strata/mixture/node_grid.hpp"

#include <algorithm>

#include "strata/core/error.hpp"

namespace strata::mixture {

namespace {
void check_box(const NodeGrid& g, int level, const Box& box, std::size_t out_size) {
  if (level < 0 || level >= g.level_count()) throw Error("node grid: level " + std::to_string(level) + " out of range");
  if (box.empty() || !Box::whole(g.level_dims(level)).contains(box))
    throw Error("node grid: box " + box.to_string() + " is not inside level " + std::to_string(level) + " (" +
                g.level_dims(level).to_string() + ")");
  if (out_size != std::size_t(box.voxel_count())) throw Error("node grid: output size does not match the box");
}
}  // namespace

void NodeGrid::decode_box(int level, const Box& box, std::span<std::uint32_t> out) const {
  check_box(*this, level, box, out.size());
  std::size_t i = 0;
  for (std::int64_t z = box.lo.z; z < box.hi.z; ++z)
    for (std::int64_t y = box.lo.y; y < box.hi.y; ++y)
      for (std::int64_t x = box.lo.x; x < box.hi.x; ++x) out[i++] = node_at(level, x, y, z);
}

void FactorizationGrid::decode_box(int level, const Box& box, std::span<std::uint32_t> out) const {
  check_box(*this, level, box, out.size());
  const MipLevel& l = f_.levels[std::size_t(level)];
  const Extent s = box.size();
  for (std::int64_t z = box.lo.z; z < box.hi.z; ++z)
    for (std::int64_t y = box.lo.y; y < box.hi.y; ++y) {
      const auto* src = l.ids.data() + l.index(box.lo.x, y, z);
      std::copy(src, src + s.x, out.data() + ((z - box.lo.z) * s.y + (y - box.lo.y)) * s.x);
    }
}

}  // namespace strata::mixture
