#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>

#include "strata/core/dtype.hpp"
#include "strata/core/error.hpp"
#include "strata/core/extent.hpp"
#include "strata/core/memory.hpp"
#include "strata/core/metrics.hpp"
#include "strata/core/progress.hpp"
#include "strata/core/statistics.hpp"
#include "strata/core/threads.hpp"
#include "strata/core/volume.hpp"
#include "support/test_support.hpp"

using namespace strata;

TEST(CoreDType, ParsesNamesAndRejectsUnknown) {
  EXPECT_EQ(parse_dtype("uint16"), DType::u16);
  EXPECT_EQ(parse_dtype("F32"), DType::f32);
  EXPECT_EQ(parse_dtype("double"), DType::f64);
  try {
    parse_dtype("complex", "sidecar.json: dtype");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("sidecar.json: dtype"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("complex"), std::string::npos);
  }
  for (DType t : kAllDTypes) EXPECT_EQ(parse_dtype(dtype_name(t)), t);
}

TEST(CoreExtent, ParsesSizesAndBoxes) {
  EXPECT_EQ(parse_extent("64"), (Extent{64, 64, 64}));
  EXPECT_EQ(parse_extent("1024,1024,512"), (Extent{1024, 1024, 512}));
  EXPECT_EQ(parse_extent("3x4x5"), (Extent{3, 4, 5}));
  EXPECT_THROW(parse_extent("3,4"), Error);
  EXPECT_THROW(parse_extent("0,4,4"), Error);
  EXPECT_THROW(parse_extent("4,,4"), Error);
  Box b = parse_box("1,2,3:4,6,8");
  EXPECT_EQ(b.size(), (Extent{3, 4, 5}));
  EXPECT_EQ(b.voxel_count(), 60);
  EXPECT_THROW(parse_box("4,2,3:1,6,8"), Error);
  EXPECT_EQ(Box::whole({10, 10, 10}).intersect(parse_box("5,5,5:20,20,20")).size(), (Extent{5, 5, 5}));
}

TEST(CoreVolume, CropAndConvert) {
  Volume v({4, 3, 2}, DType::i16);
  auto view = v.view<std::int16_t>();
  for (int z = 0; z < 2; ++z)
    for (int y = 0; y < 3; ++y)
      for (int x = 0; x < 4; ++x) view(x, y, z) = std::int16_t(x + 10 * y + 100 * z - 50);
  Volume c = v.crop({{1, 1, 1}, {3, 3, 2}});
  EXPECT_EQ(c.dims(), (Extent{2, 2, 1}));
  EXPECT_EQ(c.value(0, 0, 0), 1 + 10 + 100 - 50);
  EXPECT_EQ(c.value(1, 1, 0), 2 + 20 + 100 - 50);
  EXPECT_THROW(v.view<float>(), Error);
  Volume u8 = v.converted(DType::u8);  // negative values clamp to 0, not wrap
  EXPECT_EQ(u8.value(0, 0, 0), 0);
  EXPECT_EQ(u8.value(3, 2, 1), 3 + 20 + 100 - 50);
}

TEST(CoreMetrics, MatchPaperDefinitions) {
  // A = [3, 4] (rms = sqrt(12.5)), Ã = [3, 5]: rmse = sqrt(0.5), SNR = 20 log10(5) = 13.979 dB.
  Volume a({2, 1, 1}, DType::f32), b({2, 1, 1}, DType::f32);
  a.set_value(0, 0, 0, 3); a.set_value(1, 0, 0, 4);
  b.set_value(0, 0, 0, 3); b.set_value(1, 0, 0, 5);
  ErrorMetrics m = compare_volumes(a, b);
  EXPECT_NEAR(m.signal_rms, std::sqrt(12.5), 1e-12);
  EXPECT_NEAR(m.rmse, std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(m.snr_db, 20 * std::log10(5.0), 1e-9);
  EXPECT_NEAR(m.psnr_db, 20 * std::log10(1.0 / std::sqrt(0.5)), 1e-9);  // range 1
  EXPECT_NEAR(m.nrmse, std::sqrt(0.5), 1e-12);
  EXPECT_EQ(m.max_abs_error, 1.0);
  EXPECT_TRUE(std::isinf(compare_volumes(a, a).snr_db));
  EXPECT_DOUBLE_EQ(bits_per_voxel(1000, 4000), 2.0);
}

// NaN and infinities are left out of the figures and counted: alike in both volumes (NaN and
// NaN, +inf and +inf) or not (NaN against a value, +inf against -inf). The figures are those of
// the finite pairs, A = [3, 4] and Ã = [3, 5] as above.
TEST(CoreMetrics, NonFiniteVoxelsAreCountedApart) {
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  const std::array<double, 7> av{3, nan, 4, inf, nan, 1, inf}, bv{3, nan, 5, inf, 2, nan, -inf};
  Volume a({7, 1, 1}, DType::f64), b({7, 1, 1}, DType::f32);
  for (std::size_t i = 0; i < av.size(); ++i) {
    a.samples<double>()[i] = av[i];
    b.samples<float>()[i] = float(bv[i]);
  }
  const ErrorMetrics m = compare_volumes(a, b);
  EXPECT_EQ(m.voxel_count, 2u);
  EXPECT_EQ(m.masked_matched, 2u);     // NaN-NaN, +inf-+inf
  EXPECT_EQ(m.masked_mismatched, 3u);  // NaN-2, 1-NaN, +inf--inf
  EXPECT_NEAR(m.rmse, std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(m.snr_db, 20 * std::log10(5.0), 1e-9);
  EXPECT_EQ(m.max_abs_error, 1.0);
  EXPECT_EQ(m.value_min, 3.0);
  EXPECT_EQ(m.value_max, 4.0);
  // Merged accumulators add their counts.
  ErrorAccumulator first, second;
  first.add(a.crop(Box{{0, 0, 0}, {3, 1, 1}}), b.crop(Box{{0, 0, 0}, {3, 1, 1}}));
  second.add(a.crop(Box{{3, 0, 0}, {7, 1, 1}}), b.crop(Box{{3, 0, 0}, {7, 1, 1}}));
  first.merge(second);
  EXPECT_EQ(first.result().masked_matched, 2u);
  EXPECT_EQ(first.result().masked_mismatched, 3u);
  EXPECT_EQ(first.result().voxel_count, 2u);
}

TEST(CoreMetrics, SlabAccumulationEqualsWhole) {
  Volume a({8, 8, 8}, DType::u8), b({8, 8, 8}, DType::f32);
  for (int i = 0; i < 512; ++i) {
    a.samples<std::uint8_t>()[i] = std::uint8_t((i * 37) % 251);
    b.samples<float>()[i] = float((i * 37) % 251) + float((i % 7) - 3) * 0.25f;
  }
  ErrorAccumulator acc;
  for (int z = 0; z < 8; z += 3) {
    Box slab{{0, 0, z}, {8, 8, std::min(8, z + 3)}};
    acc.add(a.crop(slab), b.crop(slab));
  }
  ErrorMetrics whole = compare_volumes(a, b), parts = acc.result();
  EXPECT_NEAR(whole.snr_db, parts.snr_db, 1e-9);
  EXPECT_EQ(whole.max_abs_error, parts.max_abs_error);
  EXPECT_EQ(parts.voxel_count, 512u);
}

TEST(CoreStatistics, LabelsAndRanges) {
  Volume v({10, 10, 10}, DType::u32);
  auto s = v.samples<std::uint32_t>();
  for (std::size_t i = 0; i < s.size(); ++i) s[i] = (i % 4 == 0) ? std::uint32_t(1 + i % 7) : 0u;
  VolumeStatistics st = compute_statistics(v);
  EXPECT_EQ(st.voxel_count, 1000u);
  EXPECT_EQ(st.min, 0);
  ASSERT_TRUE(st.distinct_values.has_value());
  EXPECT_EQ(*st.distinct_values, 8u);  // 0 and 1..7 (i%4==0 reaches every residue mod 7)
  EXPECT_DOUBLE_EQ(st.zero_fraction, 0.75);
  std::uint64_t total = 0;
  for (auto c : st.histogram) total += c;
  EXPECT_EQ(total, 1000u);

  Volume w({300, 1, 1}, DType::u16);
  for (int x = 0; x < 300; ++x) w.set_value(x, 0, 0, 40000 + x);
  VolumeStatistics ws = compute_statistics(w);
  EXPECT_EQ(*ws.distinct_values, 300u);
  EXPECT_EQ(ws.min, 40000);
  EXPECT_EQ(ws.max, 40299);
  EXPECT_EQ(ws.histogram[0], 19u);  // values 40000..40018 fall in the first of 16 bins of 299/16
}

TEST(CoreThreads, CountIsConfigurable) {
  set_thread_count(1);
  EXPECT_EQ(thread_count(), 1);
  set_thread_count(0);
  EXPECT_GE(thread_count(), 1);
}

// The library refuses counts the runtimes cannot start (one past the cap), whoever asks, and
// keeps the count it had.
TEST(CoreThreads, CountAboveTheCapIsRefusedAndChangesNothing) {
  EXPECT_EQ(max_thread_count(), kMaxThreadsPerHardwareThread * hardware_threads());
  set_thread_count(1);
  EXPECT_THROW(set_thread_count(max_thread_count() + 1), Error);
  EXPECT_EQ(thread_count(), 1);
  set_thread_count(max_thread_count());
  EXPECT_EQ(thread_count(), max_thread_count());
  set_thread_count(0);
  EXPECT_EQ(thread_count(), hardware_threads());
}

TEST(CoreMemory, PhysicalMemoryIsReported) {
  // Every Linux machine this runs on has at least 64 MiB and fewer than 2^50 bytes.
  EXPECT_GT(physical_memory_bytes(), std::uint64_t(64) << 20);
  EXPECT_LT(physical_memory_bytes(), std::uint64_t(1) << 50);
}

// More distinct 32-bit values than the tracking cap: the counts seen before the overflow stay
// exact and only the rest is sampled, so a uniform stream (every value once, in two slabs)
// still gives a flat histogram. The sampled share is thinned evenly: each bin of it is off by
// at most a couple of strides, far below 0.5% of a bin.
TEST(CoreStatistics, DistinctOverflowKeepsTheHistogram) {
  const std::int64_t n = std::int64_t(StatisticsAccumulator::kDistinctCap) + (1 << 20);
  const std::int64_t half = n / 2;
  StatisticsAccumulator acc;
  for (std::int64_t start : {std::int64_t(0), half}) {
    const std::int64_t count = start == 0 ? half : n - half;
    Volume slab({count, 1, 1}, DType::u32);
    auto s = slab.samples<std::uint32_t>();
    for (std::int64_t i = 0; i < count; ++i) s[std::size_t(i)] = std::uint32_t(start + i);
    acc.add(slab);
  }
  const VolumeStatistics st = acc.result();
  EXPECT_FALSE(st.distinct_values.has_value());
  std::uint64_t total = 0;
  for (std::uint64_t b : st.histogram) {
    EXPECT_NEAR(double(b), double(n) / 16.0, 0.005 * double(n) / 16.0);
    total += b;
  }
  EXPECT_NEAR(double(total), double(n), 1e-3 * double(n));
}

TEST(CoreProgress, ModeNamesParseAndOthersNameTheParameter) {
  EXPECT_EQ(parse_progress_mode("json"), ProgressMode::json);
  EXPECT_EQ(parse_progress_mode("none"), ProgressMode::silent);
  EXPECT_EQ(test::error_of([] { parse_progress_mode("loud"); }),
            "progress_mode: expected auto, bar, json or none, got 'loud'");
  EXPECT_EQ(test::parameter_of([] { parse_progress_mode("loud"); }), "progress_mode");
}
