// "voronoi": N label cells around seeded sites, in coordinates warped by a smooth displacement
// field so the walls are curved, separated by thin background (0) membranes. Ids 1..N.
#include <cmath>
#include <limits>
#include <vector>

#include "gen/geometry.hpp"
#include "gen/noise.hpp"
#include "gen/slice_generator.hpp"

namespace strata::gen::detail {

namespace {

// Half the membrane thickness in voxels: 1.5 voxels across is thick enough that no straight
// run of voxels can step over a wall (no 6-connected leaks between cells), and still thin.
constexpr double kMembraneHalfWidth = 0.75;

struct Box3 {
  Vec3 lo, hi;
};

double min_dist2(const Box3& b, Vec3 p) {
  const double dx = std::max({b.lo.x - p.x, 0.0, p.x - b.hi.x});
  const double dy = std::max({b.lo.y - p.y, 0.0, p.y - b.hi.y});
  const double dz = std::max({b.lo.z - p.z, 0.0, p.z - b.hi.z});
  return dx * dx + dy * dy + dz * dz;
}

double max_dist2(const Box3& b, Vec3 p) {
  const double dx = std::max(p.x - b.lo.x, b.hi.x - p.x);
  const double dy = std::max(p.y - b.lo.y, b.hi.y - p.y);
  const double dz = std::max(p.z - b.lo.z, b.hi.z - p.z);
  return dx * dx + dy * dy + dz * dz;
}

// Sites bucketed in a uniform grid of about one site per cell, for neighbourhood queries.
class SiteGrid {
 public:
  SiteGrid(const Extent& dims, double cell) : cell_(cell) {
    for (int a = 0; a < 3; ++a) size_[a] = std::max<std::int64_t>(1, std::int64_t(std::ceil(axis(dims, a) / cell)));
    buckets_.resize(std::size_t(size_[0] * size_[1] * size_[2]));
  }
  void add(Vec3 p, std::uint32_t id) { buckets_[bucket_of(p)].push_back(id); }
  // Calls f(id) for the sites of all grid cells overlapping the box.
  template <class F>
  void for_each_in(const Box3& box, F&& f) const {
    std::int64_t lo[3], hi[3];
    const double blo[3] = {box.lo.x, box.lo.y, box.lo.z}, bhi[3] = {box.hi.x, box.hi.y, box.hi.z};
    for (int a = 0; a < 3; ++a) {
      lo[a] = clamp_cell(blo[a], a);
      hi[a] = clamp_cell(bhi[a], a);
    }
    for (std::int64_t k = lo[2]; k <= hi[2]; ++k)
      for (std::int64_t j = lo[1]; j <= hi[1]; ++j)
        for (std::int64_t i = lo[0]; i <= hi[0]; ++i)
          for (std::uint32_t id : buckets_[std::size_t((k * size_[1] + j) * size_[0] + i)]) f(id);
  }
  double cell() const { return cell_; }

 private:
  static double axis(const Extent& d, int a) { return double(a == 0 ? d.x : a == 1 ? d.y : d.z); }
  // Clamped in floating point first: query boxes may be huge (an unbounded search).
  std::int64_t clamp_cell(double v, int a) const {
    return std::int64_t(std::clamp(std::floor(v / cell_), 0.0, double(size_[a] - 1)));
  }
  std::size_t bucket_of(Vec3 p) const {
    return std::size_t((clamp_cell(p.z, 2) * size_[1] + clamp_cell(p.y, 1)) * size_[0] + clamp_cell(p.x, 0));
  }
  double cell_;
  std::int64_t size_[3];
  std::vector<std::vector<std::uint32_t>> buckets_;
};

class VoronoiGenerator final : public SliceGenerator {
 public:
  explicit VoronoiGenerator(const Params& p);

 protected:
  void fill_rows(std::int64_t z, std::int64_t y0, std::int64_t y1, std::byte* rows) const override;

 private:
  void place_sites(std::int64_t count, std::uint64_t seed);
  void candidates(const Box3& box, std::vector<std::uint32_t>& out) const;
  // dist2 is scratch space, reused across voxels.
  std::uint32_t label_at(Vec3 p, const std::vector<std::uint32_t>& candidates, std::vector<double>& dist2) const;

  std::uint64_t seed_;
  double spacing_;    // typical distance between neighbouring sites
  double warp_amp_;   // maximal displacement per axis, voxels
  // Candidate sites are found once per tile x tile voxels of a slice. Tiles about half a cell
  // wide keep the candidate lists short for any cell size.
  std::int64_t tile_;
  std::vector<Vec3> sites_;
  SiteGrid grid_;
};

VoronoiGenerator::VoronoiGenerator(const Params& p)
    : SliceGenerator(VolumeInfo{p.dims, DType::u32, {}}),
      seed_(p.seed),
      spacing_(std::cbrt(double(p.dims.voxel_count()) / double(p.count))),
      // Small against the spacing: the warp's slope stays below 0.36 per axis, so the map never
      // folds and neighbouring voxels land less than 2 * kMembraneHalfWidth apart, which keeps
      // different cells from touching across a membrane.
      warp_amp_(0.12 * spacing_),
      tile_(std::clamp<std::int64_t>(std::int64_t(0.5 * spacing_), 2, 16)),
      grid_(p.dims, std::max(1.0, spacing_)) {
  place_sites(p.count, derive_seed(p.seed, 11));
}

// Random sites, kept at least half a spacing apart when possible (up to 30 tries each) so no
// cell is a sliver swallowed by its own membrane; away from the faces by the warp amplitude so
// every cell's site is reached by some voxel.
void VoronoiGenerator::place_sites(std::int64_t count, std::uint64_t seed) {
  Random rng(seed);
  const Extent& d = info().dims;
  const double min_sep2 = 0.25 * spacing_ * spacing_;
  auto coordinate = [&](std::int64_t n) {
    const double margin = std::min(warp_amp_, 0.25 * double(n - 1));
    return rng.uniform(margin, double(n - 1) - margin);
  };
  for (std::int64_t i = 0; i < count; ++i) {
    Vec3 p;
    for (int attempt = 0; attempt < 30; ++attempt) {
      p = {coordinate(d.x), coordinate(d.y), coordinate(d.z)};
      bool crowded = false;
      const Vec3 r{0.5 * spacing_, 0.5 * spacing_, 0.5 * spacing_};
      grid_.for_each_in({p - r, p + r}, [&](std::uint32_t j) {
        const Vec3 e = sites_[j] - p;
        crowded = crowded || dot(e, e) < min_sep2;
      });
      if (!crowded) break;
    }
    grid_.add(p, std::uint32_t(sites_.size()));
    sites_.push_back(p);
  }
}

// Sites that matter for some point p of `box`: the nearest site a (d_a(p) is at most the
// second smallest distance T of any site to the farthest corner of the box) and, for the
// membrane test, sites within 2 * kMembraneHalfWidth of d_a(p). So every site whose distance to
// the box is below T + 2 * kMembraneHalfWidth.
void VoronoiGenerator::candidates(const Box3& box, std::vector<std::uint32_t>& out) const {
  out.clear();
  double bound = std::numeric_limits<double>::infinity();
  if (sites_.size() >= 2) {
    for (double reach = grid_.cell();; reach *= 2) {
      const Vec3 r{reach, reach, reach};
      double first = bound, second = bound;
      std::size_t found = 0;
      grid_.for_each_in({box.lo - r, box.hi + r}, [&](std::uint32_t id) {
        const double d2 = max_dist2(box, sites_[id]);
        ++found;
        if (d2 < first) second = first, first = d2;
        else if (d2 < second) second = d2;
      });
      if (found >= 2) {
        bound = std::sqrt(second) + 2.0 * kMembraneHalfWidth;
        break;
      }
    }
  }
  const double reach = std::isinf(bound) ? 1e300 : bound;
  const Vec3 r{reach, reach, reach};
  grid_.for_each_in({box.lo - r, box.hi + r}, [&](std::uint32_t id) {
    if (min_dist2(box, sites_[id]) <= bound * bound) out.push_back(id);
  });
  // Index order makes ties (equal distances) resolve the same way in every tile.
  std::sort(out.begin(), out.end());
}

// The nearest site's id, or 0 within kMembraneHalfWidth of its cell's boundary. The cell is
// the intersection of half-spaces bounded by the bisector planes with the other sites, so the
// distance to its boundary is the smallest distance to one of those planes,
// (d_c^2 - d_a^2) / (2 |a - c|). That is at least (d_c - d_a) / 2, so only sites within
// 2 * kMembraneHalfWidth of the nearest distance need the exact test.
std::uint32_t VoronoiGenerator::label_at(Vec3 p, const std::vector<std::uint32_t>& candidates,
                                         std::vector<double>& dist2) const {
  dist2.resize(candidates.size());
  std::size_t nearest = 0;
  for (std::size_t k = 0; k < candidates.size(); ++k) {
    const Vec3 e = sites_[candidates[k]] - p;
    dist2[k] = dot(e, e);
    if (dist2[k] < dist2[nearest]) nearest = k;
  }
  const std::uint32_t a = candidates[nearest];
  const double reach = std::sqrt(dist2[nearest]) + 2.0 * kMembraneHalfWidth;
  for (std::size_t k = 0; k < candidates.size(); ++k) {
    if (k == nearest || dist2[k] >= reach * reach) continue;
    const double gap = norm(sites_[candidates[k]] - sites_[a]);
    if (dist2[k] - dist2[nearest] < 2.0 * kMembraneHalfWidth * gap) return 0;
  }
  return a + 1;
}

void VoronoiGenerator::fill_rows(std::int64_t z, std::int64_t y0, std::int64_t y1, std::byte* rows) const {
  const std::int64_t nx = info().dims.x;
  auto* out = reinterpret_cast<std::uint32_t*>(rows);
  const double cell = std::max(4.0, spacing_), a = warp_amp_;
  const NoiseSlice warp_x(derive_seed(seed_, 12), cell, double(z), nx, y0, y1);
  const NoiseSlice warp_y(derive_seed(seed_, 13), cell, double(z), nx, y0, y1);
  const NoiseSlice warp_z(derive_seed(seed_, 14), cell, double(z), nx, y0, y1);
  std::vector<std::uint32_t> near;
  std::vector<double> dist2;
  for (std::int64_t ty = y0; ty < y1; ty += tile_) {
    const std::int64_t ty1 = std::min(y1, ty + tile_);
    for (std::int64_t tx = 0; tx < nx; tx += tile_) {
      const std::int64_t tx1 = std::min(nx, tx + tile_);
      // Warped positions of the tile's voxels lie within the tile grown by the warp amplitude.
      candidates({{double(tx) - a, double(ty) - a, double(z) - a}, {double(tx1 - 1) + a, double(ty1 - 1) + a, double(z) + a}},
                 near);
      for (std::int64_t y = ty; y < ty1; ++y) {
        for (std::int64_t x = tx; x < tx1; ++x) {
          const double fx = double(x), fy = double(y);
          const Vec3 p{fx + a * warp_x.at(fx, fy), fy + a * warp_y.at(fx, fy), double(z) + a * warp_z.at(fx, fy)};
          out[(y - y0) * nx + x] = label_at(p, near, dist2);
        }
      }
    }
  }
}

}  // namespace

std::unique_ptr<Generator> make_voronoi(const Params& params) { return std::make_unique<VoronoiGenerator>(params); }

// The constructor's objects: per site its position, its id in a bucket and that bucket's heap
// block; per bucket of the site grid (cells one site spacing wide) an empty vector.
double voronoi_setup_bytes(const Params& p) {
  const Extent& d = p.dims;
  const double cell = std::max(1.0, std::cbrt(double(d.x) * double(d.y) * double(d.z) / double(p.count)));
  const double buckets = std::ceil(double(d.x) / cell) * std::ceil(double(d.y) / cell) * std::ceil(double(d.z) / cell);
  return double(p.count) * (sizeof(Vec3) + sizeof(std::uint32_t) + 32) + buckets * sizeof(std::vector<std::uint32_t>);
}

}  // namespace strata::gen::detail
