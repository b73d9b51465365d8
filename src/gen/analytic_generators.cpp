// Closed-form test signals: Marschner–Lobb and an antialiased solid sphere.
#include <algorithm>
#include <cmath>
#include <numbers>

#include "gen/slice_generator.hpp"

namespace strata::gen::detail {

namespace {

// Voxel i of n samples [-1, 1] with both ends included (the usual Marschner–Lobb grid).
double unit_coordinate(std::int64_t i, std::int64_t n) {
  return n > 1 ? -1.0 + 2.0 * double(i) / double(n - 1) : 0.0;
}

// Marschner & Lobb (1994), "An evaluation of reconstruction filters for volume rendering":
// rho = (1 - sin(pi z / 2) + alpha (1 + rho_r(sqrt(x^2 + y^2)))) / (2 (1 + alpha)),
// rho_r(r) = cos(2 pi f_M cos(pi r / 2)); with alpha = 0.25, f_M = 6 it lies in [0, 1].
double marschner_lobb(double x, double y, double z) {
  constexpr double alpha = 0.25, f_m = 6.0, pi = std::numbers::pi;
  const double rho_r = std::cos(2.0 * pi * f_m * std::cos(pi * std::sqrt(x * x + y * y) / 2.0));
  return (1.0 - std::sin(pi * z / 2.0) + alpha * (1.0 + rho_r)) / (2.0 * (1.0 + alpha));
}

class MarschnerLobbGenerator final : public SliceGenerator {
 public:
  explicit MarschnerLobbGenerator(const Params& p) : SliceGenerator(VolumeInfo{p.dims, DType::f32, {}}) {}

 protected:
  void fill_rows(std::int64_t z, std::int64_t y0, std::int64_t y1, std::byte* rows) const override {
    const Extent& d = info().dims;
    auto* out = reinterpret_cast<float*>(rows);
    const double uz = unit_coordinate(z, d.z);
    for (std::int64_t y = y0; y < y1; ++y) {
      const double uy = unit_coordinate(y, d.y);
      for (std::int64_t x = 0; x < d.x; ++x) *out++ = float(marschner_lobb(unit_coordinate(x, d.x), uy, uz));
    }
  }
};

// A solid sphere centred in the volume (voxel centres at integer coordinates), value 1 inside
// and a linear ramp over one voxel at the surface: clamp(r - d + 0.5, 0, 1).
class SphereGenerator final : public SliceGenerator {
 public:
  explicit SphereGenerator(const Params& p)
      : SliceGenerator(VolumeInfo{p.dims, DType::f32, {}}),
        radius_(p.count > 0 ? double(p.count) : 0.4 * double(std::min({p.dims.x, p.dims.y, p.dims.z}))) {}

 protected:
  void fill_rows(std::int64_t z, std::int64_t y0, std::int64_t y1, std::byte* rows) const override {
    const Extent& d = info().dims;
    auto* out = reinterpret_cast<float*>(rows);
    const double cx = 0.5 * double(d.x - 1), cy = 0.5 * double(d.y - 1), cz = 0.5 * double(d.z - 1);
    const double dz2 = (double(z) - cz) * (double(z) - cz);
    for (std::int64_t y = y0; y < y1; ++y) {
      const double dyz2 = dz2 + (double(y) - cy) * (double(y) - cy);
      for (std::int64_t x = 0; x < d.x; ++x) {
        const double dist = std::sqrt(dyz2 + (double(x) - cx) * (double(x) - cx));
        *out++ = float(std::clamp(radius_ - dist + 0.5, 0.0, 1.0));
      }
    }
  }

 private:
  double radius_;
};

}  // namespace

std::unique_ptr<Generator> make_marschner_lobb(const Params& params) {
  return std::make_unique<MarschnerLobbGenerator>(params);
}

std::unique_ptr<Generator> make_sphere(const Params& params) { return std::make_unique<SphereGenerator>(params); }

}  // namespace strata::gen::detail
