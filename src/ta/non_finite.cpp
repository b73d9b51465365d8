#include "ta/non_finite.hpp"

#include <bit>
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

// Whether a payload of kind `k` may sit inside a masked payload (PayloadKindTraits::maskable).
bool brick_kind(store::PayloadKind k) {
  const store::PayloadKindTraits* traits = store::find_payload_kind(std::uint8_t(k));
  return traits != nullptr && traits->maskable;
}

constexpr std::size_t kHeaderBytes = 9;  // inner kind u8, inner constant f32, mask frame size u32
// Level 9 codes masks ~30% smaller than 3 at the same encoder speed (ch2better with NaN
// outside the brain: 0.199 -> 0.144 bits/voxel with a byte per voxel, 0.118 with two bits);
// 19 takes seconds per volume.
constexpr int kMaskZstdLevel = 9;

}  // namespace

bool has_non_finite(std::span<const float> samples) {
  // An all-ones exponent is NaN or an infinity: integer masks and compares, which vectorise on
  // any x86-64 (the float compare did not, and cost 1% of the encoder).
  std::uint32_t bad = 0;
  for (float v : samples) bad |= std::uint32_t((std::bit_cast<std::uint32_t>(v) & 0x7F800000u) == 0x7F800000u);
  return bad != 0;
}

namespace {

// Pull-push fill (the classic scattered-data stand-in): each coarser grid holds the mean of its
// finer cells' known values, down to one cell; then every unknown cell takes its parent's value,
// from the coarsest grid up. Unknown cells so continue the finite data nearby, not a brick-wide
// mean that would put a step at the mask's edge for the codecs to pay for.
void pull_push_fill(std::span<float> values, std::vector<float>& weights, const tensor::Dims3& dims) {
  struct Grid {
    tensor::Dims3 dims;
    std::vector<float> value, weight;
  };
  std::vector<Grid> grids;
  grids.push_back({dims, std::vector<float>(values.begin(), values.end()), std::move(weights)});
  while (grids.back().dims[0] > 1 || grids.back().dims[1] > 1 || grids.back().dims[2] > 1) {
    const Grid& fine = grids.back();
    const tensor::Dims3 fd = fine.dims, cd{(fd[0] + 1) / 2, (fd[1] + 1) / 2, (fd[2] + 1) / 2};
    Grid coarse{cd, std::vector<float>(std::size_t(cd[0] * cd[1] * cd[2]), 0.0f),
                std::vector<float>(std::size_t(cd[0] * cd[1] * cd[2]), 0.0f)};
    for (std::int64_t z = 0; z < fd[2]; ++z)
      for (std::int64_t y = 0; y < fd[1]; ++y)
        for (std::int64_t x = 0; x < fd[0]; ++x) {
          const std::size_t f = std::size_t(x + fd[0] * (y + fd[1] * z));
          const std::size_t c = std::size_t(x / 2 + cd[0] * (y / 2 + cd[1] * (z / 2)));
          coarse.value[c] += fine.weight[f] * fine.value[f];
          coarse.weight[c] += fine.weight[f];
        }
    for (std::size_t c = 0; c < coarse.value.size(); ++c)
      if (coarse.weight[c] > 0) {
        coarse.value[c] /= coarse.weight[c];
        coarse.weight[c] = 1;
      }
    grids.push_back(std::move(coarse));
  }
  for (std::size_t level = grids.size() - 1; level-- > 0;) {
    Grid& fine = grids[level];
    const Grid& coarse = grids[level + 1];
    const tensor::Dims3 fd = fine.dims, cd = coarse.dims;
    for (std::int64_t z = 0; z < fd[2]; ++z)
      for (std::int64_t y = 0; y < fd[1]; ++y)
        for (std::int64_t x = 0; x < fd[0]; ++x) {
          const std::size_t f = std::size_t(x + fd[0] * (y + fd[1] * z));
          if (fine.weight[f] > 0) continue;
          fine.value[f] = coarse.value[std::size_t(x / 2 + cd[0] * (y / 2 + cd[1] * (z / 2)))];
          fine.weight[f] = 1;
        }
  }
  std::copy(grids[0].value.begin(), grids[0].value.end(), values.begin());
}

}  // namespace

NonFiniteMask take_non_finite(std::span<float> samples, const tensor::Dims3& dims) {
  if (std::int64_t(samples.size()) != dims[0] * dims[1] * dims[2]) throw Error("take_non_finite: samples do not match the extents");
  NonFiniteMask mask;
  std::vector<float> weights(samples.size(), 1.0f);
  for (std::size_t i = 0; i < samples.size(); ++i) {
    if (std::isfinite(samples[i])) continue;
    mask.index.push_back(std::uint32_t(i));
    mask.value.push_back(samples[i]);
    samples[i] = 0;
    weights[i] = 0;
  }
  if (mask.index.size() < samples.size()) pull_push_fill(samples, weights, dims);
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
  // Two bits a voxel, four voxels a byte (voxel i in bits 2 (i mod 4) and up).
  std::vector<std::byte> classes((voxels + 3) / 4, std::byte{0});
  for (std::size_t n = 0; n < mask.index.size(); ++n)
    classes[mask.index[n] / 4] |= std::byte(unsigned(class_of(mask.value[n])) << (2 * (mask.index[n] % 4)));
  const std::vector<std::byte> frame = store::zstd_compress(classes, std::max(zstd_level, kMaskZstdLevel));
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
  const std::size_t packed = (voxels + 3) / 4;
  store::zstd_decompress(frame, packed, scratch, context, "masked brick mask");
  if (scratch.size() != packed)
    throw FormatError(context, "masked brick mask",
                      "holds " + std::to_string(scratch.size()) + " bytes, a brick of " + std::to_string(voxels) +
                          " voxels has " + std::to_string(packed));
  if (voxels % 4 != 0 && (std::to_integer<unsigned>(scratch.back()) >> (2 * (voxels % 4))) != 0)
    throw FormatError(context, "masked brick mask", "classes set past the brick's last voxel");
  for (std::size_t i = 0; i < voxels; ++i) {
    const auto c = (std::to_integer<unsigned>(scratch[i / 4]) >> (2 * (i % 4))) & 3u;
    if (c == 0) continue;
    p.mask.index.push_back(std::uint32_t(i));
    p.mask.value.push_back(value_of(VoxelClass(c)));
  }
  if (p.mask.index.empty()) throw FormatError(context, "masked brick mask", "marks no voxel (such a brick is not masked)");
  return p;
}

}  // namespace strata::ta
