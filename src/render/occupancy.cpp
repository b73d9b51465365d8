#include "render/occupancy.hpp"

#include <algorithm>

namespace strata::render::detail {

namespace {

int cell_count(int n) { return std::max(1, (n - 1 + kCell - 1) / kCell); }

// Voxel window [first, last] of cell c along an axis of n samples.
std::pair<int, int> window(int c, int n, int dilation) {
  return {std::max(0, kCell * c - dilation), std::min(n - 1, kCell * (c + 1) + dilation)};
}

}  // namespace

CellRanges compute_cell_ranges(const float* data, const std::array<int, 3>& n, int dilation) {
  CellRanges r;
  const int nx = n[0], ny = n[1], nz = n[2];
  const int cx = cell_count(nx), cy = cell_count(ny), cz = cell_count(nz);
  r.cells = {cx, cy, cz};
  // Separable: rows along x (contiguous) into (cx, ny, nz), then windows of rows along y into
  // (cx, cy, nz), then along z; the inner loops run over contiguous cell rows.
  std::vector<float> lo1(std::size_t(cx) * ny * nz), hi1(lo1.size());
  for (std::int64_t row = 0; row < std::int64_t(ny) * nz; ++row) {
    const float* v = data + row * nx;
    float* ol = lo1.data() + row * cx;
    float* oh = hi1.data() + row * cx;
    for (int c = 0; c < cx; ++c) {
      const auto [first, last] = window(c, nx, dilation);
      float mn = v[first], mx = v[first];
      for (int x = first + 1; x <= last; ++x) {
        mn = std::min(mn, v[x]);
        mx = std::max(mx, v[x]);
      }
      ol[c] = mn;
      oh[c] = mx;
    }
  }
  std::vector<float> lo2(std::size_t(cx) * cy * nz), hi2(lo2.size());
  for (int z = 0; z < nz; ++z)
    for (int c = 0; c < cy; ++c) {
      const auto [first, last] = window(c, ny, dilation);
      float* ol = lo2.data() + (std::size_t(z) * cy + c) * cx;
      float* oh = hi2.data() + (std::size_t(z) * cy + c) * cx;
      const float* il = lo1.data() + (std::size_t(z) * ny + first) * cx;
      const float* ih = hi1.data() + (std::size_t(z) * ny + first) * cx;
      std::copy(il, il + cx, ol);
      std::copy(ih, ih + cx, oh);
      for (int y = first + 1; y <= last; ++y) {
        il += cx;
        ih += cx;
        for (int i = 0; i < cx; ++i) {
          ol[i] = std::min(ol[i], il[i]);
          oh[i] = std::max(oh[i], ih[i]);
        }
      }
    }
  const std::size_t plane = std::size_t(cx) * cy;
  r.lo.resize(plane * cz);
  r.hi.resize(plane * cz);
  for (int c = 0; c < cz; ++c) {
    const auto [first, last] = window(c, nz, dilation);
    float* ol = r.lo.data() + std::size_t(c) * plane;
    float* oh = r.hi.data() + std::size_t(c) * plane;
    std::copy(lo2.data() + std::size_t(first) * plane, lo2.data() + std::size_t(first + 1) * plane, ol);
    std::copy(hi2.data() + std::size_t(first) * plane, hi2.data() + std::size_t(first + 1) * plane, oh);
    for (int z = first + 1; z <= last; ++z) {
      const float* il = lo2.data() + std::size_t(z) * plane;
      const float* ih = hi2.data() + std::size_t(z) * plane;
      for (std::size_t i = 0; i < plane; ++i) {
        ol[i] = std::min(ol[i], il[i]);
        oh[i] = std::max(oh[i], ih[i]);
      }
    }
  }
  return r;
}

std::shared_ptr<const CellFlags> CellFlagCache::find(const std::shared_ptr<const std::vector<float>>& samples) const {
  const auto it = entries_.find(samples.get());
  if (it == entries_.end() || it->second.brick.expired()) return nullptr;
  // Two live objects never share an address, so a live entry under this address is this brick's.
  return it->second.flags;
}

void CellFlagCache::insert(const std::shared_ptr<const std::vector<float>>& samples,
                           std::shared_ptr<const CellFlags> flags) {
  entries_[samples.get()] = Entry{samples, std::move(flags)};
}

void CellFlagCache::sweep() {
  for (auto it = entries_.begin(); it != entries_.end();)
    it = it->second.brick.expired() ? entries_.erase(it) : std::next(it);
}

}  // namespace strata::render::detail
