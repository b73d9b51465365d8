#include "gen/geometry.hpp"

#include <numbers>

namespace strata::gen::detail {

Vec3 random_unit_vector(Random& rng) {
  // Uniform on the sphere: z uniform in [-1, 1] (Archimedes), azimuth uniform.
  const double z = rng.uniform(-1.0, 1.0), phi = rng.uniform(0.0, 2.0 * std::numbers::pi);
  const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
  return {r * std::cos(phi), r * std::sin(phi), z};
}

void orthonormal_frame(Vec3 dir, Vec3& e1, Vec3& e2) {
  // Cross with the axis least aligned with dir, so the result is never near zero.
  const Vec3 helper = std::abs(dir.x) < 0.6 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
  e1 = normalized(cross(dir, helper));
  e2 = cross(dir, e1);
}

Segment make_segment(Vec3 a, Vec3 b, float reach, std::uint32_t owner) {
  Segment s;
  s.ax = float(a.x), s.ay = float(a.y), s.az = float(a.z);
  s.dx = float(b.x - a.x), s.dy = float(b.y - a.y), s.dz = float(b.z - a.z);
  const float len2 = s.dx * s.dx + s.dy * s.dy + s.dz * s.dz;
  s.inv_len2 = len2 > 0 ? 1.0f / len2 : 0.0f;
  s.reach = reach;
  s.owner = owner;
  return s;
}

ZBinIndex::ZBinIndex(const std::vector<std::pair<double, double>>& z_ranges, std::int64_t depth) {
  const std::int64_t bins = ((std::max<std::int64_t>(depth, 1) - 1) >> kBinShift) + 1;
  // Bin range of object i, or an empty range when it misses the volume in z.
  auto bin_range = [&](std::size_t i, std::int64_t& b0, std::int64_t& b1) {
    const auto [lo, hi] = z_ranges[i];
    b0 = std::max<std::int64_t>(0, std::int64_t(std::floor(lo))) >> kBinShift;
    b1 = std::min<std::int64_t>(depth - 1, std::int64_t(std::ceil(hi))) >> kBinShift;
    if (hi < 0 || lo > double(depth - 1)) b1 = b0 - 1;
  };
  offsets_.assign(std::size_t(bins) + 1, 0);
  for (std::size_t i = 0; i < z_ranges.size(); ++i) {
    std::int64_t b0, b1;
    bin_range(i, b0, b1);
    for (std::int64_t b = b0; b <= b1; ++b) ++offsets_[std::size_t(b) + 1];
  }
  for (std::size_t b = 1; b < offsets_.size(); ++b) offsets_[b] += offsets_[b - 1];
  ids_.resize(offsets_.back());
  std::vector<std::size_t> fill(offsets_.begin(), offsets_.end() - 1);
  for (std::size_t i = 0; i < z_ranges.size(); ++i) {
    std::int64_t b0, b1;
    bin_range(i, b0, b1);
    for (std::int64_t b = b0; b <= b1; ++b) ids_[fill[std::size_t(b)]++] = std::uint32_t(i);
  }
}

namespace {
bool touches_volume(const Segment& s, const Extent& dims) {
  auto misses = [&](float a, float d, std::int64_t n) {
    return std::max(a, a + d) + s.reach < 0.0f || std::min(a, a + d) - s.reach > float(n - 1);
  };
  return !misses(s.ax, s.dx, dims.x) && !misses(s.ay, s.dy, dims.y) && !misses(s.az, s.dz, dims.z);
}

std::vector<Segment> inside_volume(std::vector<Segment> segments, const Extent& dims) {
  std::erase_if(segments, [&](const Segment& s) { return !touches_volume(s, dims); });
  segments.shrink_to_fit();
  return segments;
}

std::vector<std::pair<double, double>> segment_z_ranges(const std::vector<Segment>& segments) {
  std::vector<std::pair<double, double>> ranges;
  ranges.reserve(segments.size());
  for (const Segment& s : segments) ranges.emplace_back(s.z_lo(), s.z_hi());
  return ranges;
}
}  // namespace

SegmentSet::SegmentSet(std::vector<Segment> segments, const Extent& dims)
    : segments_(inside_volume(std::move(segments), dims)), index_(segment_z_ranges(segments_), dims.z) {}

BentLine BentLine::random(Random& rng, Vec3 centre, Vec3 dir, double length, double bend) {
  BentLine line;
  line.centre = centre;
  line.dir = dir;
  orthonormal_frame(dir, line.e1, line.e2);
  line.half_length = 0.5 * length;
  const double two_pi = 2.0 * std::numbers::pi;
  line.amp1 = bend * length * rng.uniform(0.3, 1.0);
  line.freq1 = two_pi / (length * rng.uniform(0.8, 2.0));
  line.phase1 = rng.uniform(0.0, two_pi);
  line.amp2 = bend * length * rng.uniform(0.3, 1.0);
  line.freq2 = two_pi / (length * rng.uniform(0.8, 2.0));
  line.phase2 = rng.uniform(0.0, two_pi);
  return line;
}

void append_segments(const BentLine& line, Vec3 offset, double step, float reach, std::uint32_t owner,
                     std::vector<Segment>& out) {
  const double length = 2.0 * line.half_length;
  const int pieces = std::max(1, int(std::ceil(length / step)));
  Vec3 previous = line.at(-line.half_length) + offset;
  for (int i = 1; i <= pieces; ++i) {
    const Vec3 next = line.at(-line.half_length + length * double(i) / pieces) + offset;
    out.push_back(make_segment(previous, next, reach, owner));
    previous = next;
  }
}

}  // namespace strata::gen::detail
