#pragma once
// Helpers shared by the generator tests.
#include <cstdint>
#include <set>
#include <vector>

#include "strata/gen/generators.hpp"

namespace strata::gen::helpers {

inline Params params(Kind kind, Extent dims, std::uint64_t seed = 1, std::int64_t count = 0) {
  Params p;
  p.kind = kind;
  p.dims = dims;
  p.seed = seed;
  p.count = count;
  return p;
}

// Concatenates the slabs [cuts[i], cuts[i+1]) of a generator along z.
inline Volume assemble(const Generator& g, const std::vector<std::int64_t>& cuts) {
  Volume whole(g.info());
  const std::size_t slice_bytes = g.info().bytes_per_slice();
  for (std::size_t i = 0; i + 1 < cuts.size(); ++i) {
    const Volume slab = g.slab(cuts[i], cuts[i + 1]);
    std::copy(slab.bytes(), slab.bytes() + slab.byte_size(), whole.bytes() + std::size_t(cuts[i]) * slice_bytes);
  }
  return whole;
}

inline std::set<std::uint32_t> distinct_labels(const Volume& v) {
  const auto s = v.samples<std::uint32_t>();
  return {s.begin(), s.end()};
}

inline double zero_fraction(const Volume& v) {
  std::int64_t zeros = 0;
  for (std::uint32_t l : v.samples<std::uint32_t>()) zeros += (l == 0);
  return double(zeros) / double(v.voxel_count());
}

}  // namespace strata::gen::helpers
