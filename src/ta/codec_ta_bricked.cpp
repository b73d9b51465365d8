// ta-bricked (paper 1): each brick its own Tucker model. Two registry entries share the name:
// at a fixed rank (quantized bricks, tucker / tucker_zstd) and to an error target (coded
// bricks, tucker_coded / raw_zstd). Both fall back to the lossless raw_packed brick and wrap
// bricks with NaN or infinite voxels (masked).
#include <string>

#include "strata/store/container.hpp"
#include "strata/ta/target_codec.hpp"
#include "ta/builtin_codecs.hpp"

namespace strata::ta {

namespace {

using store::PayloadKind;

class FixedRankRun final : public CodecRun {
 public:
  FixedRankRun(const BrickCodec& codec, const CodecParams& params, int brick)
      : CodecRun(codec), params_(params), brick_(brick) {}

  bool encode(const BrickJob& job, std::vector<float>& decoded, EncodedBrick& encoded,
              tensor::BrickReconstructor& reconstructor, DecodeScratch& scratch) const override {
    encoded = encode_brick(*job.samples, params_);
    const bool constant = encoded.kind == PayloadKind::constant;
    if (!constant || job.decoded_needed)
      decode_brick(encoded.kind, encoded.payload, encoded.constant_value, params_.quant, brick_, params_.rank,
                   reconstructor, scratch, decoded, "compress");
    return constant;
  }

 private:
  CodecParams params_;
  int brick_;
};

class FixedRankBricked final : public BrickCodec {
 public:
  std::string_view name() const override { return kBrickedCodecName; }
  CodecMode mode() const override { return CodecMode::fixed_rank; }
  std::string_view summary() const override { return "bases per brick (paper 1), the default"; }
  std::vector<PayloadKind> payload_kinds() const override {
    return {PayloadKind::constant, PayloadKind::tucker, PayloadKind::tucker_zstd, PayloadKind::raw_packed,
            PayloadKind::masked};
  }
  bool distributed() const override { return true; }
  std::unique_ptr<CodecRun> begin(const CodecSetup& setup) const override {
    return std::make_unique<FixedRankRun>(*this, setup.params.codec, setup.params.layout.brick);
  }
};

class ErrorTargetRun final : public CodecRun {
 public:
  using CodecRun::CodecRun;

  bool encode(const BrickJob& job, std::vector<float>& decoded, EncodedBrick& encoded, tensor::BrickReconstructor&,
              DecodeScratch&) const override {
    encoded = encode_brick_to_target(*job.samples, job.core, *job.target, decoded);
    return encoded.kind == PayloadKind::constant;
  }
};

class ErrorTargetBricked final : public BrickCodec {
 public:
  std::string_view name() const override { return kBrickedCodecName; }
  CodecMode mode() const override { return CodecMode::error_target; }
  std::string_view summary() const override {
    return "bases per brick coded to an error target: per-brick ranks, entropy-coded coefficients";
  }
  std::vector<PayloadKind> payload_kinds() const override {
    return {PayloadKind::constant, PayloadKind::tucker_coded, PayloadKind::raw_zstd, PayloadKind::raw_packed,
            PayloadKind::masked};
  }
  std::unique_ptr<CodecRun> begin(const CodecSetup&) const override { return std::make_unique<ErrorTargetRun>(*this); }
};

}  // namespace

std::unique_ptr<BrickCodec> fixed_rank_bricked_codec() { return std::make_unique<FixedRankBricked>(); }
std::unique_ptr<BrickCodec> error_target_bricked_codec() { return std::make_unique<ErrorTargetBricked>(); }

}  // namespace strata::ta
