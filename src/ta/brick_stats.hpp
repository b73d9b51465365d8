#pragma once
/// @file
/// @brief Culling statistics of an encoded brick: min, max and 64-bin occupancy bits. Private to src/ta.
///
/// The brick index stores them for every brick (docs/format.md); the bin rule is the format's
/// (strata/store/brick_histogram.hpp). Two passes over a brick's samples and decoded values
/// per brick, so the kernel is vectorised and compiled per instruction set (strata/core/isa.hpp).
#include <cstdint>
#include <span>

namespace strata::ta {

struct HistogramRange {
  double lo = 0, hi = 1;  // the volume's value range: 64 equal bins
};

struct BrickStats {
  float lo = 0, hi = 0;
  std::uint64_t bits = 0;  // bit i set when some value falls into bin i
};

/// @brief Min, max and histogram bits over both spans, each non-empty, with the widest kernel
/// variant active_isa() allows. NaN samples are ignored by min and max and set bin 0; if every
/// sample is NaN, min and max are NaN. Every variant gives the same result. Thread-safe.
BrickStats brick_stats(std::span<const float> a, std::span<const float> b, const HistogramRange& range);

}  // namespace strata::ta
