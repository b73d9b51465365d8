// The fixed-rank Tucker payload (quant/brick.hpp: `tucker`, and `tucker_zstd`, its byte planes
// in a zstd frame) through the decoder every reader uses (ta::decode_brick).
//
// Input: byte 0 = bit 0: kind tucker_zstd (else tucker); byte 1 = the quantization scheme (an
// index into kSchemes); byte 2 = rank K (1..255); byte 3 = brick width (clamped to 2..64); then
// the payload.
#include <algorithm>
#include <array>
#include <string_view>
#include <vector>

#include "support.hpp"
#include "strata/ta/brick_codec.hpp"

namespace {

constexpr std::array<std::string_view, 10> kSchemes = {"u16,b8log+", "u16,b8log", "u8,b8lin", "u16,b16lin", "u16,b12log+",
                                                       "u16,b8mu+", "u16,b8mu1000+", "f32", "u8,b8mu", "f32,b16log"};

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  strata::fuzz::init();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 4) return 0;
  const auto kind = data[0] & 1 ? strata::store::PayloadKind::tucker_zstd : strata::store::PayloadKind::tucker;
  static const auto schemes = [] {
    std::vector<strata::quant::QuantScheme> s;
    for (auto name : kSchemes) s.push_back(strata::quant::QuantScheme::parse(name));
    return s;
  }();
  const auto& scheme = schemes[data[1] % schemes.size()];
  const int rank = std::max(1, int(data[2]));
  const int width = std::clamp(int(data[3]), 2, 64);
  const auto payload = strata::fuzz::as_bytes(data + 4, size - 4);
  static strata::tensor::BrickReconstructor reconstructor;
  static strata::ta::DecodeScratch scratch;
  std::vector<float> out(std::size_t(width) * width * width);
  strata::fuzz::run_guarded([&] {
    strata::ta::decode_brick(kind, payload, 0.0f, scheme, width, rank, reconstructor, scratch, out, "fuzz");
    (void)strata::ta::payload_parts(strata::ta::plain_payload(kind, payload, scheme, scratch, "fuzz"), scheme, "fuzz");
  });
  return 0;
}
