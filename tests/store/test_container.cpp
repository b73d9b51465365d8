#include <gtest/gtest.h>

#include <fstream>
#include <random>

#include "strata/core/error.hpp"
#include "strata/store/container.hpp"
#include "strata/store/crc32c.hpp"
#include "support/test_support.hpp"

using namespace strata;
using namespace strata::store;

namespace {

std::vector<std::byte> random_bytes(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<std::byte> v(n);
  for (auto& b : v) b = std::byte(rng() & 0xff);
  return v;
}


using strata::test::error_of;

}  // namespace

TEST(StoreContainer, RoundTripsBricksSectionsAndMetadata) {
  test::TempDir dir;
  auto path = dir / "a.strata";
  auto p1 = random_bytes(1000, 2), p2 = random_bytes(77, 3), sec = random_bytes(500, 4);
  {
    ContainerWriter w(path);
    w.add_brick({{0, 1, 2, 3}, PayloadKind::tucker, 0, 0, 0, -1.5f, 2.5f, 0xF0F0ull}, p1);
    w.add_brick({{1, 0, 0, 0}, PayloadKind::constant, 0, 0, 0, 7.0f, 7.0f, 1ull}, {});
    w.add_brick({{0, 0, 0, 0}, PayloadKind::tucker, 0, 0, 0, 0.0f, 1.0f, 2ull}, p2);
    w.add_section("global_bases", sec);
    w.finish({{"codec", "test"}, {"levels", 2}});
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "a.strata.tmp"));
  ContainerReader r(path);
  EXPECT_EQ(r.metadata()["codec"], "test");
  ASSERT_EQ(r.bricks().size(), 3u);
  const BrickEntry* e = r.find({0, 1, 2, 3});
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->kind, PayloadKind::tucker);
  EXPECT_EQ(e->min, -1.5f);
  EXPECT_EQ(e->histogram, 0xF0F0ull);
  EXPECT_EQ(e->offset % kPayloadAlignment, 0u);
  auto bytes = r.payload(*e);
  EXPECT_TRUE(std::equal(bytes.begin(), bytes.end(), p1.begin(), p1.end()));
  EXPECT_EQ(r.find({0, 0, 0, 0})->size, 77u);
  EXPECT_EQ(r.find({1, 0, 0, 0})->kind, PayloadKind::constant);
  EXPECT_EQ(r.find({2, 0, 0, 0}), nullptr);
  auto s = r.section("global_bases");
  EXPECT_TRUE(std::equal(s.begin(), s.end(), sec.begin(), sec.end()));
  EXPECT_FALSE(r.has_section("nope"));
  EXPECT_TRUE(is_strata_file(path));
}

TEST(StoreContainer, CorruptPayloadIsReportedWithTheBrick) {
  test::TempDir dir;
  auto path = dir / "c.strata";
  auto p1 = random_bytes(256, 5);
  {
    ContainerWriter w(path);
    w.add_brick({{2, 4, 5, 6}, PayloadKind::tucker, 0, 0, 0, 0, 1, 0}, p1);
    w.finish({});
  }
  std::uint64_t offset = ContainerReader(path).find({2, 4, 5, 6})->offset;
  test::flip_byte(path, offset + 100);
  ContainerReader r(path);  // header, index and metadata are still intact
  std::string msg = error_of([&] { r.payload(*r.find({2, 4, 5, 6})); });
  EXPECT_NE(msg.find("c.strata"), std::string::npos) << msg;
  EXPECT_NE(msg.find("level 2, 4,5,6"), std::string::npos) << msg;
  EXPECT_NE(msg.find("checksum"), std::string::npos) << msg;
}

TEST(StoreContainer, RejectsBadHeadersAndTruncation) {
  test::TempDir dir;
  auto path = dir / "t.strata";
  {
    ContainerWriter w(path);
    w.add_brick({{0, 0, 0, 0}, PayloadKind::tucker, 0, 0, 0, 0, 1, 0}, random_bytes(4096, 6));
    w.finish({{"x", 1}});
  }
  const auto size = std::filesystem::file_size(path);
  auto copy = dir / "t2.strata";
  std::filesystem::copy_file(path, copy);
  std::filesystem::resize_file(copy, size - 100);
  std::string msg = error_of([&] { ContainerReader r(copy); });
  EXPECT_NE(msg.find("t2.strata"), std::string::npos) << msg;
  EXPECT_NE(msg.find("outside"), std::string::npos) << msg;

  test::flip_byte(path, 9);  // version field: caught by the header checksum
  msg = error_of([&] { ContainerReader r(path); });
  EXPECT_NE(msg.find("header"), std::string::npos) << msg;

  std::ofstream(dir / "n.strata") << "NRRD0004 definitely not strata";
  msg = error_of([&] { ContainerReader r(dir / "n.strata"); });
  EXPECT_NE(msg.find("magic"), std::string::npos) << msg;
}

TEST(StoreContainer, UnfinishedWriterLeavesNothing) {
  test::TempDir dir;
  {
    ContainerWriter w(dir / "u.strata");
    w.add_brick({{0, 0, 0, 0}, PayloadKind::tucker, 0, 0, 0, 0, 1, 0}, random_bytes(64, 7));
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "u.strata"));
  EXPECT_FALSE(std::filesystem::exists(dir / "u.strata.tmp"));
}
