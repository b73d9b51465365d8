// Lossy behaviour on prisms 64^3 (brick 32, overlap 2, rank 16; paper 1 §3, §4, §6.2):
// the rank slider, the tensor-specific quantization, seams between bricks, and the per-brick
// culling metadata (min, max, 64-bin histogram) in the index.
#include <gtest/gtest.h>

#include <array>

#include <bit>
#include <map>

#include "strata/core/metrics.hpp"
#include "strata/quant/brick.hpp"
#include "ta/ta_test_util.hpp"
#include "support/test_support.hpp"

using namespace strata;
using namespace strata::ta;
using namespace strata::ta::testing;

namespace {

class TaQuality : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir;
    input_ = new Volume(prisms({64, 64, 64}, 2));
    // Plain payloads (no zstd stage) so sizes follow the code widths exactly; plus the default
    // configuration with the lossless zstd stage.
    for (const char* q : {"f32", "u16,b16lin", "u16,b8log+"}) compress(*input_, path(q), params(32, 2, 16, q, 1, 0));
    compress(*input_, zstd_path(), params(32, 2, 16, "u16,b8log+", 1, 3));
  }
  static void TearDownTestSuite() {
    delete input_;
    delete dir_;
  }
  static std::filesystem::path path(const std::string& quant) {
    std::string name = quant;
    for (char& c : name)
      if (c == ',' || c == '+') c = '_';
    return *dir_ / (name + ".strata");
  }
  static std::filesystem::path zstd_path() { return *dir_ / "zstd.strata"; }
  static double snr(const TaVolume& t, int k) {
    return compare_volumes(*input_, t.decode_box(0, Box::whole({64, 64, 64}), k)).snr_db;
  }
  static double bits_per_voxel(const std::string& quant) {
    return 8.0 * double(std::filesystem::file_size(path(quant))) / double(64 * 64 * 64);
  }

  static inline test::TempDir* dir_ = nullptr;
  static inline Volume* input_ = nullptr;
};

// Bin of a value, as the index defines it: 64 equal bins over metadata source.value_range.
int bin_of(double v, double lo, double hi) {
  const double scale = hi > lo ? 64.0 / (hi - lo) : 0.0;
  return int(std::clamp<std::int64_t>(std::int64_t((v - lo) * scale), 0, 63));
}

}  // namespace

TEST_F(TaQuality, LowerReconstructionRankLowersSnrStrictly) {
  const TaVolume t(path("f32"));
  const double s16 = snr(t, 16), s12 = snr(t, 12), s8 = snr(t, 8), s4 = snr(t, 4);
  EXPECT_GT(s16, s12);
  EXPECT_GT(s12, s8);
  EXPECT_GT(s8, s4);
  // Truncating the ordered core discards energy: a clearly visible step, not rounding noise.
  EXPECT_GT(s16 - s4, 3.0) << s16 << " " << s12 << " " << s8 << " " << s4;
  EXPECT_GT(s4, 10.0);  // even rank 4 keeps the smooth background
  // Same on the quantized file (the rank slider works on dequantized leading blocks).
  const TaVolume q(path("u16,b8log+"));
  const double q16 = snr(q, 16), q12 = snr(q, 12), q8 = snr(q, 8), q4 = snr(q, 4);
  EXPECT_GT(q16, q12);
  EXPECT_GT(q12, q8);
  EXPECT_GT(q8, q4);
}

TEST_F(TaQuality, RankAboveTheStoredRankClampsAndBelowOneClampsToOne) {
  const TaVolume t(path("u16,b8log+"));
  const Box box{{20, 20, 20}, {40, 40, 40}};
  EXPECT_EQ(t.decode_box(0, box, 40), t.decode_box(0, box, 16));
  EXPECT_EQ(t.decode_box(0, box, 17), t.decode_box(0, box, 16));
  EXPECT_EQ(t.decode_box(0, box, 0), t.decode_box(0, box, 1));
  EXPECT_FALSE(t.decode_box(0, box, 2) == t.decode_box(0, box, 1));
}

TEST_F(TaQuality, LogCoreWithHotCornerIsWithinAFractionOfADecibelOfFloat) {
  const double f = snr(TaVolume(path("f32")), 16);
  const double lin16 = snr(TaVolume(path("u16,b16lin")), 16);
  const double log8 = snr(TaVolume(path("u16,b8log+")), 16);
  // Paper 1 §6.2.2: U:16 B:8log+ matches the float decomposition closely.
  EXPECT_LE(std::abs(f - log8), 0.3) << "f32 " << f << " dB, u16,b8log+ " << log8 << " dB";
  EXPECT_LE(std::abs(f - lin16), 0.3) << "f32 " << f << " dB, u16,b16lin " << lin16 << " dB";
  EXPECT_GT(f, 15.0);  // ~20.6 dB for these data
}

TEST_F(TaQuality, BitsPerVoxelFollowTheCodeWidths) {
  const double f = bits_per_voxel("f32"), lin16 = bits_per_voxel("u16,b16lin"), log8 = bits_per_voxel("u16,b8log+");
  EXPECT_GT(f, lin16);
  EXPECT_GT(lin16, log8);
  // Cores dominate (R^3 vs 3BR codes): f32 -> 16-bit halves, 16-bit -> 8-bit cores cut ~1/3.
  EXPECT_NEAR(lin16 / f, 0.5, 0.05);
  EXPECT_NEAR(log8 / lin16, (4096.0 + 2 * 1536.0) / (2 * 4096.0 + 2 * 1536.0), 0.05);
  // Every tucker payload has exactly the size the scheme, brick width and rank imply.
  for (const char* q : {"f32", "u16,b16lin", "u16,b8log+"}) {
    const TaVolume t(path(q));
    const std::size_t expected = quant::serialized_size(t.quant_scheme(), {32, 32, 32}, {16, 16, 16});
    int tucker = 0;
    for (const auto& e : t.container().bricks()) {
      if (e.kind != store::PayloadKind::tucker) continue;
      ++tucker;
      EXPECT_EQ(e.size, expected) << q;
      EXPECT_EQ(e.offset % store::kPayloadAlignment, 0u);
    }
    EXPECT_EQ(tucker, 27 + 8 + 1) << q;  // prisms has no flat brick
  }
}

TEST_F(TaQuality, ZstdStageIsLosslessAndSmaller) {
  const TaVolume plain(path("u16,b8log+")), packed(zstd_path());
  EXPECT_LT(std::filesystem::file_size(zstd_path()), std::filesystem::file_size(path("u16,b8log+")));
  for (int k : {16, 5}) {
    const Box all = Box::whole({64, 64, 64});
    EXPECT_TRUE(plain.decode_box(0, all, k) == packed.decode_box(0, all, k)) << "rank " << k;
  }
  // Parents are built from identical decoded children, so coarser levels match too.
  EXPECT_TRUE(plain.decode_box(2, Box::whole({16, 16, 16}), 16) == packed.decode_box(2, Box::whole({16, 16, 16}), 16));
  int zstd_bricks = 0;
  for (const auto& e : packed.container().bricks()) {
    const store::BrickEntry* p = plain.container().find(e.key);
    ASSERT_NE(p, nullptr);
    EXPECT_EQ(p->kind, store::PayloadKind::tucker);
    EXPECT_TRUE(is_tucker(e.kind));
    zstd_bricks += e.kind == store::PayloadKind::tucker_zstd;
    if (e.kind == store::PayloadKind::tucker_zstd) {
      EXPECT_LT(e.size, p->size);
    }
    EXPECT_EQ(e.min, p->min);
    EXPECT_EQ(e.max, p->max);
    EXPECT_EQ(e.histogram, p->histogram);
  }
  EXPECT_GT(zstd_bricks, 0);
}

TEST_F(TaQuality, BoxesAcrossBrickSeamsEqualTheSameVoxelsOfAFullDecode) {
  const TaVolume t(path("u16,b8log+"));
  for (int k : {16, 5}) {
    const Volume full = t.decode_box(0, Box::whole({64, 64, 64}), k);
    // Cores are 28 wide: this box straddles x = 28, y = 56, z = 28 and z = 56.
    for (const Box& box : {Box{{20, 50, 10}, {40, 64, 60}}, Box{{27, 27, 27}, {29, 29, 29}},
                           Box{{55, 0, 56}, {64, 1, 57}}, Box{{63, 63, 63}, {64, 64, 64}}}) {
      const Volume part = t.decode_box(0, box, k);
      EXPECT_EQ(part.dims(), box.size());
      EXPECT_TRUE(part == full.crop(box)) << box.to_string() << " rank " << k;
    }
  }
  // Level 1 is 32^3 in 2x2x2 bricks (core 28).
  const Volume full1 = t.decode_box(1, Box::whole({32, 32, 32}), 16);
  const Box box1{{25, 3, 26}, {31, 30, 32}};
  EXPECT_TRUE(t.decode_box(1, box1, 16) == full1.crop(box1));
}

// Issue acceptance: one brick decoded on its own (TaVolume::decode_brick, overlap included)
// holds bit-exactly the voxels a full decode has in its sample region (edge-clamped).
TEST_F(TaQuality, OneBrickDecodedAloneEqualsTheSameRegionOfAFullDecode) {
  const TaVolume t(zstd_path());
  const Volume full = t.decode_box(0, Box::whole({64, 64, 64}), 16);
  tensor::BrickReconstructor reconstructor;
  DecodeScratch scratch;
  std::vector<float> brick(32 * 32 * 32);
  for (const auto& [bx, by, bz] : {std::array<int, 3>{1, 1, 1}, std::array<int, 3>{0, 2, 1}, std::array<int, 3>{2, 2, 2}}) {
    t.decode_brick({0, bx, by, bz}, 16, brick, reconstructor, scratch);
    const Box core = t.geometry().brick_core_box(0, bx, by, bz);
    auto view = full.view<float>();
    for (std::int64_t z = core.lo.z; z < core.hi.z; ++z)
      for (std::int64_t y = core.lo.y; y < core.hi.y; ++y)
        for (std::int64_t x = core.lo.x; x < core.hi.x; ++x) {
          const std::size_t local = std::size_t(((z - bz * 28 + 2) * 32 + (y - by * 28 + 2)) * 32 + (x - bx * 28 + 2));
          ASSERT_EQ(brick[local], view(x, y, z)) << bx << by << bz << " at " << x << "," << y << "," << z;
        }
  }
}

TEST_F(TaQuality, DecodeBoxRejectsBadLevelsAndBoxes) {
  const TaVolume t(path("u16,b8log+"));
  EXPECT_EQ(t.geometry().level_count(), 3);
  const std::string level = error_of([&] { t.decode_box(3, {{0, 0, 0}, {1, 1, 1}}, 16); });
  EXPECT_TRUE(contains(level, "level: 3 is not in 0..2")) << level;
  EXPECT_EQ(parameter_of([&] { t.decode_box(3, {{0, 0, 0}, {1, 1, 1}}, 16); }), "level");
  EXPECT_EQ(parameter_of([&] { t.decode_box(-1, {{0, 0, 0}, {1, 1, 1}}, 16); }), "level");
  EXPECT_EQ(parameter_of([&] { t.check_level(3); }), "level");
  EXPECT_NO_THROW(t.check_level(2));
  const std::string box = error_of([&] { t.decode_box(1, {{0, 0, 0}, {33, 1, 1}}, 16); });
  EXPECT_TRUE(contains(box, "box: ")) << box;
  EXPECT_EQ(parameter_of([&] { t.decode_box(1, {{0, 0, 0}, {33, 1, 1}}, 16); }), "box");
  EXPECT_EQ(parameter_of([&] { t.decode_box(0, {{-1, 0, 0}, {1, 1, 1}}, 16); }), "box");
  EXPECT_EQ(parameter_of([&] { t.decode_box(0, {{5, 0, 0}, {5, 1, 1}}, 16); }), "box");  // empty
}

TEST_F(TaQuality, IndexMinMaxAndHistogramCoverEveryDecodedVoxel) {
  const TaVolume t(path("u16,b8log+"));
  const double lo = t.value_min(), hi = t.value_max();
  const OctreeGeometry& g = t.geometry();
  tensor::BrickReconstructor reconstructor;
  DecodeScratch scratch;
  std::vector<float> brick(32 * 32 * 32);
  int checked = 0, partial_histograms = 0;
  for (const auto& e : t.container().bricks()) {
    t.decode_brick(e.key, t.rank(), brick, reconstructor, scratch);
    std::uint64_t decoded_bits = 0, all_bits = 0;
    float dlo = brick[0], dhi = brick[0];
    for (float v : brick) {
      decoded_bits |= std::uint64_t(1) << bin_of(v, lo, hi);
      dlo = std::min(dlo, v);
      dhi = std::max(dhi, v);
    }
    ASSERT_LE(e.min, dlo) << "level " << int(e.key.level) << " brick " << e.key.x << "," << e.key.y << "," << e.key.z;
    ASSERT_GE(e.max, dhi) << "level " << int(e.key.level) << " brick " << e.key.x << "," << e.key.y << "," << e.key.z;
    ASSERT_EQ(e.histogram & decoded_bits, decoded_bits)
        << "level " << int(e.key.level) << " brick " << e.key.x << "," << e.key.y << "," << e.key.z;
    all_bits = decoded_bits;
    if (e.key.level == 0) {
      // Level-0 bricks also cover the original samples of their (clamped) sample box, and
      // nothing else: no spurious bits or loose bounds.
      const Box s = g.brick_sample_box(0, e.key.x, e.key.y, e.key.z);
      float olo = dlo, ohi = dhi;
      for (std::int64_t z = s.lo.z; z < s.hi.z; ++z)
        for (std::int64_t y = s.lo.y; y < s.hi.y; ++y)
          for (std::int64_t x = s.lo.x; x < s.hi.x; ++x) {
            const double v = input_->value(std::clamp<std::int64_t>(x, 0, 63), std::clamp<std::int64_t>(y, 0, 63),
                                           std::clamp<std::int64_t>(z, 0, 63));
            ASSERT_GE(v, e.min);
            ASSERT_LE(v, e.max);
            all_bits |= std::uint64_t(1) << bin_of(v, lo, hi);
            olo = std::min(olo, float(v));
            ohi = std::max(ohi, float(v));
          }
      EXPECT_EQ(e.histogram & ~all_bits, 0u) << "spurious histogram bits";
      EXPECT_EQ(e.min, olo);
      EXPECT_EQ(e.max, ohi);
    }
    partial_histograms += std::popcount(e.histogram) < 64;
    ++checked;
  }
  EXPECT_EQ(checked, 36);
  EXPECT_GT(partial_histograms, 0);  // the histograms carry information (not all bits set)
}
