// `strata eval`'s error report: level 0 against the original and every coarser level against
// the original box-filtered to it, streamed in slabs that must give the same figures as the
// whole pyramid held in memory.
#include <gtest/gtest.h>

#include "strata/core/metrics.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/ta/evaluate.hpp"
#include "support/test_support.hpp"
#include "ta/ta_test_util.hpp"

namespace strata::ta {
namespace {

// Odd extents at every level and a depth of several eval slabs (48 slices for core 12).
TEST(TaEvaluate, CoarseLevelsMatchTheWholePyramidInMemory) {
  test::TempDir dir;
  const Volume v = testing::prisms({37, 29, 101}, 4);
  io::write_volume(dir / "v.nrrd", v);
  for (const char* codec : {kBrickedCodecName, kGlobalCodecName}) {
    CompressParams p = testing::params(16, 2, 6, "u16,b8log+");
    p.codec_name = codec;
    testing::compress(v, dir / "v.strata", p);
    const TaVolume t(dir / "v.strata");
    ASSERT_GE(t.geometry().level_count(), 4);
    auto source = io::open_volume(dir / "v.nrrd");
    const ErrorReport r = error_report(t, *source, 6, true);
    ASSERT_EQ(r.coarse.size(), std::size_t(t.geometry().level_count() - 1));
    Volume reference = testing::as_f32(v);
    for (int l = 1; l < t.geometry().level_count(); ++l) {
      reference = testing::average_2x2x2(reference);
      const Extent d = t.geometry().level(l).dims;
      const ErrorMetrics want = compare_volumes(reference, t.decode_box(l, {{0, 0, 0}, d}, 6));
      const ErrorMetrics& got = r.coarse[std::size_t(l - 1)];
      EXPECT_NEAR(got.rmse, want.rmse, 1e-9 * (1 + want.rmse)) << "level " << l;
      EXPECT_NEAR(got.snr_db, want.snr_db, 1e-6) << "level " << l;
      EXPECT_EQ(got.max_abs_error, want.max_abs_error) << "level " << l;
      EXPECT_GT(got.rmse, 0) << "a lossy coarse level";
    }
  }
  // Without the flag only level 0 is measured.
  auto source = io::open_volume(dir / "v.nrrd");
  EXPECT_TRUE(error_report(TaVolume(dir / "v.strata"), *source, 6).coarse.empty());
}

}  // namespace
}  // namespace strata::ta
