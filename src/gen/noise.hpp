#pragma once
// Private helpers of the generators: counter-based hashing (so any voxel's noise is computed
// from its coordinates alone and every slab partition gives identical bytes), a portable
// seeded random source for placing objects, and smooth value noise.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "strata/core/hash.hpp"

namespace strata::gen::detail {

constexpr std::uint64_t hash_combine(std::uint64_t h, std::int64_t v) {
  return splitmix64(h ^ std::uint64_t(v));
}

// An independent pseudo-random stream per purpose (blobs, noise, warp...) from one user seed.
constexpr std::uint64_t derive_seed(std::uint64_t seed, std::uint64_t purpose) {
  return splitmix64(seed ^ splitmix64(purpose));
}

constexpr std::uint64_t hash3(std::uint64_t seed, std::int64_t x, std::int64_t y, std::int64_t z) {
  return hash_combine(hash_combine(hash_combine(splitmix64(seed), z), y), x);
}

// The top 24 bits as a float in [-1, 1): exact in float, so no rounding differences anywhere.
constexpr float to_signed_unit(std::uint64_t h) {
  return float(h >> 40) * (1.0f / 8388608.0f) - 1.0f;
}

// Seeded randomness for placing objects at construction time. The std distributions are
// implementation-defined, so values are derived from the engine's bits directly to get the
// same volume from every standard library.
class Random {
 public:
  explicit Random(std::uint64_t seed) : engine_(seed) {}
  double uniform() { return double(engine_() >> 11) * 0x1.0p-53; }  // [0, 1)
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }

 private:
  std::mt19937_64 engine_;
};

// Smooth value noise: pseudo-random values on a lattice of spacing `cell` voxels, blended with
// smoothstep weights. One object holds the lattice rows covering [y0, y1) of one slice, already
// interpolated in z, so a voxel costs a bilinear lookup instead of eight hashes.
class NoiseSlice {
 public:
  NoiseSlice(std::uint64_t seed, double cell, double z, std::int64_t nx, std::int64_t y0, std::int64_t y1);
  // In [-1, 1] for voxel positions x in [0, nx), y in [y0, y1).
  float at(double x, double y) const {
    const double fx = x * inv_cell_, fy = y * inv_cell_ - double(row0_);
    const std::int64_t ix = std::int64_t(fx), iy = std::int64_t(fy);
    const float sx = smooth(float(fx - double(ix))), sy = smooth(float(fy - double(iy)));
    const float* r0 = &lattice_[std::size_t(iy * cols_ + ix)];
    const float* r1 = r0 + cols_;
    const float a = r0[0] + sx * (r0[1] - r0[0]);
    const float b = r1[0] + sx * (r1[1] - r1[0]);
    return a + sy * (b - a);
  }

 private:
  static float smooth(float t) { return t * t * (3.0f - 2.0f * t); }
  double inv_cell_ = 1;
  std::int64_t row0_ = 0, cols_ = 0;
  std::vector<float> lattice_;
};

inline NoiseSlice::NoiseSlice(std::uint64_t seed, double cell, double z, std::int64_t nx, std::int64_t y0,
                              std::int64_t y1)
    : inv_cell_(1.0 / cell) {
  // One extra lattice column/row past the last voxel so at() never reads out of bounds.
  row0_ = std::int64_t(std::floor(double(y0) * inv_cell_));
  const std::int64_t row_end = std::int64_t(std::floor(double(std::max(y1 - 1, y0)) * inv_cell_)) + 2;
  cols_ = std::int64_t(std::floor(double(std::max<std::int64_t>(nx - 1, 0)) * inv_cell_)) + 2;
  const double fz = z * inv_cell_;
  const std::int64_t iz = std::int64_t(std::floor(fz));
  const float sz = smooth(float(fz - double(iz)));
  lattice_.resize(std::size_t((row_end - row0_) * cols_));
  for (std::int64_t r = row0_; r < row_end; ++r) {
    for (std::int64_t c = 0; c < cols_; ++c) {
      const float lo = to_signed_unit(hash3(seed, c, r, iz));
      const float hi = to_signed_unit(hash3(seed, c, r, iz + 1));
      lattice_[std::size_t((r - row0_) * cols_ + c)] = lo + sz * (hi - lo);
    }
  }
}

}  // namespace strata::gen::detail
