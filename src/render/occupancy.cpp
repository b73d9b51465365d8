#include "render/occupancy.hpp"

#include <algorithm>
#include <limits>
#include <cmath>

#include "render/frame_index.hpp"
#include "render/ray_sampling.hpp"
#include "strata/render/raycaster.hpp"

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
      // NaN voxels are empty space: `v < mn ? v : mn` passes them by. A cell of NaN only keeps
      // the empty range (+inf, -inf).
      float mn = std::numeric_limits<float>::infinity(), mx = -mn;
      for (int x = first; x <= last; ++x) {
        mn = v[x] < mn ? v[x] : mn;
        mx = v[x] > mx ? v[x] : mx;
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

int skip_dilation(const RenderOptions& o) {
  if (!o.skip_cells) return 0;
  const int d = int(std::ceil(o.step - 1e-9));
  return d <= 2 ? std::max(d, 1) : 0;  // longer steps: cells too coarse to be worth it
}

std::shared_ptr<const CellFlags> cell_flags(const Block& b, int dilation, const Transparency& tr, float value_lo,
                                            float value_scale) {
  const CellRanges r = compute_cell_ranges(b.data, b.n, dilation);
  auto f = std::make_shared<CellFlags>();
  f->cells = r.cells;
  f->empty.resize(r.lo.size() + 3);  // padded for 32-bit gathers (march8)
  for (std::size_t c = 0; c < r.lo.size(); ++c) {
    // Normalised exactly as samples are, widened by a few float roundings of the trilinear
    // interpolation so a sample can never leave the range the flag was decided on.
    const float nlo = (r.lo[c] - value_lo) * value_scale, nhi = (r.hi[c] - value_lo) * value_scale;
    const float margin = 1e-5f + 4e-6f * std::max(std::abs(r.lo[c]), std::abs(r.hi[c])) * value_scale;
    const bool e = !(r.lo[c] <= r.hi[c]) ||
                   tr.next_visible[std::size_t(Transparency::bin(nlo - margin))] > Transparency::bin(nhi + margin);
    f->empty[c] = e ? 1 : 0;
    f->empty_count += e ? 1 : 0;
  }
  return f;
}

void attach_flags(Block& b, const std::shared_ptr<const CellFlags>& f, RenderStats& stats) {
  if (!f) return;
  stats.cells_total += std::uint64_t(f->cells[0]) * std::uint64_t(f->cells[1]) * std::uint64_t(f->cells[2]);
  stats.cells_empty += f->empty_count;
  b.cells = f->cells;
  b.empty = f->empty_count > 0 ? f->empty.data() : nullptr;
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
