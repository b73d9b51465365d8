#include "ta/non_finite.hpp"

#include <cmath>
#include <limits>

#include "strata/core/bytes.hpp"
#include "strata/core/error.hpp"
#include "strata/store/zstd_frame.hpp"

namespace strata::ta {
namespace {

// The mask's class byte of a voxel (docs/format.md, "Masked brick payload").
enum class VoxelClass : std::uint8_t { finite = 0, nan = 1, plus_infinity = 2, minus_infinity = 3 };

VoxelClass class_of(float v) {
  if (std::isnan(v)) return VoxelClass::nan;
  if (std::isinf(v)) return v > 0 ? VoxelClass::plus_infinity : VoxelClass::minus_infinity;
  return VoxelClass::finite;
}

float value_of(VoxelClass c) {
  switch (c) {
    case VoxelClass::nan: return std::numeric_limits<float>::quiet_NaN();
    case VoxelClass::plus_infinity: return std::numeric_limits<float>::infinity();
    case VoxelClass::minus_infinity: return -std::numeric_limits<float>::infinity();
    case VoxelClass::finite: break;
  }
  return 0;
}

bool brick_kind(store::PayloadKind k) {
  switch (k) {
    case store::PayloadKind::constant:
    case store::PayloadKind::tucker:
    case store::PayloadKind::tucker_zstd:
    case store::PayloadKind::tucker_coded:
    case store::PayloadKind::raw_zstd:
    case store::PayloadKind::raw_packed: return true;
    case store::PayloadKind::masked: return false;
  }
  return false;
}

constexpr std::size_t kHeaderBytes = 9;  // inner kind u8, inner constant f32, mask frame size u32

}  // namespace

bool has_non_finite(std::span<const float> samples) {
  bool bad = false;
  for (float v : samples) bad |= !(std::abs(v) <= std::numeric_limits<float>::max());
  return bad;
}

NonFiniteMask take_non_finite(std::span<float> samples) {
  NonFiniteMask mask;
  double sum = 0;
  std::size_t finite = 0;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    if (std::isfinite(samples[i])) {
      sum += double(samples[i]);
      ++finite;
      continue;
    }
    mask.index.push_back(std::uint32_t(i));
    mask.value.push_back(samples[i]);
  }
  const float fill = finite > 0 ? float(sum / double(finite)) : 0.0f;
  for (std::uint32_t i : mask.index) samples[i] = fill;
  return mask;
}

void restore_non_finite(const NonFiniteMask& mask, std::span<float> out) {
  for (std::size_t n = 0; n < mask.index.size(); ++n) out[mask.index[n]] = mask.value[n];
}

void copy_masked(const NonFiniteMask& mask, std::span<const float> from, std::span<float> to) {
  for (std::uint32_t i : mask.index) to[i] = from[i];
}

std::int64_t masked_in_core(const NonFiniteMask& mask, const tensor::Dims3& dims, const CoreRegion& core) {
  std::int64_t n = 0;
  for (std::uint32_t i : mask.index) {
    const std::int64_t x = std::int64_t(i) % dims[0], y = std::int64_t(i) / dims[0] % dims[1],
                       z = std::int64_t(i) / (dims[0] * dims[1]);
    n += x >= core.lo[0] && x < core.hi[0] && y >= core.lo[1] && y < core.hi[1] && z >= core.lo[2] && z < core.hi[2];
  }
  return n;
}

void wrap_with_mask(const NonFiniteMask& mask, std::size_t voxels, int zstd_level, EncodedBrick& brick) {
  brick.payload = wrap_masked(mask, voxels, brick.kind, brick.constant_value, brick.payload, zstd_level);
  brick.kind = store::PayloadKind::masked;
  brick.constant_value = 0;
}

bool uniform_non_finite(const NonFiniteMask& mask, std::size_t voxels) {
  if (mask.index.size() != voxels || voxels == 0) return false;
  const VoxelClass first = class_of(mask.value[0]);
  for (float v : mask.value)
    if (class_of(v) != first) return false;
  return true;
}

std::vector<std::byte> wrap_masked(const NonFiniteMask& mask, std::size_t voxels, store::PayloadKind inner,
                                   float inner_constant, std::span<const std::byte> inner_payload, int zstd_level) {
  if (!brick_kind(inner)) throw Error("wrap_masked: the inner payload must be a brick kind");
  std::vector<std::byte> classes(voxels, std::byte{0});
  for (std::size_t n = 0; n < mask.index.size(); ++n) classes[mask.index[n]] = std::byte(class_of(mask.value[n]));
  const std::vector<std::byte> frame = store::zstd_compress(classes, std::max(zstd_level, 1));
  ByteWriter out(kHeaderBytes + frame.size() + inner_payload.size());
  out.put(std::uint8_t(inner));
  out.put(inner == store::PayloadKind::constant ? inner_constant : 0.0f);
  out.put(std::uint32_t(frame.size()));
  out.put_bytes(frame);
  out.put_bytes(inner_payload);
  return out.take();
}

MaskedPayload unwrap_masked(std::span<const std::byte> bytes, std::size_t voxels, std::vector<std::byte>& scratch,
                            const std::string& context) {
  ByteReader in(bytes, context);
  MaskedPayload p;
  const auto inner = store::PayloadKind(in.get<std::uint8_t>("masked brick inner kind"));
  if (!brick_kind(inner))
    throw FormatError(context, "masked brick inner kind",
                      "expected a brick payload kind (1 to 6), found " + std::to_string(int(inner)));
  p.inner = inner;
  p.inner_constant = in.get<float>("masked brick inner constant");
  const auto frame_size = in.get<std::uint32_t>("masked brick mask size");
  const std::span<const std::byte> frame = in.bytes(frame_size, "masked brick mask");
  p.inner_payload = bytes.subspan(in.position());
  if (inner == store::PayloadKind::constant && !p.inner_payload.empty())
    throw FormatError(context, "masked brick payload", "an inner constant brick has no payload bytes");
  store::zstd_decompress(frame, voxels, scratch, context, "masked brick mask");
  if (scratch.size() != voxels)
    throw FormatError(context, "masked brick mask",
                      "holds " + std::to_string(scratch.size()) + " voxels, the brick has " + std::to_string(voxels));
  for (std::size_t i = 0; i < voxels; ++i) {
    const auto c = std::to_integer<std::uint8_t>(scratch[i]);
    if (c == 0) continue;
    if (c > 3) throw FormatError(context, "masked brick mask", "class " + std::to_string(c) + " (expected 0 to 3)");
    p.mask.index.push_back(std::uint32_t(i));
    p.mask.value.push_back(value_of(VoxelClass(c)));
  }
  return p;
}

}  // namespace strata::ta
