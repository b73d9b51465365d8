// The brick-codec registry: the built-in entries, the one parameter check, and a codec that
// this file alone registers and runs through compress and the readers.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "strata/core/error.hpp"
#include "strata/ta/codec_registry.hpp"
#include "strata/ta/ta_volume.hpp"
#include "ta/ta_test_util.hpp"

namespace strata::ta {
namespace {

// A codec that stores every brick losslessly: level 0 decodes to the input exactly, and a
// coarse level to the 2x2x2 averages of the decoded level below.
class ToyLossless final : public BrickCodec {
 public:
  static constexpr const char* kName = "toy-lossless";
  std::string_view name() const override { return kName; }
  CodecMode mode() const override { return CodecMode::fixed_rank; }
  std::string_view summary() const override { return "every brick lossless (a test codec)"; }
  std::vector<store::PayloadKind> payload_kinds() const override {
    return {store::PayloadKind::constant, store::PayloadKind::raw_packed};
  }
  void validate(const CompressParams& params) const override {
    if (params.codec.zstd_level == 0) throw ParameterError("CodecParams::zstd_level", "toy-lossless needs zstd");
  }
  std::unique_ptr<CodecRun> begin(const CodecSetup& setup) const override {
    return std::make_unique<Run>(*this, setup.params);
  }

 private:
  class Run final : public CodecRun {
   public:
    Run(const BrickCodec& codec, const CompressParams& p) : CodecRun(codec), params_(p) {}
    bool encode(const BrickJob& job, std::vector<float>& decoded, EncodedBrick& encoded, tensor::BrickReconstructor&,
                DecodeScratch&) const override {
      const auto values = job.samples->values();
      decoded.assign(values.begin(), values.end());
      if (std::all_of(values.begin(), values.end(), [&](float v) { return v == values[0]; })) {
        encoded = EncodedBrick{};
        encoded.constant_value = values[0];
        return true;
      }
      encoded = lossless_brick(values, params_.layout.brick, params_.codec.zstd_level);
      return false;
    }

   private:
    CompressParams params_;
  };
};

void register_toy_once() {
  static const bool registered = [] {
    register_codec(std::make_unique<ToyLossless>());
    return true;
  }();
  (void)registered;
}

TEST(CodecRegistry, BuiltInEntriesHaveTheirModesAndKinds) {
  ASSERT_NE(find_codec(kBrickedCodecName, CodecMode::fixed_rank), nullptr);
  ASSERT_NE(find_codec(kBrickedCodecName, CodecMode::error_target), nullptr);
  ASSERT_NE(find_codec(kGlobalCodecName, CodecMode::fixed_rank), nullptr);
  EXPECT_EQ(find_codec(kGlobalCodecName, CodecMode::error_target), nullptr);
  EXPECT_TRUE(find_codec(kBrickedCodecName, CodecMode::fixed_rank)->distributed());
  EXPECT_FALSE(find_codec(kGlobalCodecName, CodecMode::fixed_rank)->distributed());
  EXPECT_FALSE(find_codec(kGlobalCodecName, CodecMode::fixed_rank)->stores_non_finite());
  const auto names = codec_names();
  EXPECT_EQ(std::count(names.begin(), names.end(), kBrickedCodecName), 1);  // two entries, one name
  EXPECT_TRUE(is_codec_name(kGlobalCodecName));
  EXPECT_FALSE(is_codec_name("zfp"));
}

TEST(CodecRegistry, ValidateNamesTheFieldOfEachRule) {
  const auto refused_field = [](const CompressParams& p) {
    try {
      validate(p);
    } catch (const ParameterError& e) {
      return e.parameter();
    }
    return std::string("accepted");
  };
  const CompressParams ok = testing::params(16, 2, 8, "u16,b8log+");
  EXPECT_EQ(refused_field(ok), "accepted");
  CompressParams p = ok;
  p.codec.rank = 17;
  EXPECT_EQ(refused_field(p), "CodecParams::rank");
  p = ok;
  p.codec.hooi_iterations = kMaxHooiIterations + 1;
  EXPECT_EQ(refused_field(p), "CodecParams::hooi_iterations");
  p.codec.hooi_iterations = kMaxHooiIterations;
  EXPECT_EQ(refused_field(p), "accepted");
  p = ok;
  p.codec.zstd_level = kMaxZstdLevel + 1;
  EXPECT_EQ(refused_field(p), "CodecParams::zstd_level");
  p = ok;
  p.codec.target.coarse_growth = 0.5;  // checked with or without a target
  EXPECT_EQ(refused_field(p), "ErrorTarget::coarse_growth");
  p = ok;
  p.codec.target = {TargetKind::rmse, 1e-200};
  EXPECT_EQ(refused_field(p), "ErrorTarget::value");
  p.codec.target = {TargetKind::psnr, 40};
  EXPECT_EQ(refused_field(p), "accepted");
  p.codec.quant = quant::QuantScheme::parse("f32");  // a target chooses its own precision
  EXPECT_EQ(refused_field(p), "CodecParams::quant");
  p = ok;
  p.codec_name = "zfp";
  EXPECT_EQ(refused_field(p), "CompressParams::codec_name");
  p.codec_name = kGlobalCodecName;
  p.codec.target = {TargetKind::psnr, 40};
  EXPECT_EQ(refused_field(p), "CompressParams::codec_name");  // ta-global has no error-target entry
  p = ok;
  p.layout.overlap = 8;
  EXPECT_EQ(refused_field(p), "BrickLayout::overlap");
}

TEST(CodecRegistry, UnknownCodecMessageListsTheRegisteredNames) {
  CompressParams p = testing::params(16, 2, 8, "u16,b8log+");
  p.codec_name = "zfp";
  try {
    validate(p);
    FAIL() << "accepted";
  } catch (const ParameterError& e) {
    const std::string what = e.what();
    for (const std::string& name : codec_names()) EXPECT_NE(what.find("\"" + name + "\""), std::string::npos) << what;
  }
}

TEST(CodecRegistry, ADuplicateEntryIsRefused) {
  register_toy_once();
  EXPECT_THROW(register_codec(std::make_unique<ToyLossless>()), Error);
  EXPECT_THROW(register_codec(nullptr), Error);
}

TEST(CodecRegistry, ACodecRegisteredByATestRunsThroughCompressAndTheReaders) {
  register_toy_once();
  ASSERT_TRUE(is_codec_name(ToyLossless::kName));
  test::TempDir dir;
  const Volume v = testing::prisms({40, 36, 30}, 5);
  CompressParams p = testing::params(16, 2, 8, "u16,b8log+");
  p.codec_name = ToyLossless::kName;
  testing::compress(v, dir / "toy.strata", p);

  const TaVolume t(dir / "toy.strata");
  EXPECT_EQ(t.codec_name(), ToyLossless::kName);
  EXPECT_EQ(t.container().metadata()["codec"], ToyLossless::kName);
  std::size_t lossless = 0;
  for (const store::BrickEntry& e : t.container().bricks()) {
    EXPECT_TRUE(e.kind == store::PayloadKind::constant || e.kind == store::PayloadKind::raw_packed)
        << store::payload_kind_name(e.kind);
    lossless += e.kind == store::PayloadKind::raw_packed;
  }
  EXPECT_GT(lossless, 0u);
  // Level 0 is the input, exactly; level 1 the 2x2x2 means of it.
  const Volume level0 = t.decode_box(0, Box::whole(v.dims()), t.rank());
  const Volume original = testing::as_f32(v);
  ASSERT_EQ(level0.dims(), original.dims());
  EXPECT_EQ(std::memcmp(level0.bytes(), original.bytes(), original.byte_size()), 0);
  const Volume level1 = t.decode_box(1, Box::whole(t.geometry().level(1).dims), t.rank());
  const Volume expected1 = testing::average_2x2x2(original);
  ASSERT_EQ(level1.dims(), expected1.dims());
  const auto got = level1.samples<float>(), want = expected1.samples<float>();
  // The compressor averages in float (three roundings), the reference in double.
  for (std::size_t i = 0; i < want.size(); ++i)
    ASSERT_NEAR(got[i], want[i], 4 * std::numeric_limits<float>::epsilon() * std::max(1.0f, std::abs(want[i])))
        << "voxel " << i;
}

TEST(CodecRegistry, ACodecsOwnRuleIsPartOfValidate) {
  register_toy_once();
  CompressParams p = testing::params(16, 2, 8, "u16,b8log+", 1, 0);
  p.codec_name = ToyLossless::kName;
  try {
    validate(p);
    FAIL() << "accepted";
  } catch (const ParameterError& e) {
    EXPECT_EQ(e.parameter(), "CodecParams::zstd_level");
  }
  // A toy codec has no error-target entry: the message names the codecs that have one.
  p.codec.zstd_level = 3;
  p.codec.target = {TargetKind::psnr, 40};
  try {
    validate(p);
    FAIL() << "accepted";
  } catch (const ParameterError& e) {
    EXPECT_NE(std::string(e.what()).find(kBrickedCodecName), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace strata::ta
