#pragma once
// Bulk code -> float decoding for BrickView, compiled per instruction set (decode_kernel.cpp).
// Private to src/quant.
#include <cstddef>
#include <cstdint>

#include "strata/quant/scheme.hpp"

namespace strata::quant::detail {

// Decodes rows of consecutive codes: row (r2, r3) starts at code first + r2 stride2 + r3 stride3,
// holds `count` codes and goes to out + (r2 + rows2 r3) count. A factor matrix's leading columns
// are one row; the leading core block is K2 K3 rows of K1 codes.
struct DecodeJob {
  CoreCoding coding = CoreCoding::f32;  // factors use f32 or linear
  int bits = 32;
  float lo = 0, hi = 0;                 // linear
  float max_abs = 0, mu = 0;            // log, mu-law
  const std::byte* stream = nullptr;
  std::size_t first = 0, count = 0;
  int rows2 = 1, rows3 = 1;
  std::size_t stride2 = 0, stride3 = 0;
  float* out = nullptr;
};

// Runs the job with the widest variant active_isa() allows (strata/core/isa.hpp). The FMA
// variants may differ from the generic one by a few ulps (one rounding per multiply-add).
void decode_codes(const DecodeJob& job);

}  // namespace strata::quant::detail
