#pragma once
// Sampling and classification of the ray caster (march.cpp): trilinear values and gradients
// in a block's samples, table lookups of the transfer function, and the transparent-segment test.
// Everything here is inlined into the scalar march and read by the 8-lane march
// (march8_body.hpp), which repeats these operations on vectors.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "render/frame_index.hpp"
#include "strata/render/transfer_function.hpp"

namespace strata::render::detail {

// ---- Sampling -------------------------------------------------------------------------------

// Trilinear interpolation in a block's samples; positions are clamped to the sample grid so
// pre-samples and closing samples just outside a brick's overlap read edge values.
struct GridSampler {
  const float* data;
  std::ptrdiff_t dx, dy, dz;  // neighbour offsets (0 along an axis with one sample)
  float max_x, max_y, max_z;
  int nx, ny, nz;

  explicit GridSampler(const Block& b)
      : data(b.data),
        dx(b.n[0] > 1 ? 1 : 0),
        dy(b.n[1] > 1 ? std::ptrdiff_t(b.n[0]) : 0),
        dz(b.n[2] > 1 ? std::ptrdiff_t(b.n[0]) * b.n[1] : 0),
        max_x(limit(b.n[0])),
        max_y(limit(b.n[1])),
        max_z(limit(b.n[2])),
        nx(b.n[0]),
        ny(b.n[1]),
        nz(b.n[2]) {}

  // Largest coordinate whose +1 neighbour still exists.
  static float limit(int n) { return n > 1 ? float(n - 1) * (1.0f - 1e-6f) : 0.0f; }

  [[gnu::always_inline]] inline float operator()(float x, float y, float z) const {
    x = std::clamp(x, 0.0f, max_x);
    y = std::clamp(y, 0.0f, max_y);
    z = std::clamp(z, 0.0f, max_z);
    const int ix = int(x), iy = int(y), iz = int(z);
    const float fx = x - float(ix), fy = y - float(iy), fz = z - float(iz);
    const float* p = data + ix * dx + std::ptrdiff_t(iy) * dy + std::ptrdiff_t(iz) * dz;
    const float c00 = p[0] + fx * (p[dx] - p[0]);
    const float c10 = p[dy] + fx * (p[dy + dx] - p[dy]);
    const float c01 = p[dz] + fx * (p[dz + dx] - p[dz]);
    const float c11 = p[dz + dy] + fx * (p[dz + dy + dx] - p[dz + dy]);
    const float c0 = c00 + fy * (c10 - c00);
    const float c1 = c01 + fy * (c11 - c01);
    return c0 + fz * (c1 - c0);
  }

  // The gradient where the stencil below meets NaN or infinite voxels (empty space): along each
  // axis the central difference when both taps are finite, else twice the one-sided difference
  // toward the finite tap, else 0. The surface of a NaN region then shades like any other.
  void finite_gradient(float x, float y, float z, float g[3]) const {
    const float c = (*this)(x, y, z);
    auto axis = [c](float hi, float lo) {
      const bool h = std::isfinite(hi), l = std::isfinite(lo);
      return h && l ? hi - lo : h && std::isfinite(c) ? 2.0f * (hi - c) : l && std::isfinite(c) ? 2.0f * (c - lo) : 0.0f;
    };
    g[0] = axis((*this)(x + 1, y, z), (*this)(x - 1, y, z));
    g[1] = axis((*this)(x, y + 1, z), (*this)(x, y - 1, z));
    g[2] = axis((*this)(x, y, z + 1), (*this)(x, y, z - 1));
  }

  // Central differences one voxel either side, in local voxel units (times 2): f(p + e_a) -
  // f(p - e_a) of the trilinear interpolant f. Trilinear interpolation is linear in the samples
  // and the taps are whole voxels apart, so this equals the trilinear interpolation of the
  // per-voxel differences v[i + 1] - v[i - 1]: one 4x2x2 / 2x4x2 / 2x2x4 stencil of 32 voxels
  // around the sample instead of six separate trilinear taps (same value up to rounding).
  void gradient(float x, float y, float z, float g[3]) const {
    // Near the grid's faces each tap is clamped on its own (as six trilinear taps).
    if (!(x >= 1.0f && y >= 1.0f && z >= 1.0f && x < float(nx - 2) && y < float(ny - 2) && z < float(nz - 2))) {
      g[0] = (*this)(x + 1, y, z) - (*this)(x - 1, y, z);
      g[1] = (*this)(x, y + 1, z) - (*this)(x, y - 1, z);
      g[2] = (*this)(x, y, z + 1) - (*this)(x, y, z - 1);
      return;
    }
    const int ix = int(x), iy = int(y), iz = int(z);
    const float fx = x - float(ix), fy = y - float(iy), fz = z - float(iz);
    const float* p = data + ix + std::ptrdiff_t(iy) * dy + std::ptrdiff_t(iz) * dz;
    // Rows along x through (y, z): the interpolated value and x difference.
    auto row = [&](std::ptrdiff_t off, float& l, float& d) {
      const float* r = p + off;
      const float a = r[-1], b = r[0], c = r[1], e = r[2];
      l = b + fx * (c - b);
      d = (c - a) + fx * ((e - b) - (c - a));
    };
    auto lin = [&](std::ptrdiff_t off) {
      const float* r = p + off;
      return r[0] + fx * (r[1] - r[0]);
    };
    float l00, l10, l01, l11, d00, d10, d01, d11;  // l{y}{z}
    row(0, l00, d00);
    row(dy, l10, d10);
    row(dz, l01, d01);
    row(dy + dz, l11, d11);
    const float gx0 = d00 + fy * (d10 - d00), gx1 = d01 + fy * (d11 - d01);
    g[0] = gx0 + fz * (gx1 - gx0);
    auto diff = [](float f, float lo_m, float l0, float l1, float hi_p) {  // lerp of (l1 - lo_m) and (hi_p - l0)
      const float a = l1 - lo_m, b = hi_p - l0;
      return a + f * (b - a);
    };
    const float gy0 = diff(fy, lin(-dy), l00, l10, lin(2 * dy));
    const float gy1 = diff(fy, lin(dz - dy), l01, l11, lin(dz + 2 * dy));
    g[1] = gy0 + fz * (gy1 - gy0);
    const float gz0 = diff(fz, lin(-dz), l00, l01, lin(2 * dz));
    const float gz1 = diff(fz, lin(dy - dz), l10, l11, lin(dy + 2 * dz));
    g[2] = gz0 + fy * (gz1 - gz0);
  }
};

struct ConstantSampler {
  float value;
  explicit ConstantSampler(const Block& b) : value(b.constant) {}
  float operator()(float, float, float) const { return value; }
  void gradient(float, float, float, float g[3]) const { g[0] = g[1] = g[2] = 0; }
  void finite_gradient(float, float, float, float g[3]) const { g[0] = g[1] = g[2] = 0; }
};

// A sample normalised for classification: (value - lo) * scale, the frame's value mapping.
template <class Sampler>
[[gnu::always_inline]] inline float normalised_sample(const Sampler& sample, float x, float y, float z, float lo,
                                                      float scale) {
  return (sample(x, y, z) - lo) * scale;
}

// ---- Classification -------------------------------------------------------------------------

struct Classifier {
  const Rgbaf* table = nullptr;  // the post-classification lookup table (single)
  int size = 0;                  // entries per axis of the table in use
  float last = 0;  // size - 1
  // The pre-integrated table (size^2 entries) as bilinear cells (render/level_tables.cpp,
  // bilinear_cells): cell (i, j) holds entries (i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1),
  // 16 floats in a row, so the 8-lane march fetches a lane's four entries with two 8-float loads.
  const float* cells = nullptr;

  [[gnu::always_inline]] inline Rgbaf pair(float front, float back) const {  // bilinear in the pre-integrated table
    const float u = std::clamp(front, 0.0f, 1.0f) * last, v = std::clamp(back, 0.0f, 1.0f) * last;
    const int i = std::min(int(u), size - 2), j = std::min(int(v), size - 2);
    const float wu = u - float(i), wv = v - float(j);
    const float* c = cells + (std::ptrdiff_t(i) * (size - 1) + j) * 16;
    // Corner q of the cell is the RGBA at c + 4 q: lerp along j in rows i and i + 1, then along i.
    auto lerp = [](const float* a, const float* b, float w) {
      return Rgbaf{a[0] + w * (b[0] - a[0]), a[1] + w * (b[1] - a[1]), a[2] + w * (b[2] - a[2]), a[3] + w * (b[3] - a[3])};
    };
    const Rgbaf r0 = lerp(c, c + 8, wv), r1 = lerp(c + 4, c + 12, wv);
    return {r0.r + wu * (r1.r - r0.r), r0.g + wu * (r1.g - r0.g), r0.b + wu * (r1.b - r0.b), r0.a + wu * (r1.a - r0.a)};
  }

  [[gnu::always_inline]] inline Rgbaf single(float x) const {  // linear in the post-classification table
    const float u = std::clamp(x, 0.0f, 1.0f) * last;
    const int i = std::min(int(u), size - 2);
    const float w = u - float(i);
    const Rgbaf& a = table[i];
    const Rgbaf& b = table[i + 1];
    return {a.r + w * (b.r - a.r), a.g + w * (b.g - a.g), a.b + w * (b.b - a.b), a.a + w * (b.a - a.a)};
  }
};

// Rescales a premultiplied segment colour from its table length to `ratio` times that length.
inline Rgbaf rescale_segment(const Rgbaf& c, double ratio) {
  if (c.a <= 0.0f) return c;
  const float a = correct_opacity(std::min(c.a, 1.0f), ratio);
  const float k = a / c.a;
  return {c.r * k, c.g * k, c.b * k, a};
}

// Half of a one-step segment: opacity 1 - sqrt(1 - a) and the colour scaled alike (rescale_segment
// at ratio 1/2, by a square root instead of a power so the 8-lane march computes it identically).
inline Rgbaf half_segment(const Rgbaf& c) {
  const float a = 1.0f - std::sqrt(std::max(1.0f - c.a, 0.0f));
  const float k = c.a > 0.0f ? a / c.a : 0.0f;
  return {c.r * k, c.g * k, c.b * k, a};
}

// `front` composited over `back` (premultiplied colours).
inline Rgbaf over(const Rgbaf& front, const Rgbaf& back) {
  const float t = 1.0f - front.a;
  return {front.r + t * back.r, front.g + t * back.g, front.b + t * back.b, front.a + t * back.a};
}

// A pre-integrated segment `ratio` steps long whose values go from `front` through `mid` (the
// value at its midpoint) to `back`: two half segments, each linear. Between two samples the
// trilinear field is not linear: across a thin bright structure its peak lies above the chord
// through the two samples, so one linear segment misses opacity and darkens thin bone or
// vessels by an error of the order of the step squared; the midpoint cuts that error fourfold
// for one more trilinear sample and no more gradients.
inline Rgbaf split_pair(const Classifier& cl, float front, float mid, float back, double ratio) {
  const Rgbaf c1 = cl.pair(front, mid), c2 = cl.pair(mid, back);
  if (ratio == 1.0) return over(half_segment(c1), half_segment(c2));
  return over(rescale_segment(c1, 0.5 * ratio), rescale_segment(c2, 0.5 * ratio));
}

// Transparent-segment test without touching the classification tables: a segment whose value
// range lies in bins where the TF is zero contributes nothing (pre-integrated or not).
struct Transparency {
  static constexpr int kBins = 1024;
  std::vector<std::uint16_t> next_visible;  // first visible bin >= i (kBins = none)

  explicit Transparency(const TransferFunction& tf) : next_visible(kBins + 1, kBins) {
    for (int i = kBins - 1; i >= 0; --i)
      next_visible[std::size_t(i)] = tf.visible(double(i) / kBins, double(i + 1) / kBins)
                                         ? std::uint16_t(i)
                                         : next_visible[std::size_t(i) + 1];
  }
  // NaN falls into bin 0 (std::clamp would pass it on to an undefined conversion).
  static int bin(float x) { return std::min(int((x > 0.0f ? (x < 1.0f ? x : 1.0f) : 0.0f) * float(kBins)), kBins - 1); }
};

}  // namespace strata::render::detail
