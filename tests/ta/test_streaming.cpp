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

// 40x36x50 u16 prisms, brick 16 overlap 2 (core 12): 40x36x50, 20x18x25, 10x9x13, 5x5x7, so
// 4x3x5 + 2x2x3 + 1x1x2 + 1 bricks over four levels.
const CompressParams kParams = params(16, 2, 8, "u16,b8log+", 2);

}  // namespace

TEST(TaStreaming, RawAndNrrdSourcesGiveTheSameFile) {
  test::TempDir dir;
  const Volume v = prisms({40, 36, 50}, 21);
  io::write_volume(dir / "v.raw", v);
  io::write_volume(dir / "v.nrrd", v);  // gzip-encoded: read through a decoded temporary
  ThreadCount one(1);
  const CompressReport a = compress_file(dir / "v.raw", dir / "a.strata", kParams);
  const CompressReport b = compress_file(dir / "v.nrrd", dir / "b.strata", kParams);
  const CompressReport c = compress(v, dir / "c.strata", kParams);  // straight from memory
  EXPECT_EQ(a.file_bytes, b.file_bytes);
  EXPECT_TRUE(file_bytes(dir / "a.strata") == file_bytes(dir / "b.strata"));
  EXPECT_TRUE(file_bytes(dir / "a.strata") == file_bytes(dir / "c.strata"));
  EXPECT_EQ(a.levels.size(), 4u);
}

TEST(TaStreaming, CodecOutputIsTheSameForOneAndTwoThreads) {
  test::TempDir dir;
  const Volume v = prisms({40, 36, 50}, 22);
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
  EXPECT_EQ(c1.bricks.size(), 60u + 12u + 2u + 1u);
  EXPECT_TRUE(c1 == content_of(dir / "t2.strata"));
  EXPECT_TRUE(c1 == content_of(dir / "t2b.strata"));
}

TEST(TaStreaming, OneThreadRunsAreByteIdentical) {
  test::TempDir dir;
  const Volume v = prisms({40, 36, 50}, 23);
  ThreadCount one(1);
  compress(v, dir / "a.strata", kParams);
  compress(v, dir / "b.strata", kParams);
  EXPECT_TRUE(file_bytes(dir / "a.strata") == file_bytes(dir / "b.strata"));
}

// Reproducible builds: the same input and parameters give the same file bytes whatever the
// thread count (so files can be compared by checksum). Payloads and index entries must not be
// laid out in the order worker threads happen to finish.
TEST(TaStreaming, FileBytesDoNotDependOnTheThreadCount) {
  test::TempDir dir;
  const Volume v = prisms({40, 36, 50}, 24);
  {
    ThreadCount one(1);
    compress(v, dir / "t1.strata", kParams);
  }
  ThreadCount two(2);
  for (int run = 0; run < 3; ++run) {
    const fs::path p = dir / ("t2_" + std::to_string(run) + ".strata");
    compress(v, p, kParams);
    EXPECT_TRUE(file_bytes(dir / "t1.strata") == file_bytes(p)) << "run " << run << " with 2 threads";
  }
}
