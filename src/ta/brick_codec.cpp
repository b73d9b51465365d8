#include "strata/ta/brick_codec.hpp"

#include <algorithm>

#include "strata/core/error.hpp"
#include "strata/quant/bitpack.hpp"
#include "strata/tensor/tucker.hpp"

namespace strata::ta {

namespace {

bool is_constant(const Tensor3& samples) {
  auto v = samples.values();
  return std::all_of(v.begin(), v.end(), [first = v[0]](float x) { return x == first; });
}

}  // namespace

EncodedBrick encode_brick(const Tensor3& samples, const CodecParams& params) {
  EncodedBrick out;
  if (is_constant(samples)) {
    // Empty background is common (44% of ch2better's bricks): one value, no tensor.
    out.kind = store::PayloadKind::constant;
    out.constant_value = samples.values()[0];
    return out;
  }
  const int r = params.rank;
  const Ranks3 ranks{r, r, r};
  Tucker model = params.hooi_iterations > 0
                     ? hooi(samples, ranks, HooiOptions{params.hooi_tolerance, params.hooi_iterations, true})
                     : hosvd(samples, ranks);
  out.kind = store::PayloadKind::tucker;
  out.payload = quant::serialize(quant::quantize(model, params.quant), params.quant);
  const PayloadParts parts = payload_parts(out.payload, params.quant, "encode");
  out.core_bytes = parts.core_bytes;
  out.factor_bytes = parts.factor_bytes;
  out.header_bytes = parts.header_bytes;
  return out;
}

PayloadParts payload_parts(std::span<const std::byte> payload, const quant::QuantScheme& scheme,
                           const std::string& context) {
  try {
    const quant::BrickView view(payload, scheme);
    PayloadParts p;
    const Ranks3& r = view.ranks();
    const Dims3& d = view.dims();
    p.core_bytes = quant::packed_size(std::size_t(r[0]) * r[1] * r[2], scheme.core_bits);
    p.factor_bytes = quant::packed_size(std::size_t(d[0] * r[0] + d[1] * r[1] + d[2] * r[2]), scheme.factor_bits);
    p.header_bytes = payload.size() - p.core_bytes - p.factor_bytes;
    return p;
  } catch (const Error& e) {
    throw Error(context + ": " + e.what());
  }
}

void decode_brick(store::PayloadKind kind, std::span<const std::byte> payload, float constant_value,
                  const quant::QuantScheme& scheme, int brick_width, int rank, BrickReconstructor& reconstructor,
                  DecodeScratch& scratch, std::span<float> out, const std::string& context) {
  const std::size_t voxels = std::size_t(brick_width) * brick_width * brick_width;
  if (out.size() != voxels) throw Error(context + ": decode buffer holds " + std::to_string(out.size()) + " floats, brick needs " + std::to_string(voxels));
  if (kind == store::PayloadKind::constant) {
    std::fill(out.begin(), out.end(), constant_value);
    return;
  }
  if (kind != store::PayloadKind::tucker) throw Error(context + ": unsupported payload kind " + std::to_string(int(kind)));
  try {
    const quant::BrickView view(payload, scheme);
    const Dims3& d = view.dims();
    if (d[0] != brick_width || d[1] != brick_width || d[2] != brick_width)
      throw Error("brick extents " + to_string(d) + " differ from the brick width " + std::to_string(brick_width));
    const Ranks3& r = view.ranks();
    const Ranks3 k{std::min(rank, r[0]), std::min(rank, r[1]), std::min(rank, r[2])};
    quant::dequantize(view, k, scratch);
    reconstructor.reconstruct(scratch.view(), out);
  } catch (const Error& e) {
    throw Error(context + ": " + e.what());
  }
}

}  // namespace strata::ta
