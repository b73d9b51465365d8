// "fibres": N curved tubes as labels 1..N on a background of 0 (about 85% of the voxels).
// Tube segments are binned by z, so tens of thousands of fibres cost about their own volume.
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include "gen/geometry.hpp"
#include "gen/noise.hpp"
#include "gen/slice_generator.hpp"

namespace strata::gen::detail {

namespace {

constexpr double kForegroundFraction = 0.15;
// Preferred tube radius: thinner tubes break up on the voxel grid, so when many fibres must
// share the foreground volume they get shorter rather than thinner.
constexpr double kPreferredRadius = 1.2;

struct FibreShape {
  double radius_scale = 1;  // the fibre's radius relative to the common radius
  double inside_length = 0;  // length of its axis inside the volume
  double inside_ends = 0;    // how many of its two end caps lie inside the volume
};

bool inside(Vec3 p, const Extent& d) {
  return p.x >= -0.5 && p.y >= -0.5 && p.z >= -0.5 && p.x <= double(d.x) - 0.5 && p.y <= double(d.y) - 0.5 &&
         p.z <= double(d.z) - 0.5;
}

// Length of the segment's part inside the volume box [-0.5, n - 0.5] per axis.
double inside_length(const Segment& s, const Extent& d) {
  double t0 = 0, t1 = 1;
  const bool hit = clip_to_interval(s.ax, s.dx, -0.5, double(d.x) - 0.5, t0, t1) &&
                   clip_to_interval(s.ay, s.dy, -0.5, double(d.y) - 0.5, t0, t1) &&
                   clip_to_interval(s.az, s.dz, -0.5, double(d.z) - 0.5, t0, t1);
  return hit ? (t1 - t0) * std::sqrt(double(s.dx) * s.dx + double(s.dy) * s.dy + double(s.dz) * s.dz) : 0.0;
}

// The common radius r for which the tubes fill `target` voxels: each fibre is a cylinder
// (pi r^2 L) plus two hemispherical caps, counting only what lies inside the volume. The total
// grows with r, so bisection finds it.
double radius_for_volume(const std::vector<FibreShape>& shapes, double target, double upper) {
  auto volume = [&](double r) {
    double v = 0;
    for (const FibreShape& f : shapes) {
      const double ri = r * f.radius_scale;
      v += std::numbers::pi * ri * ri * f.inside_length + (2.0 / 3.0) * std::numbers::pi * ri * ri * ri * f.inside_ends;
    }
    return v;
  };
  double lo = 0, hi = upper;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (volume(mid) < target ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

class FibresGenerator final : public SliceGenerator {
 public:
  explicit FibresGenerator(const Params& p);

 protected:
  void fill_rows(std::int64_t z, std::int64_t y0, std::int64_t y1, std::byte* rows) const override;

 private:
  std::vector<float> radius_;  // per fibre (id - 1)
  SegmentSet segments_;
};

FibresGenerator::FibresGenerator(const Params& p) : SliceGenerator(VolumeInfo{p.dims, DType::u32, {}}) {
  const Extent& d = p.dims;
  const double g = mean_extent(d), n = double(p.count);
  // Random placement covers 1 - exp(-tube volume / V) of the volume; invert that for the target.
  const double target = -std::log(1.0 - kForegroundFraction) * double(d.voxel_count());
  const double length = std::clamp(target / (std::numbers::pi * n * kPreferredRadius * kPreferredRadius), 6.0,
                                   std::max(6.0, 0.6 * g));
  Random rng(derive_seed(p.seed, 21));
  std::vector<Segment> segments;
  std::vector<FibreShape> shapes(std::size_t(p.count));
  for (std::size_t i = 0; i < shapes.size(); ++i) {
    const Vec3 centre{rng.uniform(0, double(d.x)), rng.uniform(0, double(d.y)), rng.uniform(0, double(d.z))};
    const double fibre_length = length * rng.uniform(0.6, 1.4);
    const BentLine line = BentLine::random(rng, centre, random_unit_vector(rng), fibre_length, 0.06);
    shapes[i].radius_scale = rng.uniform(0.7, 1.3);
    const std::size_t first = segments.size();
    append_segments(line, {}, std::clamp(fibre_length / 12.0, 2.0, 8.0), 0.0f, std::uint32_t(i), segments);
    for (std::size_t k = first; k < segments.size(); ++k) shapes[i].inside_length += inside_length(segments[k], d);
    shapes[i].inside_ends = double(inside(line.at(-line.half_length), d)) + double(inside(line.at(line.half_length), d));
  }
  const double radius = radius_for_volume(shapes, target, g);
  for (const FibreShape& f : shapes) radius_.push_back(float(radius * f.radius_scale));
  for (Segment& s : segments) s.reach = radius_[s.owner];
  segments_ = SegmentSet(std::move(segments), d);
}

// Where tubes overlap, the voxel goes to the tube whose axis is closer relative to its radius;
// exact ties go to the higher id. Both are properties of the voxel alone, so the result does not
// depend on the order segments are visited in.
void FibresGenerator::fill_rows(std::int64_t z, std::int64_t y0, std::int64_t y1, std::byte* rows) const {
  const std::int64_t nx = info().dims.x;
  auto* out = reinterpret_cast<std::uint32_t*>(rows);
  const std::size_t n = std::size_t((y1 - y0) * nx);
  std::fill(out, out + n, 0u);
  std::vector<float> best(n, std::numeric_limits<float>::infinity());
  segments_.for_each_touching(z, [&](const Segment& s) {
    const float inv_r2 = 1.0f / (s.reach * s.reach);
    const std::uint32_t id = s.owner + 1;
    rasterize_segment(s, z, y0, y1, nx, [&](std::int64_t x, std::int64_t y, float d2) {
      const std::size_t i = std::size_t((y - y0) * nx + x);
      const float relative = d2 * inv_r2;
      if (relative < best[i] || (relative == best[i] && id > out[i])) {
        best[i] = relative;
        out[i] = id;
      }
    });
  });
}

}  // namespace

std::unique_ptr<Generator> make_fibres(const Params& params) { return std::make_unique<FibresGenerator>(params); }

// The constructor's objects: per fibre its shape and radius, and its pieces (a fibre at most
// 1.4 times the common length, cut every clamp(length / 12, 2, 8) voxels) with vector growth
// and z-bins.
double fibres_setup_bytes(const Params& p) {
  const Extent& d = p.dims;
  const double g = mean_extent(d), n = double(p.count);
  const double target = -std::log(1.0 - kForegroundFraction) * double(d.x) * double(d.y) * double(d.z);
  const double length =
      1.4 * std::clamp(target / (std::numbers::pi * n * kPreferredRadius * kPreferredRadius), 6.0, std::max(6.0, 0.6 * g));
  const double pieces = std::ceil(length / std::clamp(length / 12.0, 2.0, 8.0));
  return n * (sizeof(FibreShape) + sizeof(float) + pieces * (1.5 * sizeof(Segment) + 8)) + zbin_index_bytes(d.z);
}

}  // namespace strata::gen::detail
