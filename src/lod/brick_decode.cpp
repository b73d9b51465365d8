#include "strata/lod/brick_decode.hpp"

#include <algorithm>
#include <memory>

#include "strata/core/error.hpp"

namespace strata::lod {

BrickModel dequantize_payload(store::PayloadKind kind, std::span<const std::byte> payload,
                              const quant::QuantScheme& scheme, int brick_width, ta::DecodeScratch& scratch,
                              const std::string& context) {
  if (kind == store::PayloadKind::constant) throw Error(context + ": a constant brick has no model to dequantize");
  try {
    const quant::BrickView view(ta::plain_payload(kind, payload, scheme, scratch, context), scheme);
    const Dims3& d = view.dims();
    if (d[0] != brick_width || d[1] != brick_width || d[2] != brick_width)
      throw Error("brick extents " + to_string(d) + " differ from the brick width " + std::to_string(brick_width));
    auto model = std::make_shared<quant::DequantizedModel>();
    quant::dequantize(view, view.ranks(), *model);
    return model;
  } catch (const Error& e) {
    throw Error(context + ": " + e.what());
  }
}

BrickModel fetch_model(const ta::TaVolume& volume, const store::BrickEntry& entry, ta::DecodeScratch& scratch,
                       std::uint64_t& bytes_read) {
  const std::span<const std::byte> payload = volume.container().payload(entry);
  bytes_read += entry.size;
  return dequantize_payload(entry.kind, payload, volume.quant_scheme(), volume.geometry().layout().brick, scratch,
                            brick_context(volume, entry.key));
}

void reconstruct_at_rank(const quant::DequantizedModel& model, int k, BrickReconstructor& reconstructor,
                         std::span<float> out) {
  const int kk = std::max(k, 1);
  const Ranks3 leading{std::min(kk, model.ranks[0]), std::min(kk, model.ranks[1]), std::min(kk, model.ranks[2])};
  reconstructor.reconstruct(model.view(), leading, out);
}

std::string brick_context(const ta::TaVolume& volume, const store::BrickKey& key) {
  return volume.container().path().string() + ": brick (level " + std::to_string(key.level) + ", " +
         std::to_string(key.x) + "," + std::to_string(key.y) + "," + std::to_string(key.z) + ")";
}

}  // namespace strata::lod
