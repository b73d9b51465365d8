// The `masked` payload (ta/non_finite.hpp: inner kind, inner constant, the zstd frame of 2-bit
// voxel classes, the inner brick) through the decoder every reader uses (ta::decode_brick),
// which unwraps it, decodes the inner brick and writes the NaN and infinite voxels back.
//
// Input: byte 0 = rank K (1..255), byte 1 = brick width (clamped to 2..16), then the payload.
#include <algorithm>
#include <vector>

#include "support.hpp"
#include "strata/ta/brick_codec.hpp"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  strata::fuzz::init();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 2) return 0;
  const int rank = std::max(1, int(data[0]));
  const int width = std::clamp(int(data[1]), 2, 16);
  const auto payload = strata::fuzz::as_bytes(data + 2, size - 2);
  static strata::tensor::BrickReconstructor reconstructor;
  static strata::ta::DecodeScratch scratch;
  std::vector<float> out(std::size_t(width) * width * width);
  strata::fuzz::run_guarded([&] {
    strata::ta::decode_brick(strata::store::PayloadKind::masked, payload, 0.0f, strata::quant::QuantScheme{}, width, rank,
                             reconstructor, scratch, out, "fuzz");
  });
  return 0;
}
