#include "strata/quant/brick.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "strata/core/bytes.hpp"
#include "strata/core/error.hpp"
#include "strata/quant/bitpack.hpp"
#include "strata/quant/quantizers.hpp"
#include "strata/tensor/ttm.hpp"
#include "quant/decode_kernel.hpp"

namespace strata::quant {
namespace {

constexpr std::size_t kHeaderBytes = 6 * sizeof(std::uint16_t);
constexpr std::int64_t kMaxExtent = 65535;  // u16 in the header

void check_scheme(const QuantScheme& s) {
  const bool factors_ok = s.factor_coding == FactorCoding::f32 ? s.factor_bits == 32
                                                                : (s.factor_bits == 8 || s.factor_bits == 16);
  const bool core_ok = s.core_coding == CoreCoding::f32
                           ? s.core_bits == 32 && !s.hot_corner_float
                           : (s.core_bits == 8 || s.core_bits == 12 || s.core_bits == 16);
  const bool mu_ok = s.core_coding != CoreCoding::mulaw || (std::isfinite(s.mu) && s.mu > 0);
  if (!factors_ok || !core_ok || !mu_ok) throw Error("quantization scheme \"" + s.to_string() + "\" is inconsistent");
}

// The parameters a scheme stores, in serialization order (at most 7; no allocation, since a
// view is built per decoded brick).
struct ParamList {
  std::array<float BrickParams::*, 7> fields{};
  std::size_t count = 0;
  void add(float BrickParams::*field) { fields[count++] = field; }
  std::size_t size() const { return count; }
  auto begin() const { return fields.begin(); }
  auto end() const { return fields.begin() + std::ptrdiff_t(count); }
};

ParamList stored_params(const QuantScheme& s) {
  ParamList list;
  if (s.factor_coding == FactorCoding::linear) {
    list.add(&BrickParams::factor_lo);
    list.add(&BrickParams::factor_hi);
  }
  if (s.core_coding == CoreCoding::linear) {
    list.add(&BrickParams::core_lo);
    list.add(&BrickParams::core_hi);
  }
  if (s.core_coding == CoreCoding::log || s.core_coding == CoreCoding::mulaw) list.add(&BrickParams::core_max_abs);
  if (s.core_coding == CoreCoding::mulaw) list.add(&BrickParams::mu);
  if (s.hot_corner_float) list.add(&BrickParams::hot_corner);
  return list;
}

std::size_t core_count(const tensor::Ranks3& r) { return std::size_t(r[0]) * std::size_t(r[1]) * std::size_t(r[2]); }
std::size_t factor_count(const tensor::Dims3& d, const tensor::Ranks3& r) {
  return std::size_t(d[0] * r[0] + d[1] * r[1] + d[2] * r[2]);
}
// Index of U^(mode)'s first code in the concatenated factor stream.
std::size_t factor_offset(const tensor::Dims3& d, const tensor::Ranks3& r, int mode) {
  std::size_t offset = 0;
  for (int n = 0; n < mode - 1; ++n) offset += std::size_t(d[std::size_t(n)] * r[std::size_t(n)]);
  return offset;
}

// Extents {0, 0, 0} mark a core-only brick (the global-basis codec keeps its bases elsewhere).
bool core_only(const tensor::Dims3& d) { return d[0] == 0 && d[1] == 0 && d[2] == 0; }

void check_shape(const tensor::Dims3& d, const tensor::Ranks3& r, const char* context) {
  if (core_only(d)) {
    for (std::size_t n = 0; n < 3; ++n)
      if (r[n] < 1 || r[n] > kMaxExtent)
        throw Error(std::string(context) + ": a core-only brick needs ranks in [1, 65535], got " + std::to_string(r[0]) +
                    "," + std::to_string(r[1]) + "," + std::to_string(r[2]));
    return;
  }
  for (std::size_t n = 0; n < 3; ++n) {
    if (d[n] < 1 || d[n] > kMaxExtent || r[n] < 1 || r[n] > d[n]) {
      throw Error(std::string(context) + ": extents must be in [1, 65535] and ranks in [1, extent], got " +
                  tensor::to_string(d) + " with ranks " + std::to_string(r[0]) + "," + std::to_string(r[1]) + "," +
                  std::to_string(r[2]));
    }
  }
}

void check_finite(std::span<const float> values, const char* what) {
  for (float v : values)
    if (!std::isfinite(v)) throw Error(std::string("quantize: non-finite value in the ") + what);
}

// ---- encoding -------------------------------------------------------------------------------

template <class Quantizer>
void encode_all(std::span<const float> values, const Quantizer& q, std::uint32_t* codes) {
  for (std::size_t i = 0; i < values.size(); ++i) codes[i] = q.encode(values[i]);
}

void encode_floats(std::span<const float> values, std::uint32_t* codes) {
  for (std::size_t i = 0; i < values.size(); ++i) codes[i] = std::bit_cast<std::uint32_t>(values[i]);
}

void quantize_factors(const tensor::Tucker& model, const QuantScheme& s, QuantizedBrick& q) {
  q.factor_codes.resize(factor_count(q.dims, q.ranks));
  for (const auto& u : model.factors) check_finite({u.data(), std::size_t(u.size())}, "factor matrices");
  std::uint32_t* codes = q.factor_codes.data();
  if (s.factor_coding == FactorCoding::f32) {
    for (const auto& u : model.factors) {
      encode_floats({u.data(), std::size_t(u.size())}, codes);
      codes += u.size();
    }
    return;
  }
  // One min/max pair for all three matrices (paper §4.1): one range for the decoder to load.
  q.params.factor_lo = std::numeric_limits<float>::max();
  q.params.factor_hi = std::numeric_limits<float>::lowest();
  for (const auto& u : model.factors) {
    q.params.factor_lo = std::min(q.params.factor_lo, u.minCoeff());
    q.params.factor_hi = std::max(q.params.factor_hi, u.maxCoeff());
  }
  const LinearQuantizer linear(q.params.factor_lo, q.params.factor_hi, s.factor_bits);
  for (const auto& u : model.factors) {
    encode_all({u.data(), std::size_t(u.size())}, linear, codes);
    codes += u.size();
  }
}

// Range over the coded core coefficients: all of them, or all but the hot corner.
void core_range(std::span<const float> coded, float& lo, float& hi, float& max_abs) {
  lo = hi = max_abs = 0;
  if (coded.empty()) return;
  const auto [mn, mx] = std::minmax_element(coded.begin(), coded.end());
  lo = *mn, hi = *mx;
  max_abs = std::max(std::abs(lo), std::abs(hi));
}

void quantize_core(const tensor::Tucker& model, const QuantScheme& s, QuantizedBrick& q) {
  const std::span<const float> values = model.core.values();
  check_finite(values, "core");
  q.core_codes.resize(values.size());
  if (s.core_coding == CoreCoding::f32) return encode_floats(values, q.core_codes.data());

  const std::size_t first = s.hot_corner_float ? 1 : 0;
  BrickParams& p = q.params;
  if (s.hot_corner_float) p.hot_corner = values[0];
  core_range(values.subspan(first), p.core_lo, p.core_hi, p.core_max_abs);
  auto encode_with = [&](const auto& quantizer) {
    encode_all(values, quantizer, q.core_codes.data());
    if (s.hot_corner_float) q.core_codes[0] = quantizer.encode(0.0f);  // decoders restore the float
  };
  switch (s.core_coding) {
    case CoreCoding::linear:
      p.core_max_abs = 0;
      return encode_with(LinearQuantizer(p.core_lo, p.core_hi, s.core_bits));
    case CoreCoding::log:
      p.core_lo = p.core_hi = 0;
      return encode_with(LogQuantizer(p.core_max_abs, s.core_bits));
    case CoreCoding::mulaw:
      p.core_lo = p.core_hi = 0;
      p.mu = s.mu;
      return encode_with(MuLawQuantizer(p.core_max_abs, p.mu, s.core_bits));
    case CoreCoding::f32: break;
  }
}

// ---- validation of stored parameters (they come from a file) -------------------------------

void check_params(const QuantScheme& s, const BrickParams& p) {
  for (auto field : stored_params(s))
    if (!std::isfinite(p.*field)) throw Error("quantized brick: non-finite parameter");
  if (s.factor_coding == FactorCoding::linear && p.factor_hi < p.factor_lo)
    throw Error("quantized brick: factor range has max < min");
  if (s.core_coding == CoreCoding::linear && p.core_hi < p.core_lo) throw Error("quantized brick: core range has max < min");
  if (s.core_coding == CoreCoding::mulaw && !(p.mu > 0)) throw Error("quantized brick: mu must be positive");
  if ((s.core_coding == CoreCoding::log || s.core_coding == CoreCoding::mulaw) && (p.core_max_abs < 0 || p.core_max_abs > 1e38f))
    throw Error("quantized brick: core max |b| out of range");
}

}  // namespace

QuantizedBrick quantize(const tensor::Tucker& model, const QuantScheme& scheme) {
  check_scheme(scheme);
  QuantizedBrick q;
  q.dims = model.dims();
  q.ranks = model.ranks();
  check_shape(q.dims, q.ranks, "quantize");
  for (std::size_t n = 0; n < 3; ++n) {
    if (model.factors[n].cols() != q.ranks[n]) throw Error("quantize: factor U" + std::to_string(n + 1) + " does not match the core");
  }
  quantize_factors(model, scheme, q);
  quantize_core(model, scheme, q);
  return q;
}

QuantizedBrick quantize_core_only(const tensor::Tensor3& core, const QuantScheme& scheme) {
  check_scheme(scheme);
  QuantizedBrick q;
  q.ranks = {int(core.dim(1)), int(core.dim(2)), int(core.dim(3))};
  check_shape(q.dims, q.ranks, "quantize_core_only");
  tensor::Tucker model;
  model.core = core;
  quantize_core(model, scheme, q);
  return q;
}

std::size_t serialized_size(const QuantScheme& scheme, const tensor::Dims3& dims, const tensor::Ranks3& ranks) {
  check_scheme(scheme);
  return kHeaderBytes + stored_params(scheme).size() * sizeof(float) + packed_size(core_count(ranks), scheme.core_bits) +
         packed_size(factor_count(dims, ranks), scheme.factor_bits);
}

std::vector<std::byte> serialize(const QuantizedBrick& brick, const QuantScheme& scheme) {
  check_shape(brick.dims, brick.ranks, "serialize");
  if (brick.core_codes.size() != core_count(brick.ranks) || brick.factor_codes.size() != factor_count(brick.dims, brick.ranks)) {
    throw Error("serialize: code counts do not match the extents and ranks");
  }
  std::vector<std::byte> out(serialized_size(scheme, brick.dims, brick.ranks));
  std::size_t at = 0;
  for (auto v : brick.dims) store_field(out, std::exchange(at, at + 2), std::uint16_t(v));
  for (auto v : brick.ranks) store_field(out, std::exchange(at, at + 2), std::uint16_t(v));
  for (auto field : stored_params(scheme)) store_field(out, std::exchange(at, at + 4), brick.params.*field);
  std::byte* p = out.data() + at;
  const std::size_t core_bytes = packed_size(brick.core_codes.size(), scheme.core_bits);
  pack_codes(brick.core_codes, scheme.core_bits, {p, core_bytes});
  p += core_bytes;
  pack_codes(brick.factor_codes, scheme.factor_bits, {p, std::size_t(out.data() + out.size() - p)});
  return out;
}

BrickView::BrickView(std::span<const std::byte> bytes, const QuantScheme& scheme) : scheme_(scheme) {
  check_scheme(scheme);
  if (bytes.size() < kHeaderBytes) {
    throw FormatError("quantized brick", "header", "needs 12 bytes, got " + std::to_string(bytes.size()));
  }
  ByteReader header(bytes, "quantized brick");
  for (auto& v : dims_) v = header.get<std::uint16_t>("dims");
  for (auto& v : ranks_) v = header.get<std::uint16_t>("ranks");
  check_shape(dims_, ranks_, "quantized brick header");
  const std::size_t expected = serialized_size(scheme, dims_, ranks_);
  if (bytes.size() != expected) {
    throw FormatError("quantized brick", "size",
                      "scheme " + scheme.to_string() + " with extents " + tensor::to_string(dims_) + " needs " +
                          std::to_string(expected) + " bytes, got " + std::to_string(bytes.size()));
  }
  for (auto field : stored_params(scheme)) params_.*field = header.get<float>("parameters");
  check_params(scheme, params_);
  core_ = bytes.data() + header.position();
  factors_ = core_ + packed_size(core_count(ranks_), scheme.core_bits);
}

void BrickView::dequantize_core(const tensor::Ranks3& k, std::span<float> out) const {
  for (std::size_t n = 0; n < 3; ++n) {
    if (k[n] < 1 || k[n] > ranks_[n]) throw Error("dequantize_core: leading ranks must be in [1, R]");
  }
  if (out.size() != core_count(k)) throw Error("dequantize_core: output size does not match the leading ranks");
  detail::DecodeJob job;
  job.coding = scheme_.core_coding;
  job.bits = scheme_.core_bits;
  job.lo = params_.core_lo, job.hi = params_.core_hi;
  job.max_abs = params_.core_max_abs, job.mu = params_.mu;
  job.stream = core_;
  // Rows of K1 codes are contiguous in the stored R1 x R2 x R3 core.
  job.count = std::size_t(k[0]);
  job.rows2 = k[1], job.rows3 = k[2];
  job.stride2 = std::size_t(ranks_[0]);
  job.stride3 = std::size_t(ranks_[0]) * std::size_t(ranks_[1]);
  job.out = out.data();
  detail::decode_codes(job);
  if (scheme_.hot_corner_float) out[0] = params_.hot_corner;
}

void BrickView::dequantize_factor(int mode, int leading, std::span<float> out) const {
  tensor::check_mode(mode, "dequantize_factor");
  if (core_only(dims_)) throw Error("dequantize_factor: a core-only brick has no factors");
  const std::size_t n = std::size_t(mode - 1);
  if (leading < 1 || leading > ranks_[n]) throw Error("dequantize_factor: leading rank must be in [1, R]");
  const std::size_t count = std::size_t(dims_[n]) * std::size_t(leading);  // the first columns are contiguous
  if (out.size() != count) throw Error("dequantize_factor: output size does not match I_n x K");
  detail::DecodeJob job;
  job.coding = scheme_.factor_coding == FactorCoding::f32 ? CoreCoding::f32 : CoreCoding::linear;
  job.bits = scheme_.factor_bits;
  job.lo = params_.factor_lo, job.hi = params_.factor_hi;
  job.stream = factors_;
  job.first = factor_offset(dims_, ranks_, mode);
  job.count = count;
  job.out = out.data();
  detail::decode_codes(job);
}

tensor::TuckerView DequantizedModel::view() const {
  tensor::TuckerView v;
  v.core = core.data();
  v.ranks = ranks;
  for (std::size_t n = 0; n < 3; ++n) v.factors[n] = factors[n].data();
  v.dims = dims;
  return v;
}

void dequantize(const BrickView& brick, const tensor::Ranks3& leading, DequantizedModel& out) {
  out.dims = brick.dims();
  out.ranks = leading;
  out.offset = 0;
  out.correction_index.clear();
  out.correction_value.clear();
  out.samples.clear();
  out.core.resize(core_count(leading));
  brick.dequantize_core(leading, out.core);
  if (core_only(out.dims)) return;  // the caller supplies the factors
  for (int mode = 1; mode <= 3; ++mode) {
    auto& f = out.factors[std::size_t(mode - 1)];
    f.resize(std::size_t(out.dims[std::size_t(mode - 1)]) * std::size_t(leading[std::size_t(mode - 1)]));
    brick.dequantize_factor(mode, leading[std::size_t(mode - 1)], f);
  }
}

tensor::Tucker dequantize(const QuantizedBrick& brick, const QuantScheme& scheme) {
  const std::vector<std::byte> bytes = serialize(brick, scheme);
  const BrickView view(bytes, scheme);
  tensor::Tucker t;
  t.core = tensor::Tensor3(brick.ranks[0], brick.ranks[1], brick.ranks[2]);
  view.dequantize_core(brick.ranks, t.core.values());
  for (int mode = 1; mode <= 3; ++mode) {
    const std::size_t n = std::size_t(mode - 1);
    t.factors[n].resize(brick.dims[n], brick.ranks[n]);
    view.dequantize_factor(mode, brick.ranks[n], {t.factors[n].data(), std::size_t(t.factors[n].size())});
  }
  t.fit = std::numeric_limits<double>::quiet_NaN();
  return t;
}

QuantizedBrick deserialize(std::span<const std::byte> bytes, const QuantScheme& scheme) {
  const BrickView view(bytes, scheme);
  QuantizedBrick q;
  q.dims = view.dims();
  q.ranks = view.ranks();
  q.params = view.params();
  q.core_codes.resize(core_count(q.ranks));
  q.factor_codes.resize(factor_count(q.dims, q.ranks));
  const std::size_t core_bytes = packed_size(q.core_codes.size(), scheme.core_bits);
  const std::byte* core = bytes.data() + kHeaderBytes + stored_params(scheme).size() * sizeof(float);
  unpack_codes({core, core_bytes}, scheme.core_bits, q.core_codes);
  unpack_codes({core + core_bytes, bytes.data() + bytes.size()}, scheme.factor_bits, q.factor_codes);
  return q;
}

}  // namespace strata::quant
