// "prisms": an enamel-like multiscale scalar volume (u16). From coarse to fine: a smooth
// background, large anisotropic Gaussian blobs, bundles of thin parallel tubes along bent curves
// (alternately tilted, like decussating enamel prisms), and per-voxel noise.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "gen/geometry.hpp"
#include "gen/noise.hpp"
#include "gen/slice_generator.hpp"

namespace strata::gen::detail {

namespace {

// Blobs are cut off at a Mahalanobis distance of 3 (q = 9) and shifted so they reach 0 there.
constexpr double kBlobCutoff = 9.0;

// An anisotropic Gaussian: amp * exp(-q / 2), q = (p - c)^T M (p - c).
struct Blob {
  Vec3 centre;
  double mxx = 0, mxy = 0, mxz = 0, myy = 0, myz = 0, mzz = 0;  // M, the inverse covariance
  Vec3 half;  // half extents of the bounding box of q <= kBlobCutoff
  float amp = 0;
};

Blob random_blob(Random& rng, const Extent& dims) {
  const double g = mean_extent(dims);
  Blob b;
  b.centre = {rng.uniform(0, double(dims.x)), rng.uniform(0, double(dims.y)), rng.uniform(0, double(dims.z))};
  const Vec3 axis = random_unit_vector(rng);
  Vec3 e1, e2;
  orthonormal_frame(axis, e1, e2);
  const Vec3 axes[3] = {axis, e1, e2};
  double cov[3][3] = {};
  for (const Vec3& a : axes) {
    const double sigma = g * rng.uniform(0.03, 0.11);
    const double inv = 1.0 / (sigma * sigma);
    const double v[3] = {a.x, a.y, a.z};
    b.mxx += inv * v[0] * v[0], b.mxy += inv * v[0] * v[1], b.mxz += inv * v[0] * v[2];
    b.myy += inv * v[1] * v[1], b.myz += inv * v[1] * v[2], b.mzz += inv * v[2] * v[2];
    for (int i = 0; i < 3; ++i) cov[i][i] += sigma * sigma * v[i] * v[i];
  }
  // The ellipsoid q <= Q extends sqrt(Q * Cov_ii) from the centre along axis i.
  b.half = {std::sqrt(kBlobCutoff * cov[0][0]), std::sqrt(kBlobCutoff * cov[1][1]), std::sqrt(kBlobCutoff * cov[2][2])};
  b.amp = float(rng.uniform(0.3, 0.8));
  return b;
}

// Adds the blob to rows [y0, y1) of slice z; each row visits only the x-interval inside the
// ellipsoid (q is a quadratic in x), so cost follows the blob's volume, not its bounding box.
void add_blob(const Blob& b, std::int64_t z, std::int64_t y0, std::int64_t y1, std::int64_t nx, float* acc) {
  const double zz = double(z) - b.centre.z;
  if (std::abs(zz) > b.half.z) return;
  const std::int64_t ylo = std::max(y0, std::int64_t(std::ceil(b.centre.y - b.half.y)));
  const std::int64_t yhi = std::min(y1 - 1, std::int64_t(std::floor(b.centre.y + b.half.y)));
  const float floor_value = std::exp(-0.5f * float(kBlobCutoff)), scale = b.amp / (1.0f - floor_value);
  for (std::int64_t y = ylo; y <= yhi; ++y) {
    const double yy = double(y) - b.centre.y;
    const double qb = 2.0 * (b.mxy * yy + b.mxz * zz);
    const double qc = b.myy * yy * yy + 2.0 * b.myz * yy * zz + b.mzz * zz * zz;
    const double disc = qb * qb - 4.0 * b.mxx * (qc - kBlobCutoff);
    if (disc < 0) continue;
    const double sq = std::sqrt(disc), inv = 0.5 / b.mxx;
    const std::int64_t xlo = std::max<std::int64_t>(0, std::int64_t(std::ceil(b.centre.x + (-qb - sq) * inv)));
    const std::int64_t xhi = std::min(nx - 1, std::int64_t(std::floor(b.centre.x + (-qb + sq) * inv)));
    float* row = acc + (y - y0) * nx;
    for (std::int64_t x = xlo; x <= xhi; ++x) {
      const double xx = double(x) - b.centre.x;
      const float q = float((b.mxx * xx + qb) * xx + qc);
      if (q <= float(kBlobCutoff)) row[x] += scale * (std::exp(-0.5f * q) - floor_value);
    }
  }
}

// Identity up to 0.85, then bends smoothly (matching slope) towards 1: bright tubes crossing
// bright blobs keep their texture instead of clipping to a flat plateau.
float soft_limit(float v) {
  constexpr float knee = 0.85f, room = 1.0f - knee;
  if (v <= knee) return std::max(v, 0.0f);
  return knee + room * (1.0f - std::exp(-(v - knee) / room));
}

struct Tube {
  float radius = 0;  // full value inside radius - 0.5, a linear 1-voxel edge to radius + 0.5
  float amp = 0;
};

class PrismsGenerator final : public SliceGenerator {
 public:
  explicit PrismsGenerator(const Params& p);

 protected:
  void fill_rows(std::int64_t z, std::int64_t y0, std::int64_t y1, std::byte* rows) const override;

 private:
  void add_bundle(Random& rng, Vec3 main_dir, Vec3 side, int index, std::vector<Segment>& segments);
  void add_blobs(std::int64_t z, std::int64_t y0, std::int64_t y1, float* acc) const;
  void add_tubes(std::int64_t z, std::int64_t y0, std::int64_t y1, float* tubes) const;
  void combine(std::int64_t z, std::int64_t y0, std::int64_t y1, const float* blobs, const float* tubes,
               std::uint16_t* out) const;

  std::uint64_t seed_;
  std::vector<Blob> blobs_;
  ZBinIndex blob_index_;
  std::vector<Tube> tubes_;
  SegmentSet tube_segments_;
};

PrismsGenerator::PrismsGenerator(const Params& p)
    : SliceGenerator(VolumeInfo{p.dims, DType::u16, {}}), seed_(p.seed) {
  Random rng(derive_seed(p.seed, 1));
  std::vector<std::pair<double, double>> blob_z;
  for (std::int64_t i = 0; i < p.count; ++i) {
    blobs_.push_back(random_blob(rng, p.dims));
    blob_z.emplace_back(blobs_.back().centre.z - blobs_.back().half.z, blobs_.back().centre.z + blobs_.back().half.z);
  }
  blob_index_ = ZBinIndex(blob_z, p.dims.z);

  // Bundles run roughly along one main direction, alternately tilted to either side.
  const Vec3 main_dir = normalized({rng.uniform(-0.4, 0.4), rng.uniform(-0.4, 0.4), 1.0});
  Vec3 side, unused;
  orthonormal_frame(main_dir, side, unused);
  std::vector<Segment> segments;
  const int bundles = int(std::max<std::int64_t>(3, p.count / 4));
  for (int k = 0; k < bundles; ++k) add_bundle(rng, main_dir, side, k, segments);
  tube_segments_ = SegmentSet(std::move(segments), p.dims);
}

void PrismsGenerator::add_bundle(Random& rng, Vec3 main_dir, Vec3 side, int index, std::vector<Segment>& segments) {
  const Extent& d = info().dims;
  const double g = mean_extent(d);
  const double tilt = (index % 2 == 0 ? 0.3 : -0.3);
  const Vec3 dir = normalized(main_dir + tilt * side + 0.15 * random_unit_vector(rng));
  const Vec3 centre{rng.uniform(0, double(d.x)), rng.uniform(0, double(d.y)), rng.uniform(0, double(d.z))};
  // Long enough to cross the whole volume from any centre.
  const double length = 2.0 * norm({double(d.x), double(d.y), double(d.z)});
  const BentLine line = BentLine::random(rng, centre, dir, length, 0.03);
  const double radius = rng.uniform(1.0, 3.0), spacing = 2.0 * radius + 1.5;
  const double bundle_radius = std::max(g * rng.uniform(0.03, 0.07), 2.5 * spacing);
  const double amp = rng.uniform(0.25, 0.4);
  const double step = std::clamp(g / 64.0, 2.0, 8.0);
  // Tubes on a jittered hexagonal lattice over the bundle's disc, a few left out.
  // Rows j of the lattice are sheared by j / 2, so i needs twice the range to cover the disc.
  const int n = int(std::ceil(bundle_radius / spacing)) + 1;
  for (int i = -2 * n; i <= 2 * n; ++i) {
    for (int j = -n; j <= n; ++j) {
      const double u = (i + 0.5 * j) * spacing + rng.uniform(-0.1, 0.1) * spacing;
      const double v = 0.8660254037844386 * j * spacing + rng.uniform(-0.1, 0.1) * spacing;
      const bool dropped = rng.uniform() < 0.1;
      if (dropped || u * u + v * v > bundle_radius * bundle_radius) continue;
      const auto owner = std::uint32_t(tubes_.size());
      tubes_.push_back({float(radius * rng.uniform(0.9, 1.1)), float(amp * rng.uniform(0.85, 1.0))});
      append_segments(line, u * line.e1 + v * line.e2, step, tubes_.back().radius + 0.5f, owner, segments);
    }
  }
}

void PrismsGenerator::add_blobs(std::int64_t z, std::int64_t y0, std::int64_t y1, float* acc) const {
  blob_index_.for_each_near(z, [&](std::uint32_t i) { add_blob(blobs_[i], z, y0, y1, info().dims.x, acc); });
}

// Tubes combine by maximum, so overlapping segments of one tube (at joints) and crossing
// tubes never exceed the brightest tube.
void PrismsGenerator::add_tubes(std::int64_t z, std::int64_t y0, std::int64_t y1, float* tubes) const {
  const std::int64_t nx = info().dims.x;
  tube_segments_.for_each_touching(z, [&](const Segment& s) {
    const Tube& tube = tubes_[s.owner];
    rasterize_segment(s, z, y0, y1, nx, [&](std::int64_t x, std::int64_t y, float d2) {
      const float value = tube.amp * std::min(1.0f, tube.radius + 0.5f - std::sqrt(d2));
      float& cell = tubes[(y - y0) * nx + x];
      cell = std::max(cell, value);
    });
  });
}

void PrismsGenerator::combine(std::int64_t z, std::int64_t y0, std::int64_t y1, const float* blobs,
                              const float* tubes, std::uint16_t* out) const {
  const std::int64_t nx = info().dims.x;
  const double g = mean_extent(info().dims);
  // Three octaves of smooth background, from a quarter of the volume down to 1/16.
  const NoiseSlice coarse(derive_seed(seed_, 2), std::max(4.0, g / 4), double(z), nx, y0, y1);
  const NoiseSlice medium(derive_seed(seed_, 3), std::max(4.0, g / 8), double(z), nx, y0, y1);
  const NoiseSlice fine(derive_seed(seed_, 4), std::max(4.0, g / 16), double(z), nx, y0, y1);
  const std::uint64_t noise_seed = derive_seed(seed_, 5);
  for (std::int64_t y = y0; y < y1; ++y) {
    const std::uint64_t row_key = hash3(noise_seed, 0, y, z);
    for (std::int64_t x = 0; x < nx; ++x) {
      const std::size_t i = std::size_t((y - y0) * nx + x);
      const float background = 0.5f * coarse.at(double(x), double(y)) + 0.3f * medium.at(double(x), double(y)) +
                               0.2f * fine.at(double(x), double(y));
      const float noise = to_signed_unit(hash_combine(row_key, x));
      // Overlapping blobs saturate smoothly instead of adding up without bound.
      const float v = 0.12f + 0.06f * background + 0.6f * (1.0f - std::exp(-2.0f * blobs[i])) + tubes[i] +
                      0.012f * noise;
      out[i] = std::uint16_t(std::lround(soft_limit(v) * 65535.0f));
    }
  }
}

void PrismsGenerator::fill_rows(std::int64_t z, std::int64_t y0, std::int64_t y1, std::byte* rows) const {
  const std::size_t n = std::size_t((y1 - y0) * info().dims.x);
  std::vector<float> blobs(n, 0.0f), tubes(n, 0.0f);
  add_blobs(z, y0, y1, blobs.data());
  add_tubes(z, y0, y1, tubes.data());
  combine(z, y0, y1, blobs.data(), tubes.data(), reinterpret_cast<std::uint16_t*>(rows));
}

}  // namespace

std::unique_ptr<Generator> make_prisms(const Params& params) { return std::make_unique<PrismsGenerator>(params); }

// The constructor's objects at their expected sizes: the blobs with their z-bins, and
// max(3, count/4) bundles of tubes on a lattice of spacing 2r + 1.5 (r in [1, 3]: E[1/s^2] =
// 0.038, 90% kept) over a disc of rms radius 0.05 g (at least 2.5 spacings), each tube cut into
// pieces of `step` along twice the diagonal; per segment its bytes with vector growth and z-bins.
double prisms_setup_bytes(const Params& p) {
  const Extent& d = p.dims;
  const double g = mean_extent(d);
  const double diagonal = norm({double(d.x), double(d.y), double(d.z)});
  const double blobs = double(p.count) * (sizeof(Blob) + 16 + 4 * (0.66 * g / 8 + 2));
  const double bundles = std::max(3.0, double(p.count / 4));
  const double radius = std::max(0.05 * g, 2.5 * 5.5);
  const double tubes = 0.9 * std::numbers::pi * radius * radius / 0.866 * 0.038 + 2 * std::numbers::pi * radius / 3.5;
  const double pieces = 2 * diagonal / std::clamp(g / 64.0, 2.0, 8.0) + 1;
  const double segments = bundles * tubes * pieces * (1.5 * sizeof(Segment) + 8) + bundles * tubes * sizeof(Tube);
  return blobs + segments + 2 * zbin_index_bytes(d.z);
}

}  // namespace strata::gen::detail
