#pragma once
// Helpers shared by the ta tests: an in-memory VolumeSource, a one-call compressor, and the
// reference computations the tests compare the codec against.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <string>
#include <vector>

#include "strata/core/error.hpp"
#include "strata/core/progress.hpp"
#include "strata/core/volume.hpp"
#include "strata/gen/generators.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/quant/scheme.hpp"
#include "strata/ta/compress.hpp"
#include "strata/ta/ta_volume.hpp"
#include "support/test_support.hpp"

namespace strata::ta::testing {

// A Volume served through the streaming interface the compressor reads from.
class MemorySource : public io::VolumeSource {
 public:
  explicit MemorySource(Volume v, std::filesystem::path name = "memory-volume")
      : volume_(std::move(v)), path_(std::move(name)) {}
  const VolumeInfo& info() const override { return volume_.info(); }
  const std::filesystem::path& path() const override { return path_; }
  Volume read_box(const Box& box) override { return volume_.crop(box); }

 private:
  Volume volume_;
  std::filesystem::path path_;
};

inline Volume prisms(Extent dims, std::uint64_t seed = 7) {
  gen::Params p;
  p.kind = gen::Kind::prisms;
  p.dims = dims;
  p.seed = seed;
  return gen::generate(p);
}

// hooi and zstd default to the library's defaults (one HOOI sweep, zstd level 3); every brick
// stays Tucker (no lossless fallback).
inline CompressParams params(int brick, int overlap, int rank, const std::string& quant, int hooi = 1, int zstd = 3) {
  CompressParams p;
  p.layout = {brick, overlap};
  p.codec.rank = rank;
  p.codec.quant = quant::QuantScheme::parse(quant);
  p.codec.hooi_iterations = hooi;
  p.codec.zstd_level = zstd;
  p.codec.lossless_fallback = false;  // these tests study the Tucker bricks themselves
  return p;
}

inline bool is_tucker(store::PayloadKind k) {
  return k == store::PayloadKind::tucker || k == store::PayloadKind::tucker_zstd;
}

inline CompressReport compress(const Volume& v, const std::filesystem::path& out, const CompressParams& p) {
  MemorySource source(v);
  return compress_volume(source, out, p, silent_progress());
}

// The whole volume as f32 (for reference computations).
inline Volume as_f32(const Volume& v) { return v.dtype() == DType::f32 ? v : v.converted(DType::f32); }

// The parent level as the format defines it: each voxel is the mean of its 2x2x2 children,
// an odd last child index standing for itself (indices clamped to the edge).
inline Volume average_2x2x2(const Volume& f) {
  const Extent d = f.dims();
  const Extent h{(d.x + 1) / 2, (d.y + 1) / 2, (d.z + 1) / 2};
  Volume out(h, DType::f32);
  auto src = f.view<float>();
  auto dst = out.view<float>();
  for (std::int64_t z = 0; z < h.z; ++z)
    for (std::int64_t y = 0; y < h.y; ++y)
      for (std::int64_t x = 0; x < h.x; ++x) {
        double s = 0;
        for (int dz = 0; dz < 2; ++dz)
          for (int dy = 0; dy < 2; ++dy)
            for (int dx = 0; dx < 2; ++dx)
              s += src(std::min(2 * x + dx, d.x - 1), std::min(2 * y + dy, d.y - 1), std::min(2 * z + dz, d.z - 1));
        dst(x, y, z) = float(s / 8);
      }
  return out;
}

struct MaxDiff {
  double value = 0;
  Extent at;
};

inline MaxDiff max_abs_diff(const Volume& a, const Volume& b) {
  MaxDiff m;
  const Extent d = a.dims();
  for (std::int64_t z = 0; z < d.z; ++z)
    for (std::int64_t y = 0; y < d.y; ++y)
      for (std::int64_t x = 0; x < d.x; ++x) {
        const double e = std::abs(a.value(x, y, z) - b.value(x, y, z));
        if (e > m.value) m = {e, {x, y, z}};
      }
  return m;
}

inline std::pair<double, double> value_range(const Volume& v) {
  double lo = INFINITY, hi = -INFINITY;
  const Extent d = v.dims();
  for (std::int64_t z = 0; z < d.z; ++z)
    for (std::int64_t y = 0; y < d.y; ++y)
      for (std::int64_t x = 0; x < d.x; ++x) {
        lo = std::min(lo, v.value(x, y, z));
        hi = std::max(hi, v.value(x, y, z));
      }
  return {lo, hi};
}

inline std::vector<char> file_bytes(const std::filesystem::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

using strata::test::error_of;
using strata::test::parameter_of;

inline bool contains(const std::string& haystack, const std::string& needle) {
  return haystack.find(needle) != std::string::npos;
}

}  // namespace strata::ta::testing
