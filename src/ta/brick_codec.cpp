#include "strata/ta/brick_codec.hpp"

#include <algorithm>
#include <memory>

#include "strata/core/error.hpp"
#include "ta/non_finite.hpp"
#include "strata/quant/bitpack.hpp"
#include "strata/store/byte_planes.hpp"
#include "strata/store/zstd_frame.hpp"
#include "strata/quant/coded_brick.hpp"
#include "strata/ta/global_basis.hpp"
#include "strata/tensor/tucker.hpp"
#include "ta/raw_brick.hpp"

namespace strata::ta {

namespace {

// Runs `f`, prefixing the message of an Error it throws with `context`.
template <class F>
decltype(auto) in_context(const std::string& context, F&& f) {
  try {
    return f();
  } catch (const Error& e) {
    throw Error(context + ": " + e.what());
  }
}

bool is_constant(const tensor::Tensor3& samples) {
  auto v = samples.values();
  return std::all_of(v.begin(), v.end(), [first = v[0]](float x) { return x == first; });
}

// 16-bit factor codes compress far better as two byte planes (low bytes, then high bytes):
// the high bytes of orthonormal-basis codes cluster around the middle of the range.
constexpr std::size_t kFactorPlanes = 2;

// The byte range of the factor codes inside a plain quantized brick, when they are 16-bit.
std::pair<std::size_t, std::size_t> factor_plane_range(std::span<const std::byte> plain, const quant::QuantScheme& scheme) {
  if (scheme.factor_bits != 16) return {plain.size(), plain.size()};
  const PayloadParts parts = payload_parts(plain, scheme, "zstd stage");
  return {plain.size() - parts.factor_bytes, plain.size()};
}

std::vector<std::byte> deflate_payload(const std::vector<std::byte>& plain, const quant::QuantScheme& scheme, int level) {
  std::vector<std::byte> shuffled(plain);
  auto [f0, f1] = factor_plane_range(plain, scheme);
  store::split_byte_planes(std::span(plain).subspan(f0, f1 - f0), std::span(shuffled).subspan(f0, f1 - f0), kFactorPlanes);
  return store::zstd_compress(shuffled, level);
}

}  // namespace

const char* target_kind_name(TargetKind kind) {
  switch (kind) {
    case TargetKind::none: return "none";
    case TargetKind::psnr: return "psnr";
    case TargetKind::rmse: return "rmse";
    case TargetKind::max_error: return "max_error";
  }
  return "?";
}

// A quantized brick is far below this (32^3 at f32 everywhere: 128 KiB plus factors).
constexpr std::uint64_t kMaxInflatedBrick = std::uint64_t(64) << 20;

std::span<const std::byte> plain_payload(store::PayloadKind kind, std::span<const std::byte> payload,
                                         const quant::QuantScheme& scheme, DecodeScratch& scratch,
                                         const std::string& context) {
  const store::PayloadKindTraits* traits = store::find_payload_kind(std::uint8_t(kind));
  const bool quantized = traits != nullptr && (traits->decoder == store::PayloadDecoder::tucker ||
                                               traits->decoder == store::PayloadDecoder::global_core);
  if (!quantized) throw Error(context + ": payload kind " + std::to_string(int(kind)) + " is not a Tucker brick");
  if (!traits->zstd) return payload;
  store::zstd_decompress(payload, kMaxInflatedBrick, scratch.inflated, context, "zstd payload");
  scratch.unshuffled = scratch.inflated;
  auto [f0, f1] = factor_plane_range(scratch.inflated, scheme);
  store::merge_byte_planes(std::span<const std::byte>(scratch.inflated).subspan(f0, f1 - f0),
                    std::span(scratch.unshuffled).subspan(f0, f1 - f0), kFactorPlanes);
  return scratch.unshuffled;
}

EncodedBrick encode_global_brick(const tensor::Tensor3& samples, const BrickBases& bases, const quant::QuantScheme& scheme,
                                 int zstd_level, tensor::Tensor3& core) {
  EncodedBrick out;
  core = tensor::Tensor3();
  if (is_constant(samples)) {
    out.kind = store::PayloadKind::constant;
    out.constant_value = samples.values()[0];
    return out;
  }
  const tensor::Tensor3 projected = project_brick(samples, bases);
  out.kind = store::PayloadKind::global_core;
  out.payload = quant::serialize(quant::quantize_core_only(projected, scheme), scheme);
  const quant::BrickView view(out.payload, scheme);
  core = tensor::Tensor3(projected.dims());
  view.dequantize_core(view.ranks(), core.values());
  const PayloadParts parts = payload_parts(out.payload, scheme, "encode");
  out.core_bytes = parts.core_bytes;
  out.header_bytes = parts.header_bytes;
  if (zstd_level > 0) {
    std::vector<std::byte> packed = deflate_payload(out.payload, scheme, zstd_level);
    if (packed.size() < out.payload.size()) {
      out.core_bytes = std::size_t(double(out.core_bytes) * double(packed.size()) / double(out.payload.size()));
      out.header_bytes = packed.size() - out.core_bytes;
      out.kind = store::PayloadKind::global_core_zstd;
      out.payload = std::move(packed);
    }
  }
  return out;
}

EncodedBrick encode_brick(const tensor::Tensor3& samples, const CodecParams& params) {
  EncodedBrick out;
  if (is_constant(samples)) {
    // Empty background is common (44% of ch2better's bricks): one value, no tensor.
    out.kind = store::PayloadKind::constant;
    out.constant_value = samples.values()[0];
    return out;
  }
  const int r = params.rank;
  const tensor::Ranks3 ranks{r, r, r};
  tensor::Tucker model = params.hooi_iterations > 0
                     ? tensor::hooi(samples, ranks, tensor::HooiOptions{params.hooi_tolerance, params.hooi_iterations, true})
                     : tensor::hosvd(samples, ranks);
  out.kind = store::PayloadKind::tucker;
  out.payload = quant::serialize(quant::quantize(model, params.quant), params.quant);
  const PayloadParts parts = payload_parts(out.payload, params.quant, "encode");
  out.core_bytes = parts.core_bytes;
  out.factor_bytes = parts.factor_bytes;
  out.header_bytes = parts.header_bytes;
  if (params.zstd_level > 0) {
    std::vector<std::byte> packed = deflate_payload(out.payload, params.quant, params.zstd_level);
    if (packed.size() < out.payload.size()) {
      // Attribute the saving to the parts in proportion, so `strata eval` still adds up.
      const double ratio = double(packed.size()) / double(out.payload.size());
      out.core_bytes = std::size_t(double(out.core_bytes) * ratio);
      out.factor_bytes = std::size_t(double(out.factor_bytes) * ratio);
      out.header_bytes = packed.size() - out.core_bytes - out.factor_bytes;
      out.kind = store::PayloadKind::tucker_zstd;
      out.payload = std::move(packed);
    }
  }
  // zstd level 0 asks for the plain fixed layout throughout (addressable in place), which a
  // packed lossless brick is not.
  if (!params.lossless_fallback || params.zstd_level == 0) return out;
  return lossless_if_smaller(std::move(out), samples.values(), int(samples.dims()[0]), params.zstd_level);
}

namespace {
EncodedBrick raw_packed_brick(std::vector<std::byte> payload) {
  EncodedBrick out;
  out.kind = store::PayloadKind::raw_packed;
  out.payload = std::move(payload);
  out.header_bytes = out.payload.size();
  return out;
}
}  // namespace

EncodedBrick lossless_if_smaller(EncodedBrick coded, std::span<const float> samples, int width, int zstd_level) {
  // Zstd rarely shrinks the codes of a brick the lossy coder finds hard by more than 2x: below
  // that the lossless brick is not tried, and most bricks skip its cost (first against one
  // byte per sample of the box, then against the coding's own width; 3% of the encoder's time
  // on fibsem_medulla_250 at --psnr 40 when every brick measured its coding).
  PackedBrickEncoder lossless(samples, width);
  if (coded.payload.size() * 2 < lossless.box_voxels()) return coded;
  if (coded.payload.size() * 2 < lossless.plain_bytes()) return coded;
  std::vector<std::byte> raw = lossless.encode(zstd_level);
  if (raw.size() >= coded.payload.size()) return coded;
  return raw_packed_brick(std::move(raw));
}

EncodedBrick lossless_brick(std::span<const float> samples, int width, int zstd_level) {
  return raw_packed_brick(encode_packed_brick(samples, width, zstd_level));
}

PayloadParts payload_parts(std::span<const std::byte> payload, const quant::QuantScheme& scheme,
                           const std::string& context) {
  return in_context(context, [&] {
    const quant::BrickView view(payload, scheme);
    PayloadParts p;
    const tensor::Ranks3& r = view.ranks();
    const tensor::Dims3& d = view.dims();
    p.core_bytes = quant::packed_size(std::size_t(r[0]) * r[1] * r[2], scheme.core_bits);
    p.factor_bytes = quant::packed_size(std::size_t(d[0] * r[0] + d[1] * r[1] + d[2] * r[2]), scheme.factor_bits);
    p.header_bytes = payload.size() - p.core_bytes - p.factor_bytes;
    return p;
  });
}

namespace {

// A global_core payload: its core at the leading ranks, and the first columns of the brick's
// row-block bases as the factors.
void dequantize_global_core(std::span<const std::byte> payload, const quant::QuantScheme& scheme, int brick_width,
                            int rank, const BrickBases* bases, quant::DequantizedModel& model) {
  if (!bases) throw Error("a global_core brick needs the volume's global bases");
  const quant::BrickView view(payload, scheme);
  if (view.dims() != tensor::Dims3{0, 0, 0}) throw Error("a global_core brick must be core-only (extents 0, 0, 0)");
  tensor::Ranks3 leading{};
  for (std::size_t n = 0; n < 3; ++n) {
    const tensor::Matrix<float>& q = *(*bases)[n];
    if (q.rows() != brick_width || view.ranks()[n] > q.cols())
      throw Error("core ranks " + tensor::to_string(tensor::Dims3{view.ranks()[0], view.ranks()[1], view.ranks()[2]}) +
                  " exceed the brick's bases (" + std::to_string(q.cols()) + " columns of " + std::to_string(q.rows()) + " rows)");
    leading[n] = std::min(rank, view.ranks()[n]);
  }
  quant::dequantize(view, leading, model);
  model.dims = {brick_width, brick_width, brick_width};
  for (std::size_t n = 0; n < 3; ++n) {
    const float* q = (*bases)[n]->data();  // column-major: the leading columns are contiguous
    model.factors[n].assign(q, q + std::size_t(brick_width) * std::size_t(leading[n]));
  }
}

// dequantize_brick for every kind but `masked`.
void dequantize_unmasked(store::PayloadKind kind, std::span<const std::byte> payload, const quant::QuantScheme& scheme,
                         int brick_width, int rank, DecodeScratch& scratch, quant::DequantizedModel& model,
                         const std::string& context, const BrickBases* bases) {
  const store::PayloadKindTraits* traits = store::find_payload_kind(std::uint8_t(kind));
  switch (traits != nullptr ? traits->decoder : store::PayloadDecoder::none) {
    case store::PayloadDecoder::global_core:
      in_context(context, [&] {
        dequantize_global_core(plain_payload(kind, payload, scheme, scratch, context), scheme, brick_width, rank, bases,
                               model);
      });
      return;
    case store::PayloadDecoder::coded_tucker:
      // The rank slider truncates at reconstruction (reconstruct_model): the model stays whole.
      quant::dequantize(quant::deserialize_coded(payload, brick_width, context), model);
      return;
    case store::PayloadDecoder::lossless:
      model = quant::DequantizedModel{};
      model.dims = {brick_width, brick_width, brick_width};
      model.samples.resize(std::size_t(brick_width) * std::size_t(brick_width) * std::size_t(brick_width));
      if (kind == store::PayloadKind::raw_zstd) decode_raw_brick(payload, model.samples, scratch.inflated, context);
      else decode_packed_brick(payload, brick_width, model.samples, scratch.inflated, context);
      return;
    case store::PayloadDecoder::tucker:
      in_context(context, [&] {
        // plain_payload's own errors already name `context`; they get it once more here.
        const quant::BrickView view(plain_payload(kind, payload, scheme, scratch, context), scheme);
        const tensor::Dims3& d = view.dims();
        if (d[0] != brick_width || d[1] != brick_width || d[2] != brick_width)
          throw Error("brick extents " + tensor::to_string(d) + " differ from the brick width " +
                      std::to_string(brick_width));
        const tensor::Ranks3& r = view.ranks();
        quant::dequantize(view, {std::min(rank, r[0]), std::min(rank, r[1]), std::min(rank, r[2])}, model);
      });
      return;
    case store::PayloadDecoder::none:
    case store::PayloadDecoder::masked: break;
  }
  throw Error(context + ": payload kind " + std::to_string(int(kind)) + " is not a Tucker brick");
}

}  // namespace

void dequantize_brick(store::PayloadKind kind, std::span<const std::byte> payload, const quant::QuantScheme& scheme,
                      int brick_width, int rank, DecodeScratch& scratch, quant::DequantizedModel& model,
                      const std::string& context, const BrickBases* bases) {
  if (kind != store::PayloadKind::masked) {
    dequantize_unmasked(kind, payload, scheme, brick_width, rank, scratch, model, context, bases);
    model.non_finite_index.clear();
    model.non_finite_value.clear();
    return;
  }
  const std::size_t voxels = std::size_t(brick_width) * std::size_t(brick_width) * std::size_t(brick_width);
  MaskedPayload masked = unwrap_masked(payload, voxels, scratch.inflated, context);
  if (masked.inner == store::PayloadKind::constant) {
    model = quant::DequantizedModel{};
    model.dims = {brick_width, brick_width, brick_width};
    model.offset = masked.inner_constant;  // no Tucker part: the reconstruction is the offset
  } else {
    dequantize_unmasked(masked.inner, masked.inner_payload, scheme, brick_width, rank, scratch, model, context, bases);
  }
  model.non_finite_index = std::move(masked.mask.index);
  model.non_finite_value = std::move(masked.mask.value);
}

void decode_brick(store::PayloadKind kind, std::span<const std::byte> payload, float constant_value,
                  const quant::QuantScheme& scheme, int brick_width, int rank, tensor::BrickReconstructor& reconstructor,
                  DecodeScratch& scratch, std::span<float> out, const std::string& context, const BrickBases* bases) {
  const std::size_t voxels = std::size_t(brick_width) * brick_width * brick_width;
  if (out.size() != voxels) throw Error(context + ": decode buffer holds " + std::to_string(out.size()) + " floats, brick needs " + std::to_string(voxels));
  if (kind == store::PayloadKind::constant) {
    std::fill(out.begin(), out.end(), constant_value);
    return;
  }
  dequantize_brick(kind, payload, scheme, brick_width, rank, scratch, scratch.model, context, bases);
  in_context(context, [&] { reconstruct_model(scratch.model, leading_ranks(scratch.model, rank), reconstructor, out); });
}

tensor::Ranks3 leading_ranks(const quant::DequantizedModel& model, int k) {
  const int kk = std::max(k, 1);
  return {std::min(kk, model.ranks[0]), std::min(kk, model.ranks[1]), std::min(kk, model.ranks[2])};
}

void reconstruct_model(const quant::DequantizedModel& model, const tensor::Ranks3& leading,
                       tensor::BrickReconstructor& reconstructor, std::span<float> out) {
  if (!model.samples.empty()) {
    if (out.size() != model.samples.size()) throw Error("reconstruct: buffer does not match the stored brick");
    std::copy(model.samples.begin(), model.samples.end(), out.begin());
  } else {
    if (model.has_tucker()) reconstructor.reconstruct(model.view(), leading, out);
    else std::fill(out.begin(), out.end(), 0.0f);
    // Quantized (fixed-rank) bricks carry neither: their samples stay exactly the kernel's.
    if (model.offset != 0)
      for (float& v : out) v += model.offset;
    if (leading == model.ranks)
      for (std::size_t i = 0; i < model.correction_index.size(); ++i)
        out[model.correction_index[i]] += model.correction_value[i];
  }
  for (std::size_t i = 0; i < model.non_finite_index.size(); ++i) {
    if (model.non_finite_index[i] >= out.size()) throw Error("reconstruct: a non-finite voxel lies outside the brick");
    out[model.non_finite_index[i]] = model.non_finite_value[i];
  }
}

}  // namespace strata::ta
