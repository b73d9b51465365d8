// The global-basis codec (ta-global, paper 2) end to end: every brick decodes to its samples
// projected on its stored row-block bases (exactly, with float cores; within the quantization
// otherwise), lower ranks use the leading columns, the feature-scale table holds each brick's
// error, the LOD loader decodes the same samples, and damaged or unsupported input is refused
// by name.
#include <gtest/gtest.h>

#include <cmath>

#include "strata/core/error.hpp"
#include "strata/lod/brick_decode.hpp"
#include "strata/ta/compress.hpp"
#include "strata/ta/ta_volume.hpp"
#include "strata/tensor/ttm.hpp"
#include "ta/ta_test_util.hpp"

namespace strata::ta {
namespace {

CompressParams global_params(int rank, const std::string& quant) {
  CompressParams p = testing::params(16, 2, rank, quant);
  p.codec_name = kGlobalCodecName;
  return p;
}

// Brick (0, bx, by, bz)'s samples of `v` (overlap included, clamped at the edges).
tensor::Tensor3 samples_of(const Volume& v, const OctreeGeometry& g, std::int64_t bx, std::int64_t by, std::int64_t bz) {
  const Box box = g.brick_sample_box(0, bx, by, bz);
  const int b = g.layout().brick;
  const Volume f = testing::as_f32(v);
  const auto view = f.view<float>();
  tensor::Tensor3 out(b, b, b);
  const Extent d = v.dims();
  for (int z = 0; z < b; ++z)
    for (int y = 0; y < b; ++y)
      for (int x = 0; x < b; ++x)
        out(x, y, z) = view(std::clamp<std::int64_t>(box.lo.x + x, 0, d.x - 1), std::clamp<std::int64_t>(box.lo.y + y, 0, d.y - 1),
                            std::clamp<std::int64_t>(box.lo.z + z, 0, d.z - 1));
  return out;
}

// The brick rebuilt from the leading k columns of its bases and the leading k^3 block of `core`.
tensor::Tensor3 rebuild(const tensor::Tensor3& core, const BrickBases& q, int k) {
  tensor::Tensor3 leading(k, k, k);
  for (int c = 0; c < k; ++c)
    for (int b = 0; b < k; ++b)
      for (int a = 0; a < k; ++a) leading(a, b, c) = core(a, b, c);
  return tensor::reconstruct(leading, tensor::Factors<float>{q[0]->leftCols(k), q[1]->leftCols(k), q[2]->leftCols(k)});
}

TEST(TaGlobalCodec, FloatCoresDecodeToTheProjectionAtEveryRank) {
  test::TempDir dir;
  const Volume v = testing::prisms({40, 36, 30}, 3);
  const auto path = dir / "g.strata";
  const CompressReport report = testing::compress(v, path, global_params(8, "f32"));
  ASSERT_FALSE(report.global_fit.empty());
  const TaVolume t(path);
  ASSERT_TRUE(t.global());
  EXPECT_EQ(t.container().metadata()["codec"], "ta-global");
  EXPECT_EQ(t.feature_scale_ladder(), (std::vector<int>{2, 4, 6, 8}));
  const auto [lo, hi] = testing::value_range(v);
  const double tolerance = 1e-5 * (hi - lo);  // float products of B = 16 terms, thrice
  tensor::BrickReconstructor reconstructor;
  DecodeScratch scratch;
  std::vector<float> decoded(16 * 16 * 16);
  const Extent grid = t.geometry().level(0).bricks;
  int coded = 0;
  for (std::int64_t bz = 0; bz < grid.z; ++bz)
    for (std::int64_t by = 0; by < grid.y; ++by)
      for (std::int64_t bx = 0; bx < grid.x; ++bx) {
        const store::BrickKey key{0, std::int32_t(bx), std::int32_t(by), std::int32_t(bz)};
        if (t.entry(key).kind == store::PayloadKind::constant) continue;
        ASSERT_TRUE(t.entry(key).kind == store::PayloadKind::global_core ||
                    t.entry(key).kind == store::PayloadKind::global_core_zstd);
        ++coded;
        const BrickBases q = t.brick_bases(key);
        const tensor::Tensor3 samples = samples_of(v, t.geometry(), bx, by, bz);
        const tensor::Tensor3 core = tensor::project(samples, tensor::Factors<float>{*q[0], *q[1], *q[2]});
        for (int k : {8, 3}) {
          t.decode_brick(key, k, decoded, reconstructor, scratch);
          const tensor::Tensor3 expected = rebuild(core, q, k);
          double worst = 0;
          for (std::size_t i = 0; i < decoded.size(); ++i)
            worst = std::max(worst, double(std::abs(decoded[i] - expected.data()[i])));
          EXPECT_LT(worst, tolerance) << "brick " << bx << "," << by << "," << bz << " rank " << k;
        }
        // The table's last entry is the decoded brick's RMSE over its core region.
        t.decode_brick(key, 8, decoded, reconstructor, scratch);
        const Box inner = t.geometry().brick_core_box(0, bx, by, bz);
        double sum = 0;
        for (std::int64_t z = 0; z < inner.size().z; ++z)
          for (std::int64_t y = 0; y < inner.size().y; ++y)
            for (std::int64_t x = 0; x < inner.size().x; ++x) {
              const double d = decoded[std::size_t(((z + 2) * 16 + y + 2) * 16 + x + 2)] - samples(x + 2, y + 2, z + 2);
              sum += d * d;
            }
        const auto errors = t.rank_errors(key);
        ASSERT_EQ(errors.size(), 4u);
        EXPECT_NEAR(errors.back(), std::sqrt(sum / double(inner.size().voxel_count())), 1e-3 * (1 + errors.back()));
        for (std::size_t i = 1; i < errors.size(); ++i) EXPECT_GE(errors[i - 1], errors[i]);
        // The LOD loader's path decodes the same samples.
        std::uint64_t read = 0;
        const lod::BrickModel model = lod::fetch_model(t, t.entry(key), scratch, read);
        std::vector<float> via_lod(decoded.size());
        lod::reconstruct_at_rank(*model, 8, reconstructor, via_lod);
        EXPECT_EQ(via_lod, decoded);
      }
  EXPECT_GT(coded, 10);
}

// Coarse rows of the feature-scale table measure a brick against the original (paper 2 §4.2):
// each decoded level-l voxel stands for its 2^l-wide cell of original voxels, and the table's
// full-rank entry is the RMSE of that cell-wise upsampling over the core. Extents divisible by
// 4 keep every cell whole at levels 1 and 2.
TEST(TaGlobalCodec, CoarseRowsAreTheErrorAgainstTheOriginal) {
  test::TempDir dir;
  const Volume v = testing::prisms({48, 40, 32}, 5);
  const auto path = dir / "g.strata";
  testing::compress(v, path, global_params(8, "f32"));
  const TaVolume t(path);
  ASSERT_GE(t.geometry().level_count(), 3);
  const Volume f = testing::as_f32(v);
  const auto original = f.view<float>();
  tensor::BrickReconstructor reconstructor;
  DecodeScratch scratch;
  std::vector<float> decoded(16 * 16 * 16);
  int checked = 0;
  for (int level = 1; level <= 2; ++level) {
    const Extent grid = t.geometry().level(level).bricks;
    const std::int64_t cell = std::int64_t(1) << level;
    for (std::int32_t bz = 0; bz < grid.z; ++bz)
      for (std::int32_t by = 0; by < grid.y; ++by)
        for (std::int32_t bx = 0; bx < grid.x; ++bx) {
          const store::BrickKey key{std::uint8_t(level), bx, by, bz};
          if (t.entry(key).kind == store::PayloadKind::constant) continue;
          t.decode_brick(key, 8, decoded, reconstructor, scratch);
          const Box core = t.geometry().brick_core_box(level, bx, by, bz);
          double sum = 0, sum_against_means = 0;
          for (std::int64_t z = core.lo.z; z < core.hi.z; ++z)
            for (std::int64_t y = core.lo.y; y < core.hi.y; ++y)
              for (std::int64_t x = core.lo.x; x < core.hi.x; ++x) {
                const std::size_t local = std::size_t(((z - core.lo.z + 2) * 16 + (y - core.lo.y + 2)) * 16 + (x - core.lo.x + 2));
                const double rebuilt = decoded[local];
                double mean = 0;
                for (std::int64_t k = 0; k < cell; ++k)
                  for (std::int64_t j = 0; j < cell; ++j)
                    for (std::int64_t i = 0; i < cell; ++i) {
                      const double o = original(x * cell + i, y * cell + j, z * cell + k);
                      sum += (o - rebuilt) * (o - rebuilt);
                      mean += o;
                    }
                mean /= double(cell * cell * cell);
                sum_against_means += (mean - rebuilt) * (mean - rebuilt) * double(cell * cell * cell);
              }
          const double fine_voxels = double(core.size().voxel_count() * cell * cell * cell);
          const double rmse = std::sqrt(sum / fine_voxels);
          const auto errors = t.rank_errors(key);
          EXPECT_NEAR(errors.back(), rmse, 1e-3 * (1 + rmse)) << "level " << level << " brick " << bx << "," << by << "," << bz;
          // The prisms' edges make the within-cell variance count: measured against the cell
          // means alone the error would be smaller.
          if (sum > 1.01 * sum_against_means) ++checked;
        }
  }
  EXPECT_GT(checked, 3);
}

// The zstd stage is lossless: the same samples with and without it, in fewer bytes.
TEST(TaGlobalCodec, ZstdCoresDecodeToTheSameSamples) {
  test::TempDir dir;
  const Volume v = testing::prisms({40, 36, 30}, 3);
  CompressParams plain = global_params(8, "u16,b8log+");
  plain.codec.zstd_level = 0;
  CompressParams packed = plain;
  packed.codec.zstd_level = 9;
  const CompressReport a = testing::compress(v, dir / "a.strata", plain), b = testing::compress(v, dir / "b.strata", packed);
  EXPECT_LT(b.file_bytes, a.file_bytes);
  const TaVolume ta(dir / "a.strata"), tb(dir / "b.strata");
  int zstd = 0;
  for (const store::BrickEntry& e : tb.container().bricks()) zstd += e.kind == store::PayloadKind::global_core_zstd;
  EXPECT_GT(zstd, 0);
  for (int level = 0; level < ta.geometry().level_count(); ++level) {
    const Box whole = Box::whole(ta.geometry().level(level).dims);
    EXPECT_EQ(ta.decode_box(level, whole, 8), tb.decode_box(level, whole, 8)) << level;
  }
}

TEST(TaGlobalCodec, QuantizedCoresStayWithinTheCoreStepAndTheFileIsSmaller) {
  test::TempDir dir;
  const Volume v = testing::prisms({40, 36, 30}, 3);
  testing::compress(v, dir / "f.strata", global_params(8, "f32"));
  const CompressReport q = testing::compress(v, dir / "q.strata", global_params(8, "u16,b8log+"));
  const TaVolume exact(dir / "f.strata"), quantized(dir / "q.strata");
  EXPECT_EQ(quantized.quant_name(), "f32,b8log+");  // cores only: the factor part is unused
  const Volume a = exact.decode_box(0, Box::whole(v.dims()), 8), b = quantized.decode_box(0, Box::whole(v.dims()), 8);
  const auto [lo, hi] = testing::value_range(v);
  // 8-bit logarithmic cores: a few percent of the range at worst, far from exact, far from noise.
  const testing::MaxDiff d = testing::max_abs_diff(a, b);
  EXPECT_GT(d.value, 0.0);
  EXPECT_LT(d.value, 0.1 * (hi - lo));
  EXPECT_LT(q.file_bytes, std::filesystem::file_size(dir / "f.strata") / 2);
}

TEST(TaGlobalCodec, UnsupportedInputAndDamageAreNamed) {
  test::TempDir dir;
  CompressParams target = global_params(8, "u16,b8log+");
  target.codec.target = {TargetKind::psnr, 40};
  EXPECT_EQ(test::parameter_of([&] { testing::compress(testing::prisms({20, 20, 20}), dir / "t.strata", target); }),
            "CompressParams::codec_name");
  Volume nan(Extent{20, 20, 20}, DType::f32);
  nan.view<float>()(3, 4, 5) = std::nanf("");
  EXPECT_NE(test::error_of([&] { testing::compress(nan, dir / "n.strata", global_params(8, "u16,b8log+")); })
                .find("does not store NaN"),
            std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(dir / "n.strata"));

  const auto path = dir / "g.strata";
  testing::compress(testing::prisms({40, 36, 30}, 3), path, global_params(8, "u16,b8log+"));
  auto bytes = testing::file_bytes(path);
  const store::ContainerReader reader(path);
  const auto offset = reader.metadata()["sections"]["global_bases"]["offset"].get<std::size_t>();
  bytes[offset + 100] ^= 1;
  std::ofstream(dir / "bad.strata", std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
  const std::string message = test::error_of([&] { TaVolume(dir / "bad.strata"); });
  EXPECT_NE(message.find("section global_bases"), std::string::npos) << message;
  EXPECT_NE(message.find("checksum mismatch"), std::string::npos) << message;
}

}  // namespace
}  // namespace strata::ta
