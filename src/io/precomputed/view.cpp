// PrecomputedView (include/strata/io/precomputed.hpp): the writer's description of a pyramid,
// answered per request. A chunk name is accepted only when it is exactly the name the writer
// would give the chunk (parsed, then formatted again and compared), so misaligned, clipped
// differently, signed or padded spellings all miss.
#include <charconv>

#include <fmt/format.h>

#include "io/precomputed/chunk_codec.hpp"
#include "io/precomputed/pyramid.hpp"
#include "strata/core/error.hpp"
#include "strata/io/precomputed.hpp"

namespace strata::io {

using namespace detail::precomputed;

struct PrecomputedView::Scales {
  VolumeDescription description;
};

namespace {

// The six numbers of `<x0>-<x1>_<y0>-<y1>_<z0>-<z1>`, or nothing.
std::optional<std::array<std::int64_t, 6>> parse_chunk_numbers(std::string_view name) {
  std::array<std::int64_t, 6> v{};
  const char* p = name.data();
  const char* end = name.data() + name.size();
  for (std::size_t i = 0; i < v.size(); ++i) {
    const auto [next, ec] = std::from_chars(p, end, v[i]);
    if (ec != std::errc() || next == p) return std::nullopt;
    p = next;
    if (i + 1 == v.size()) break;
    if (p == end || *p != (i % 2 == 0 ? '-' : '_')) return std::nullopt;
    ++p;
  }
  if (p != end) return std::nullopt;
  return v;
}

}  // namespace

PrecomputedView::PrecomputedView(std::vector<VolumeInfo> levels, const std::string& name,
                                 const PrecomputedEncoding& encoding)
    : scales_(std::make_unique<const Scales>(Scales{written_description(levels, name, encoding)})),
      info_(info_json(scales_->description)) {}

PrecomputedView::~PrecomputedView() = default;

std::optional<PrecomputedView::Chunk> PrecomputedView::chunk(std::string_view key, std::string_view name) const {
  const auto& scales = scales_->description.scales;
  for (std::size_t level = 0; level < scales.size(); ++level) {
    const Scale& s = scales[level];
    if (s.key != key) continue;
    const auto n = parse_chunk_numbers(name);
    if (!n) return std::nullopt;
    const Extent lo{(*n)[0] - s.voxel_offset.x, (*n)[2] - s.voxel_offset.y, (*n)[4] - s.voxel_offset.z};
    if (lo.x < 0 || lo.y < 0 || lo.z < 0) return std::nullopt;
    const Extent position{lo.x / s.chunk.x, lo.y / s.chunk.y, lo.z / s.chunk.z};
    const Extent grid = chunk_grid(s);
    if (position.x >= grid.x || position.y >= grid.y || position.z >= grid.z) return std::nullopt;
    if (chunk_name(s, position) != name) return std::nullopt;
    const Extent hi{std::min(lo.x + s.chunk.x, s.size.x), std::min(lo.y + s.chunk.y, s.size.y),
                    std::min(lo.z + s.chunk.z, s.size.z)};
    return Chunk{level, Box{lo, hi}};
  }
  return std::nullopt;
}

std::vector<std::byte> PrecomputedView::encode(const Chunk& chunk, const Volume& samples) const {
  const auto& d = scales_->description;
  if (chunk.level >= d.scales.size() || samples.dims() != chunk.box.size() || samples.dtype() != d.dtype)
    throw Error(fmt::format("precomputed chunk of scale {}: got {} {} samples for box {}", chunk.level,
                            samples.dims().to_string(), dtype_name(samples.dtype()), chunk.box.to_string()));
  return encode_chunk(samples.bytes(), samples.dims(), d.scales[chunk.level], d.dtype);
}

}  // namespace strata::io
