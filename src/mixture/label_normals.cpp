#include "strata/mixture/label_normals.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>

#include <fmt/format.h>

#include "strata/core/error.hpp"
#include "strata/core/stopwatch.hpp"
#include "strata/core/threads.hpp"
#include "strata/mixture/label_map.hpp"

namespace strata::mixture {

namespace {

using Normal = std::array<float, 3>;

constexpr int kOctahedralCells = 128;

float dot3(const Normal& a, const Normal& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

Normal normalized3(const Normal& v) {
  const float n = std::sqrt(dot3(v, v));
  return n > 0 ? Normal{v[0] / n, v[1] / n, v[2] / n} : Normal{0, 0, 0};
}

// Octahedral map of a unit vector to [-1, 1]²: the upper half sphere onto the inner diamond,
// the lower half folded onto the corners.
std::array<float, 2> octahedral(const Normal& n) {
  const float l1 = std::abs(n[0]) + std::abs(n[1]) + std::abs(n[2]);
  float u = n[0] / l1, v = n[1] / l1;
  if (n[2] < 0) {
    const float fu = (1 - std::abs(v)) * (u >= 0 ? 1.0f : -1.0f), fv = (1 - std::abs(u)) * (v >= 0 ? 1.0f : -1.0f);
    u = fu, v = fv;
  }
  return {u, v};
}

Normal from_octahedral(float u, float v) {
  Normal n{u, v, 1 - std::abs(u) - std::abs(v)};
  if (n[2] < 0) {
    n[0] = (1 - std::abs(v)) * (u >= 0 ? 1.0f : -1.0f);
    n[1] = (1 - std::abs(u)) * (v >= 0 ? 1.0f : -1.0f);
  }
  return normalized3(n);
}

int cell_of(float t) { return std::clamp(int((t + 1) * 0.5f * kOctahedralCells), 0, kOctahedralCells - 1); }

// The nearest code of every octahedral cell's centre, by exhaustive search (once).
const std::vector<std::uint16_t>& code_table() {
  static const std::vector<std::uint16_t> table = [] {
    const auto& book = normal_codebook();
    std::vector<std::uint16_t> t(std::size_t(kOctahedralCells * kOctahedralCells));
    for (int j = 0; j < kOctahedralCells; ++j)
      for (int i = 0; i < kOctahedralCells; ++i) {
        const Normal n = from_octahedral((i + 0.5f) / kOctahedralCells * 2 - 1, (j + 0.5f) / kOctahedralCells * 2 - 1);
        int best = 1;
        for (int c = 2; c < kNormalCodes; ++c)
          if (dot3(book[std::size_t(c)], n) > dot3(book[std::size_t(best)], n)) best = c;
        t[std::size_t(j * kOctahedralCells + i)] = std::uint16_t(best);
      }
    return t;
  }();
  return table;
}

// The window's offsets and weights: a Gaussian of σ = radius voxels, world-unit offsets.
struct WindowTap {
  int dx, dy, dz;
  Normal weighted;  // w · offset in world units
};

std::vector<WindowTap> window_taps(int radius, const Spacing& s) {
  std::vector<WindowTap> taps;
  const double sigma2 = double(radius) * double(radius);
  for (int dz = -radius; dz <= radius; ++dz)
    for (int dy = -radius; dy <= radius; ++dy)
      for (int dx = -radius; dx <= radius; ++dx) {
        if (dx == 0 && dy == 0 && dz == 0) continue;
        const double w = std::exp(-double(dx * dx + dy * dy + dz * dz) / (2 * sigma2));
        taps.push_back({dx, dy, dz, {float(w * dx * s.x), float(w * dy * s.y), float(w * dz * s.z)}});
      }
  return taps;
}

// Voxels with a 6-neighbour of another id, dilated by `radius` along each axis (a box).
std::vector<std::uint8_t> boundary_band(const std::vector<std::uint32_t>& ids, const Extent& d, int radius) {
  const std::int64_t sx = 1, sy = d.x, sz = d.x * d.y;
  std::vector<std::uint8_t> band(ids.size(), 0);
#pragma omp parallel for schedule(static) num_threads(thread_count())
  for (std::int64_t z = 0; z < d.z; ++z)
    for (std::int64_t y = 0; y < d.y; ++y)
      for (std::int64_t x = 0; x < d.x; ++x) {
        const std::int64_t i = z * sz + y * sy + x;
        const std::uint32_t id = ids[std::size_t(i)];
        band[std::size_t(i)] = (x > 0 && ids[std::size_t(i - sx)] != id) || (x + 1 < d.x && ids[std::size_t(i + sx)] != id) ||
                               (y > 0 && ids[std::size_t(i - sy)] != id) || (y + 1 < d.y && ids[std::size_t(i + sy)] != id) ||
                               (z > 0 && ids[std::size_t(i - sz)] != id) || (z + 1 < d.z && ids[std::size_t(i + sz)] != id);
      }
  // Separable dilation: a running maximum along each axis in turn.
  const std::array<std::int64_t, 3> extent{d.x, d.y, d.z}, stride{sx, sy, sz};
  for (int axis = 0; axis < 3; ++axis) {
    const std::int64_t n = extent[std::size_t(axis)], step = stride[std::size_t(axis)];
    const std::int64_t lines = std::int64_t(ids.size()) / n;
#pragma omp parallel for schedule(static) num_threads(thread_count())
    for (std::int64_t line = 0; line < lines; ++line) {
      // The line's first voxel: every index whose coordinate along `axis` is 0.
      const std::int64_t below = line % step, above = line / step;
      const std::int64_t start = above * step * n + below;
      std::vector<std::uint8_t> in(static_cast<std::size_t>(n));
      for (std::int64_t k = 0; k < n; ++k) in[std::size_t(k)] = band[std::size_t(start + k * step)];
      for (std::int64_t k = 0; k < n; ++k) {
        std::uint8_t any = 0;
        for (std::int64_t j = std::max<std::int64_t>(0, k - radius); j <= std::min(n - 1, k + radius) && !any; ++j)
          any = in[std::size_t(j)];
        band[std::size_t(start + k * step)] = any;
      }
    }
  }
  return band;
}

// The band's normals: the weighted first moment of the other-id voxels in the window. When the
// window holds background (`background`, the id of label 0, usually transparent), only the
// background counts: the visible surface of a segmentation is where it meets the background,
// and a neighbouring segment in the same window would tilt that normal inwards.
void band_normals(const std::vector<std::uint32_t>& ids, const std::vector<std::uint8_t>& band, const Extent& d,
                  const std::vector<WindowTap>& taps, std::optional<std::uint32_t> background,
                  std::vector<Normal>& normals) {
#pragma omp parallel for schedule(dynamic, 1) num_threads(thread_count())
  for (std::int64_t z = 0; z < d.z; ++z)
    for (std::int64_t y = 0; y < d.y; ++y)
      for (std::int64_t x = 0; x < d.x; ++x) {
        const std::size_t i = std::size_t((z * d.y + y) * d.x + x);
        if (!band[i]) continue;
        const std::uint32_t id = ids[i];
        Normal other{0, 0, 0}, empty{0, 0, 0};
        bool sees_background = false;
        for (const WindowTap& t : taps) {
          const std::int64_t px = x + t.dx, py = y + t.dy, pz = z + t.dz;
          if (px < 0 || py < 0 || pz < 0 || px >= d.x || py >= d.y || pz >= d.z) continue;  // outside: own label
          const std::uint32_t seen = ids[std::size_t((pz * d.y + py) * d.x + px)];
          if (seen == id) continue;
          other[0] += t.weighted[0], other[1] += t.weighted[1], other[2] += t.weighted[2];
          if (seen == background) {
            sees_background = true;
            empty[0] += t.weighted[0], empty[1] += t.weighted[1], empty[2] += t.weighted[2];
          }
        }
        normals[i] = normalized3(sees_background ? empty : other);
      }
}

// Gauss–Seidel sweeps (alternately forwards and backwards) carrying normals from the band into
// the rest of each segment through same-id 6-neighbours; the band stays fixed.
void diffuse_inwards(const std::vector<std::uint32_t>& ids, const std::vector<std::uint8_t>& band, const Extent& d,
                     int sweeps, std::vector<Normal>& normals) {
  const std::int64_t sy = d.x, sz = d.x * d.y, n = std::int64_t(ids.size());
  auto relax = [&](std::int64_t i) {
    if (band[std::size_t(i)]) return;
    const std::int64_t x = i % d.x, y = (i / d.x) % d.y, z = i / sz;
    const std::uint32_t id = ids[std::size_t(i)];
    Normal sum{0, 0, 0};
    auto add = [&](std::int64_t j) {
      if (ids[std::size_t(j)] != id) return;
      const Normal& v = normals[std::size_t(j)];
      sum[0] += v[0], sum[1] += v[1], sum[2] += v[2];
    };
    if (x > 0) add(i - 1);
    if (x + 1 < d.x) add(i + 1);
    if (y > 0) add(i - sy);
    if (y + 1 < d.y) add(i + sy);
    if (z > 0) add(i - sz);
    if (z + 1 < d.z) add(i + sz);
    normals[std::size_t(i)] = normalized3(sum);
  };
  for (int s = 0; s < sweeps; ++s) {
    if (s % 2 == 0) {
      for (std::int64_t i = 0; i < n; ++i) relax(i);
    } else {
      for (std::int64_t i = n; i-- > 0;) relax(i);
    }
  }
}

}  // namespace

void NormalOptions::validate() const {
  if (radius < 1 || radius > 4) throw ParameterError("NormalOptions::radius", fmt::format("must lie in 1..4, got {}", radius));
  if (band < 0 || band > radius)
    throw ParameterError("NormalOptions::band", fmt::format("must lie in 0..radius ({}), got {}", radius, band));
  if (diffusion < 0 || diffusion > 64)
    throw ParameterError("NormalOptions::diffusion", fmt::format("must lie in 0..64, got {}", diffusion));
}

const std::array<std::array<float, 3>, kNormalCodes>& normal_codebook() {
  static const std::array<std::array<float, 3>, kNormalCodes> book = [] {
    std::array<std::array<float, 3>, kNormalCodes> b{};
    const int count = kNormalCodes - 1;
    const double golden = std::numbers::pi * (3 - std::sqrt(5.0));
    for (int i = 0; i < count; ++i) {
      const double z = 1 - (2.0 * i + 1) / count, r = std::sqrt(std::max(0.0, 1 - z * z)), phi = golden * i;
      b[std::size_t(i + 1)] = {float(r * std::cos(phi)), float(r * std::sin(phi)), float(z)};
    }
    return b;
  }();
  return book;
}

std::uint16_t nearest_normal_code(const std::array<float, 3>& n) {
  if (n[0] == 0 && n[1] == 0 && n[2] == 0) return 0;
  // The nearest codes of the 3 × 3 cells around n's are the candidates: a code's region spans
  // several cells (about 9° against at most 3° per cell), so the exact nearest is among them.
  const auto [u, v] = octahedral(n);
  const int ci = cell_of(u), cj = cell_of(v);
  const auto& table = code_table();
  const auto& book = normal_codebook();
  std::uint16_t best = table[std::size_t(cj * kOctahedralCells + ci)];
  for (int j = std::max(0, cj - 1); j <= std::min(kOctahedralCells - 1, cj + 1); ++j)
    for (int i = std::max(0, ci - 1); i <= std::min(kOctahedralCells - 1, ci + 1); ++i) {
      const std::uint16_t c = table[std::size_t(j * kOctahedralCells + i)];
      if (dot3(book[c], n) > dot3(book[best], n)) best = c;
    }
  return best;
}

namespace {

std::vector<Normal> estimate(const std::vector<std::uint32_t>& ids, const Extent& d, const Spacing& spacing,
                             std::optional<std::uint32_t> background, const NormalOptions& options,
                             LabelNormals* counts) {
  // The public entry points validate `options` before any work.
  const std::vector<std::uint8_t> band = boundary_band(ids, d, options.band);
  std::vector<Normal> normals(ids.size(), Normal{0, 0, 0});
  band_normals(ids, band, d, window_taps(options.radius, spacing), background, normals);
  diffuse_inwards(ids, band, d, options.diffusion, normals);
  if (counts) {
    counts->band_voxels = counts->interior_voxels = 0;
    for (std::size_t i = 0; i < normals.size(); ++i) {
      const bool has = normals[i][0] != 0 || normals[i][1] != 0 || normals[i][2] != 0;
      (band[i] ? counts->band_voxels : counts->interior_voxels) += has;
    }
  }
  return normals;
}

}  // namespace

std::vector<std::array<float, 3>> estimate_label_normals(const Volume& labels, const NormalOptions& options,
                                                         LabelNormals* counts) {
  options.validate();
  const SourceIds source = to_source_ids(labels);
  return estimate(source.ids, labels.dims(), labels.spacing(), source.map.id_of(0), options, counts);
}

LabelNormals quantize_label_normals(const Volume& labels, const NormalOptions& options) {
  const auto start = SteadyClock::now();
  options.validate();
  LabelNormals result;
  const Extent d = labels.dims();
  const SourceIds source = to_source_ids(labels);
  const std::vector<Normal> normals = estimate(source.ids, d, labels.spacing(), source.map.id_of(0), options, &result);
  const auto& book = normal_codebook();
  result.codes = Volume(d, DType::u16, labels.spacing());
  auto codes = result.codes.samples<std::uint16_t>();
  // The residual of each coded voxel goes forward to same-id neighbours: this slice's (x+1,
  // y+1) and the next slice's (z+1), two rolling slices of carried error.
  const std::size_t slice = std::size_t(d.x * d.y);
  std::vector<Normal> carried(slice, Normal{0, 0, 0}), next(slice, Normal{0, 0, 0});
  for (std::int64_t z = 0; z < d.z; ++z) {
    for (std::int64_t y = 0; y < d.y; ++y)
      for (std::int64_t x = 0; x < d.x; ++x) {
        const std::size_t local = std::size_t(y * d.x + x), i = std::size_t(z) * slice + local;
        const Normal& n = normals[i];
        if (n[0] == 0 && n[1] == 0 && n[2] == 0) {
          codes[i] = 0;
          continue;
        }
        const Normal& e = carried[local];
        const Normal wanted = options.error_diffusion ? normalized3({n[0] + e[0], n[1] + e[1], n[2] + e[2]}) : n;
        const std::uint16_t code = nearest_normal_code(wanted);
        codes[i] = code;
        if (!options.error_diffusion) continue;
        const Normal& c = book[code];
        const Normal residual{wanted[0] - c[0], wanted[1] - c[1], wanted[2] - c[2]};
        auto pass = [&](std::vector<Normal>& to, std::size_t at, std::size_t neighbour, float w) {
          if (source.ids[neighbour] != source.ids[i]) return;
          to[at][0] += w * residual[0], to[at][1] += w * residual[1], to[at][2] += w * residual[2];
        };
        if (x + 1 < d.x) pass(carried, local + 1, i + 1, 0.5f);
        if (y + 1 < d.y) pass(carried, local + std::size_t(d.x), i + std::size_t(d.x), 0.25f);
        if (z + 1 < d.z) pass(next, local, i + slice, 0.25f);
      }
    std::swap(carried, next);
    std::fill(next.begin(), next.end(), Normal{0, 0, 0});
  }
  result.seconds = seconds_since(start);
  return result;
}

}  // namespace strata::mixture
