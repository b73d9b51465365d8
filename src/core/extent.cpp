#include "strata/core/extent.hpp"

#include <charconv>
#include <vector>

#include "strata/core/error.hpp"

namespace strata {

std::string Extent::to_string() const {
  return std::to_string(x) + "x" + std::to_string(y) + "x" + std::to_string(z);
}

void Extent::throw_voxel_count_overflow() const {
  throw Error("dims " + to_string() + ": the voxel count overflows 64 bits");
}

std::string Box::to_string() const {
  return std::to_string(lo.x) + "," + std::to_string(lo.y) + "," + std::to_string(lo.z) + ":" +
         std::to_string(hi.x) + "," + std::to_string(hi.y) + "," + std::to_string(hi.z);
}

namespace {

// Splits "a,b,c" (or "axbxc" when allow_x) into integers; throws naming `what` on failure.
std::vector<std::int64_t> parse_integers(const std::string& text, bool allow_x, const std::string& what) {
  std::vector<std::int64_t> values;
  const char* p = text.data();
  const char* end = p + text.size();
  while (p < end) {
    std::int64_t v = 0;
    auto [next, ec] = std::from_chars(p, end, v);
    if (ec != std::errc() || next == p) throw Error(what + ": expected integers, got '" + text + "'");
    values.push_back(v);
    p = next;
    if (p < end) {
      if (*p == ',' || (allow_x && (*p == 'x' || *p == 'X'))) ++p;
      else throw Error(what + ": unexpected character '" + std::string(1, *p) + "' in '" + text + "'");
      if (p == end) throw Error(what + ": trailing separator in '" + text + "'");
    }
  }
  return values;
}

}  // namespace

Extent parse_extent(const std::string& text) {
  auto v = parse_integers(text, true, "size");
  if (v.size() == 1) v = {v[0], v[0], v[0]};
  if (v.size() != 3) throw Error("size: expected X or X,Y,Z, got '" + text + "'");
  for (auto c : v)
    if (c <= 0) throw Error("size: every dimension must be positive, got '" + text + "'");
  return {v[0], v[1], v[2]};
}

Box parse_box(const std::string& text) {
  auto colon = text.find(':');
  if (colon == std::string::npos) throw Error("box: expected x0,y0,z0:x1,y1,z1, got '" + text + "'");
  auto lo = parse_integers(text.substr(0, colon), false, "box");
  auto hi = parse_integers(text.substr(colon + 1), false, "box");
  if (lo.size() != 3 || hi.size() != 3) throw Error("box: expected x0,y0,z0:x1,y1,z1, got '" + text + "'");
  Box b{{lo[0], lo[1], lo[2]}, {hi[0], hi[1], hi[2]}};
  if (b.empty() || lo[0] < 0 || lo[1] < 0 || lo[2] < 0)
    throw Error("box: need 0 <= x0 < x1, y0 < y1, z0 < z1, got '" + text + "'");
  return b;
}

}  // namespace strata
