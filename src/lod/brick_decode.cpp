#include "strata/lod/brick_decode.hpp"

#include <algorithm>
#include <limits>
#include <memory>

#include "strata/core/error.hpp"

namespace strata::lod {

BrickModel dequantize_payload(store::PayloadKind kind, std::span<const std::byte> payload,
                              const quant::QuantScheme& scheme, int brick_width, ta::DecodeScratch& scratch,
                              const std::string& context, const ta::BrickBases* bases) {
  if (kind == store::PayloadKind::constant) throw Error(context + ": a constant brick has no model to dequantize");
  auto model = std::make_shared<quant::DequantizedModel>();
  ta::dequantize_brick(kind, payload, scheme, brick_width, std::numeric_limits<int>::max(), scratch, *model, context,
                       bases);
  return model;
}

BrickModel fetch_model(const ta::TaVolume& volume, const store::BrickEntry& entry, ta::DecodeScratch& scratch,
                       std::uint64_t& bytes_read) {
  const io::SharedBytes payload = volume.container().payload(entry);
  bytes_read += entry.size;
  const ta::BrickBases bases = volume.global() ? volume.brick_bases(entry.key) : ta::BrickBases{};
  return dequantize_payload(entry.kind, payload, volume.quant_scheme(), volume.geometry().layout().brick, scratch,
                            brick_context(volume, entry.key), volume.global() ? &bases : nullptr);
}

void reconstruct_at_rank(const quant::DequantizedModel& model, int k, tensor::BrickReconstructor& reconstructor,
                         std::span<float> out) {
  ta::reconstruct_model(model, ta::leading_ranks(model, k), reconstructor, out);
}

std::string brick_context(const ta::TaVolume& volume, const store::BrickKey& key) {
  return volume.container().name() + ": " + store::brick_name(key);
}

}  // namespace strata::lod
