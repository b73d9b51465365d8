// ta-global (paper 2): one set of mipmapped factor matrices for the whole volume, fitted before
// the first brick, a quantized core per brick projected on its level's row-block bases, and the
// feature-scale table (each brick's RMSE at the ranks of a ladder) the error-driven LOD reads.
#include <algorithm>
#include <span>

#include "strata/core/error.hpp"
#include "strata/store/container.hpp"
#include "strata/ta/global_basis.hpp"
#include "ta/builtin_codecs.hpp"

namespace strata::ta {

namespace {

using store::PayloadKind;

std::span<const std::byte> as_bytes(const std::vector<float>& v) {
  return {reinterpret_cast<const std::byte*>(v.data()), v.size() * sizeof(float)};
}

class GlobalRun final : public CodecRun {
 public:
  GlobalRun(const BrickCodec& codec, const CodecSetup& setup) : CodecRun(codec), geometry_(setup.geometry) {
    const CompressParams& params = setup.params;
    quant_ = params.codec.quant;
    zstd_level_ = params.codec.zstd_level;
    GlobalFitOptions o = params.global;
    o.rank = params.codec.rank;
    o.slab_bytes = setup.slab_bytes;
    fit_ = fit_global_factors(setup.source, o, setup.progress);
    bases_ = std::make_unique<GlobalBases>(fit_.factors, geometry_);
    ladder_ = feature_scale_ladder(std::min({bases_->rank(1), bases_->rank(2), bases_->rank(3)}));
    // Constant bricks are exact at every rank: their rows stay 0.
    table_.assign(std::size_t(geometry_.total_bricks()) * ladder_.size(), 0.0f);
  }

  bool encode(const BrickJob& job, std::vector<float>& decoded, EncodedBrick& encoded,
              tensor::BrickReconstructor& reconstructor, DecodeScratch& scratch) const override {
    const tensor::Tensor3& samples = *job.samples;
    const BrickBases bases = bases_->brick_bases(job.level, job.bx, job.by, job.bz);
    tensor::Tensor3 core;
    encoded = encode_global_brick(samples, bases, quant_, zstd_level_, core);
    const bool constant = encoded.kind == PayloadKind::constant;
    if (!constant) store_rank_errors(job, samples, core, bases);
    const int brick = geometry_.layout().brick;
    if (!constant || job.decoded_needed)
      decode_brick(encoded.kind, encoded.payload, encoded.constant_value, quant_, brick, brick, reconstructor, scratch,
                   decoded, "compress", &bases);
    return constant;
  }

  void finish(store::ContainerWriter& writer, nlohmann::json& metadata, CompressReport& report) const override {
    writer.add_section("global_bases", bases_->serialize());
    writer.add_section("feature_scale", as_bytes(table_));
    // Cores only: no per-brick HOOI; `quant` is the cores' scheme, `zstd_level` their zstd stage.
    metadata.erase("hooi_iterations");
    metadata["global"] = {{"ranks", {bases_->rank(1), bases_->rank(2), bases_->rank(3)}},
                          {"ladder", ladder_},
                          {"fit", fit_.fit()},
                          {"sweeps", fit_.fit_per_sweep.size()}};
    report.global_fit = fit_.fit_per_sweep;
    report.global_seconds = fit_.seconds;
  }

 private:
  // The brick's row of the feature-scale table: the RMSE of its core region at each rank of the
  // ladder. Level 0 is the original; a coarse level is measured against the original's cells.
  // Each brick owns its row, so concurrent bricks write apart.
  void store_rank_errors(const BrickJob& job, const tensor::Tensor3& samples, const tensor::Tensor3& core,
                         const BrickBases& bases) const {
    const Box region{{job.core.lo[0], job.core.lo[1], job.core.lo[2]}, {job.core.hi[0], job.core.hi[1], job.core.hi[2]}};
    std::vector<double> errors;
    if (job.level == 0) {
      errors = rank_ladder_rmse(samples, core, bases, region, ladder_);
    } else {
      tensor::Tensor3 means(samples.dim(1), samples.dim(2), samples.dim(3));
      const double variance = job.reference(means);
      errors = rank_ladder_rmse(means, core, bases, region, ladder_, variance);
    }
    float* row = table_.data() + std::ptrdiff_t(geometry_.brick_ordinal(job.level, job.bx, job.by, job.bz)) *
                                     std::ptrdiff_t(ladder_.size());
    for (std::size_t i = 0; i < errors.size(); ++i) row[i] = float(errors[i]);
  }

  const OctreeGeometry& geometry_;
  quant::QuantScheme quant_;
  int zstd_level_ = 0;
  GlobalFit fit_;
  std::unique_ptr<GlobalBases> bases_;
  std::vector<int> ladder_;
  mutable std::vector<float> table_;  // rows of ladder_.size() floats, in octree order (brick_ordinal)
};

class GlobalCodec final : public BrickCodec {
 public:
  std::string_view name() const override { return kGlobalCodecName; }
  CodecMode mode() const override { return CodecMode::fixed_rank; }
  std::string_view summary() const override {
    return "one set of global bases for the volume, a core per brick and a feature-scale table (paper 2; fixed rank, "
           "--quant applies to the cores)";
  }
  std::vector<PayloadKind> payload_kinds() const override {
    return {PayloadKind::constant, PayloadKind::global_core, PayloadKind::global_core_zstd};
  }
  bool stores_non_finite() const override { return false; }
  bool needs_feature_reference() const override { return true; }
  // Core-only bricks: the scheme's factor part is unused (f32 stores no factor parameters).
  CompressParams normalized(const CompressParams& params) const override {
    CompressParams p = params;
    p.codec.quant.factor_coding = quant::FactorCoding::f32;
    p.codec.quant.factor_bits = 32;
    return p;
  }
  std::unique_ptr<CodecRun> begin(const CodecSetup& setup) const override {
    return std::make_unique<GlobalRun>(*this, setup);
  }
};

}  // namespace

std::unique_ptr<BrickCodec> global_codec() { return std::make_unique<GlobalCodec>(); }

}  // namespace strata::ta
