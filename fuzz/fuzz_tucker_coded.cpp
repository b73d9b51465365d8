// The `tucker_coded` payload (quant/coded_brick.hpp: header, steps, error table and the
// range-coded core, factors and corrections) through the decoder every reader uses
// (ta::decode_brick), at a reconstruction rank taken from the input.
//
// Input: byte 0 = rank K (1..255), then the payload. The brick width is the payload's own I1
// (bytes 2-3) clamped to 2..64, so the extents check passes and the decoder gets past it.
#include <algorithm>
#include <vector>

#include "support.hpp"
#include "strata/ta/brick_codec.hpp"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  strata::fuzz::init();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const int rank = std::max(1, int(data[0]));
  const auto payload = strata::fuzz::as_bytes(data + 1, size - 1);
  int width = 16;
  if (payload.size() >= 4) width = std::clamp(int(data[3]) | int(data[4]) << 8, 2, 64);
  static strata::tensor::BrickReconstructor reconstructor;
  static strata::ta::DecodeScratch scratch;
  std::vector<float> out(std::size_t(width) * width * width);
  strata::fuzz::run_guarded([&] {
    strata::ta::decode_brick(strata::store::PayloadKind::tucker_coded, payload, 0.0f, strata::quant::QuantScheme{}, width,
                             rank, reconstructor, scratch, out, "fuzz");
  });
  return 0;
}
