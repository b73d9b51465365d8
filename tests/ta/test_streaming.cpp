// The compressor streams: the output depends only on the samples and the parameters, not on
// the input format, the thread count or the run.
#include <gtest/gtest.h>

#include <map>

#include "strata/core/threads.hpp"
#include "strata/store/container.hpp"
#include "ta/ta_test_util.hpp"
#include "support/test_support.hpp"

using namespace strata;
using namespace strata::ta;
using namespace strata::ta::testing;
namespace fs = std::filesystem;

namespace {

// Restores the default thread count when a test ends (also on failure).
struct ThreadCount {
  explicit ThreadCount(int n) { set_thread_count(n); }
  ~ThreadCount() { set_thread_count(0); }
};

CompressReport compress_file(const fs::path& in, const fs::path& out, const CompressParams& p) {
  auto source = io::open_volume(in);
  return compress_volume(*source, out, p, silent_progress());
}

// Everything a reader can observe, independent of where payloads sit in the file: metadata,
// and per brick key its kind, min, max, histogram and payload bytes.
struct Content {
  nlohmann::json metadata;
  std::map<std::tuple<int, int, int, int>, std::tuple<int, float, float, std::uint64_t, std::vector<std::byte>>> bricks;
  bool operator==(const Content&) const = default;
};

Content content_of(const fs::path& p) {
  store::ContainerReader r(p);
  Content c{r.metadata(), {}};
  for (const auto& e : r.bricks()) {
    auto bytes = r.payload(e);
    c.bricks[{e.key.level, e.key.x, e.key.y, e.key.z}] = {int(e.kind), e.min, e.max, e.histogram,
                                                          std::vector<std::byte>(bytes.begin(), bytes.end())};
  }
  return c;
}

// 30x28x40 u16 prisms, brick 16 overlap 2 (core 12): 30x28x40, 15x14x20, 8x7x10, so
// 3x3x4 + 2x2x2 + 1 bricks over three levels.
const CompressParams kParams = params(16, 2, 8, "u16,b8log+", 2);

}  // namespace

TEST(TaStreaming, RawAndNrrdSourcesGiveTheSameFile) {
  test::TempDir dir;
  const Volume v = prisms({30, 28, 40}, 21);
  io::write_volume(dir / "v.raw", v);
  io::write_volume(dir / "v.nrrd", v);  // gzip-encoded: read through a decoded temporary
  ThreadCount one(1);
  const CompressReport a = compress_file(dir / "v.raw", dir / "a.strata", kParams);
  const CompressReport b = compress_file(dir / "v.nrrd", dir / "b.strata", kParams);
  const CompressReport c = compress(v, dir / "c.strata", kParams);  // straight from memory
  EXPECT_EQ(a.file_bytes, b.file_bytes);
  EXPECT_TRUE(file_bytes(dir / "a.strata") == file_bytes(dir / "b.strata"));
  EXPECT_TRUE(file_bytes(dir / "a.strata") == file_bytes(dir / "c.strata"));
  EXPECT_EQ(a.levels.size(), 3u);
}

TEST(TaStreaming, OneSliceSlabsGiveTheSameFileAsOneSlab) {
  test::TempDir dir;
  const Volume v = prisms({30, 28, 40}, 25);
  const OctreeGeometry g(v.dims(), kParams.layout);
  // The smallest memory limit the compressor accepts: its input slabs shrink to one slice.
  CompressParams tight = kParams;
  std::uint64_t lo = 0, hi = 1ull << 34;
  while (lo + 1 < hi) {
    tight.memory_limit = (lo + hi) / 2;
    (error_of([&] { input_slab_bytes(g, v.info(), tight); }).empty() ? hi : lo) = tight.memory_limit;
  }
  tight.memory_limit = hi;
  ASSERT_EQ(input_slab_bytes(g, v.info(), tight), v.info().bytes_per_slice());
  EXPECT_GE(input_slab_bytes(g, v.info(), kParams), v.info().byte_size());  // default: one slab
  tight.memory_limit = lo;
  EXPECT_EQ(parameter_of([&] { compress(v, dir / "x.strata", tight); }), "CompressParams::memory_limit");
  tight.memory_limit = hi;

  ThreadCount one(1);
  compress(v, dir / "one_slab.strata", kParams);
  compress(v, dir / "slices.strata", tight);
  EXPECT_TRUE(file_bytes(dir / "one_slab.strata") == file_bytes(dir / "slices.strata"));
}

TEST(TaStreaming, CodecOutputIsTheSameForOneAndTwoThreads) {
  test::TempDir dir;
  const Volume v = prisms({30, 28, 40}, 22);
  {
    ThreadCount one(1);
    compress(v, dir / "t1.strata", kParams);
  }
  {
    ThreadCount two(2);
    compress(v, dir / "t2.strata", kParams);
    compress(v, dir / "t2b.strata", kParams);
  }
  const Content c1 = content_of(dir / "t1.strata");
  EXPECT_EQ(c1.bricks.size(), 36u + 8u + 1u);
  EXPECT_TRUE(c1 == content_of(dir / "t2.strata"));
  EXPECT_TRUE(c1 == content_of(dir / "t2b.strata"));
}

TEST(TaStreaming, OneThreadRunsAreByteIdentical) {
  test::TempDir dir;
  const Volume v = prisms({30, 28, 40}, 23);
  ThreadCount one(1);
  compress(v, dir / "a.strata", kParams);
  compress(v, dir / "b.strata", kParams);
  EXPECT_TRUE(file_bytes(dir / "a.strata") == file_bytes(dir / "b.strata"));
}

// Reproducible builds: the same input and parameters give the same file bytes whatever the
// thread count (so files can be compared by checksum). Payloads and index entries must not be
// laid out in the order worker threads happen to finish. The input makes that order
// predictable: brick rows of two bricks, the first a costly HOOI, the second constant; with
// two threads the constant brick of a row tends to finish (and used to be written) first.
TEST(TaStreaming, FileBytesDoNotDependOnTheThreadCount) {
  test::TempDir dir;
  Volume v = prisms({56, 28, 112}, 24);
  auto s = v.view<std::uint16_t>();
  for (std::int64_t z = 0; z < 112; ++z)
    for (std::int64_t y = 0; y < 28; ++y)
      for (std::int64_t x = 26; x < 56; ++x) s(x, y, z) = 1000;  // bricks (1,0,z) sample x >= 26
  const CompressParams p = params(32, 2, 16, "u16,b8log+", 10);
  {
    ThreadCount one(1);
    compress(v, dir / "t1.strata", p);
  }
  {
    store::ContainerReader r(dir / "t1.strata");
    for (int z = 0; z < 4; ++z) {
      ASSERT_EQ(r.find({0, 1, 0, z})->kind, store::PayloadKind::constant);
      ASSERT_TRUE(is_tucker(r.find({0, 0, 0, z})->kind));
    }
  }
  ThreadCount two(2);
  for (int run = 0; run < 2; ++run) {  // the first run also starts the second worker thread
    const std::filesystem::path t2 = dir / ("t2_" + std::to_string(run) + ".strata");
    compress(v, t2, p);
    EXPECT_TRUE(content_of(dir / "t1.strata") == content_of(t2));
    EXPECT_TRUE(file_bytes(dir / "t1.strata") == file_bytes(t2)) << "run " << run;
  }
}
