#pragma once
// Private geometry of the object-based generators (prisms, fibres): vectors, tube segments
// (capsules) with a per-slice rasterizer, smooth bent curves, and a z-binned index so a slice
// only visits the objects near it.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "gen/noise.hpp"
#include "strata/core/extent.hpp"

namespace strata::gen::detail {

struct Vec3 {
  double x = 0, y = 0, z = 0;
};
inline Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3 operator*(double s, Vec3 a) { return {s * a.x, s * a.y, s * a.z}; }
inline double dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3 cross(Vec3 a, Vec3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
inline double norm(Vec3 a) { return std::sqrt(dot(a, a)); }
inline Vec3 normalized(Vec3 a) { return (1.0 / norm(a)) * a; }

Vec3 random_unit_vector(Random& rng);
// Two unit vectors completing `dir` (unit) to a right-handed orthonormal frame.
void orthonormal_frame(Vec3 dir, Vec3& e1, Vec3& e2);

// A straight piece of a tube. Floats keep tens of thousands of fibres compact; every voxel is
// evaluated by the same float code whatever the slab, so precision never breaks determinism.
struct Segment {
  float ax = 0, ay = 0, az = 0;  // start
  float dx = 0, dy = 0, dz = 0;  // end - start
  float inv_len2 = 0;            // 1 / |d|^2, 0 for a point
  float reach = 0;               // voxels whose centre is within this distance are visited
  std::uint32_t owner = 0;       // the tube this segment belongs to

  float z_lo() const { return std::min(az, az + dz) - reach; }
  float z_hi() const { return std::max(az, az + dz) + reach; }
};
Segment make_segment(Vec3 a, Vec3 b, float reach, std::uint32_t owner);

// Parameter interval [t0, t1] of a + t d (t in [0, 1]) with lo <= coordinate <= hi.
inline bool clip_to_interval(double a, double d, double lo, double hi, double& t0, double& t1) {
  if (std::abs(d) < 1e-12) return a >= lo && a <= hi;
  double ta = (lo - a) / d, tb = (hi - a) / d;
  if (ta > tb) std::swap(ta, tb);
  t0 = std::max(t0, ta);
  t1 = std::min(t1, tb);
  return t0 <= t1;
}

// Calls visit(x, y, dist2) for each voxel of slice z with rows in [y0, y1) and x in [0, nx)
// whose centre lies within s.reach of the segment. Each row is first cut to the exact interval
// where the infinite line is within reach (a quadratic in x), so an oblique segment costs about
// its cross-section rather than its bounding box.
template <class Visit>
void rasterize_segment(const Segment& s, std::int64_t z, std::int64_t y0, std::int64_t y1, std::int64_t nx,
                       Visit&& visit) {
  const double r = s.reach, r2 = r * r, pz = double(z);
  double t0 = 0, t1 = 1;
  if (!clip_to_interval(s.az, s.dz, pz - r, pz + r, t0, t1)) return;
  const double xa = s.ax + t0 * s.dx, xb = s.ax + t1 * s.dx;
  const double ya = s.ay + t0 * s.dy, yb = s.ay + t1 * s.dy;
  const std::int64_t ylo = std::max(y0, std::int64_t(std::ceil(std::min(ya, yb) - r)));
  const std::int64_t yhi = std::min(y1 - 1, std::int64_t(std::floor(std::max(ya, yb) + r)));
  const std::int64_t xmin = std::max<std::int64_t>(0, std::int64_t(std::ceil(std::min(xa, xb) - r)));
  const std::int64_t xmax = std::min(nx - 1, std::int64_t(std::floor(std::max(xa, xb) + r)));
  if (ylo > yhi || xmin > xmax) return;
  const double len2 = double(s.dx) * s.dx + double(s.dy) * s.dy + double(s.dz) * s.dz;
  // A point segment has no direction; any axis gives a line whose tube contains the ball.
  const double inv_len = len2 > 0 ? 1.0 / std::sqrt(len2) : 0.0;
  const double ux = len2 > 0 ? s.dx * inv_len : 0.0, uy = s.dy * inv_len, uz = len2 > 0 ? s.dz * inv_len : 1.0;
  const float wz = float(pz - s.az);
  const double qa = 1.0 - ux * ux;
  for (std::int64_t y = ylo; y <= yhi; ++y) {
    const float wy = float(double(y) - s.ay);
    const double k = uy * wy + uz * wz;
    const double qc = double(wy) * wy + double(wz) * wz - k * k - r2;
    std::int64_t lo = xmin, hi = xmax;
    if (qa > 1e-9) {
      const double qb = -2.0 * ux * k, disc = qb * qb - 4.0 * qa * qc;
      if (disc < 0) continue;
      const double sq = std::sqrt(disc), inv = 0.5 / qa;
      // A little slack: the exact distance test below decides, the interval only prunes.
      lo = std::max(lo, std::int64_t(std::ceil(s.ax + (-qb - sq) * inv - 1e-3)));
      hi = std::min(hi, std::int64_t(std::floor(s.ax + (-qb + sq) * inv + 1e-3)));
    } else if (qc > 1e-6) {
      continue;
    }
    const float wdy = wy * s.dy + wz * s.dz;
    for (std::int64_t x = lo; x <= hi; ++x) {
      const float wx = float(double(x) - s.ax);
      const float t = std::clamp((wx * s.dx + wdy) * s.inv_len2, 0.0f, 1.0f);
      const float ex = wx - t * s.dx, ey = wy - t * s.dy, ez = wz - t * s.dz;
      const float d2 = ex * ex + ey * ey + ez * ez;
      if (d2 <= float(r2)) visit(x, y, d2);
    }
  }
}

// Object indices binned by the 8-slice z-bins their extent [z_lo, z_hi] touches, so a slice
// looks only at objects in its bin instead of all of them.
class ZBinIndex {
 public:
  ZBinIndex() = default;
  // z_ranges[i] = {z_lo, z_hi} of object i; depth = number of slices of the volume.
  ZBinIndex(const std::vector<std::pair<double, double>>& z_ranges, std::int64_t depth);
  // Calls f(i) for objects whose bin covers slice z, in increasing i; callers re-check z.
  template <class F>
  void for_each_near(std::int64_t z, F&& f) const {
    const std::size_t bin = std::size_t(z >> kBinShift);
    if (bin + 1 >= offsets_.size()) return;
    for (std::size_t k = offsets_[bin]; k < offsets_[bin + 1]; ++k) f(ids_[k]);
  }

 private:
  static constexpr int kBinShift = 3;
  std::vector<std::size_t> offsets_;  // CSR: bin b holds ids_[offsets_[b], offsets_[b+1])
  std::vector<std::uint32_t> ids_;
};

// Segments with their z index; for_each_touching visits those within reach of a slice.
class SegmentSet {
 public:
  SegmentSet() = default;
  // Keeps only segments that can touch a voxel of a volume of these dimensions.
  SegmentSet(std::vector<Segment> segments, const Extent& dims);
  template <class F>
  void for_each_touching(std::int64_t z, F&& f) const {
    const float fz = float(z);
    index_.for_each_near(z, [&](std::uint32_t i) {
      const Segment& s = segments_[i];
      if (fz >= s.z_lo() && fz <= s.z_hi()) f(s);
    });
  }
  std::size_t size() const { return segments_.size(); }

 private:
  std::vector<Segment> segments_;
  ZBinIndex index_;
};

// A smooth curve: a straight axis bent by one sinusoid along each perpendicular direction,
// p(t) = centre + t dir + a1 sin(w1 t + f1) e1 + a2 sin(w2 t + f2) e2, t in [-half, half].
struct BentLine {
  Vec3 centre, dir, e1, e2;
  double half_length = 0;
  double amp1 = 0, freq1 = 0, phase1 = 0, amp2 = 0, freq2 = 0, phase2 = 0;

  Vec3 at(double t) const {
    return centre + t * dir + (amp1 * std::sin(freq1 * t + phase1)) * e1 + (amp2 * std::sin(freq2 * t + phase2)) * e2;
  }
  // Bend amplitudes up to `bend` * length with wavelengths of about the length: gently curved,
  // so chords a few voxels long follow the curve to a fraction of a voxel.
  static BentLine random(Random& rng, Vec3 centre, Vec3 dir, double length, double bend);
};

// Appends the curve shifted by `offset` as segments of at most `step` voxels.
void append_segments(const BentLine& line, Vec3 offset, double step, float reach, std::uint32_t owner,
                     std::vector<Segment>& out);

}  // namespace strata::gen::detail
