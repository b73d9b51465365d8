// store::ContainerReader on an http:// URL (tests/support/range_server.py): it opens with two
// requests (the head, then metadata and index together), reads payloads, sections and volume set
// members like a local file, and names the URL when the file on the server is truncated.
#include <gtest/gtest.h>

#include <vector>

#include "strata/core/error.hpp"
#include "strata/store/container.hpp"
#include "strata/store/volume_set.hpp"
#include "support/range_server.hpp"
#include "support/test_support.hpp"

namespace strata::store {
namespace {

using test::error_of;
using test::RangeServer;
using test::TempDir;

std::vector<std::byte> pattern(std::size_t n, unsigned seed) {
  std::vector<std::byte> b(n);
  for (std::size_t i = 0; i < n; ++i) b[i] = std::byte((i * 2654435761u + seed) >> 11);
  return b;
}

// 200 payloads of 3000 bytes (600 KB, so the tail lies far beyond the first 64 KiB) and a section.
void write_container(const std::filesystem::path& path) {
  ContainerWriter w(path);
  for (int i = 0; i < 200; ++i)
    w.add_brick({{0, i % 10, i / 10, 0}, PayloadKind::tucker, 0, 0, 0, 0.0f, 1.0f, 1ull}, pattern(3000, unsigned(i)));
  w.add_section("extra", pattern(5000, 99));
  w.finish({{"codec", "test"}});
}

std::vector<std::byte> copy(const io::SharedBytes& b) { return {b.begin(), b.end()}; }

class StoreRemoteContainer : public ::testing::Test {
 protected:
  StoreRemoteContainer() { write_container(dir_ / "c.strata"); }
  TempDir dir_;
  RangeServer server_{dir_.path()};
};

TEST_F(StoreRemoteContainer, ReadsLikeTheLocalFile) {
  const ContainerReader local(dir_ / "c.strata");
  const std::string url = server_.url("ok", "c.strata");
  const ContainerReader remote(url);
  EXPECT_EQ(remote.name(), url);
  EXPECT_EQ(remote.path().string(), url);
  EXPECT_EQ(remote.file_size(), local.file_size());
  EXPECT_EQ(remote.metadata(), local.metadata());
  ASSERT_EQ(remote.bricks().size(), local.bricks().size());
  EXPECT_TRUE(remote.source().remote());
  EXPECT_FALSE(local.source().remote());
  EXPECT_EQ(remote.source().transfer_stats().requests, 2u);  // the head; metadata and index
  std::vector<const BrickEntry*> wanted;
  for (std::size_t i = 50; i < 60; ++i) wanted.push_back(&remote.bricks()[i]);
  remote.prefetch(wanted);
  EXPECT_EQ(remote.source().transfer_stats().requests, 3u);  // ten neighbours, one request
  for (std::size_t i = 50; i < 60; ++i)
    EXPECT_EQ(copy(remote.payload(remote.bricks()[i])), copy(local.payload(local.bricks()[i])));
  EXPECT_EQ(remote.source().transfer_stats().requests, 3u);
  EXPECT_EQ(copy(remote.payload(remote.bricks()[150])), copy(local.payload(local.bricks()[150])));
  EXPECT_EQ(copy(remote.section("extra")), copy(local.section("extra")));
  EXPECT_EQ(remote.source().transfer_stats().requests, 5u);
}

TEST_F(StoreRemoteContainer, ATruncatedFileNamesTheUrl) {
  const std::string url = server_.url("truncate", "c.strata");
  const std::string message = error_of([&] { ContainerReader r(url); });
  EXPECT_NE(message.find(url + ": metadata: range ["), std::string::npos) << message;
  EXPECT_NE(message.find("lies outside the"), std::string::npos) << message;
}

TEST_F(StoreRemoteContainer, VolumeSetMembersOpenFromTheSetsUrl) {
  write_container(dir_ / "b.strata");
  write_volume_set(dir_ / "set.strata", {dir_ / "c.strata", dir_ / "b.strata"}, nlohmann::json::object());
  const std::string url = server_.url("ok", "set.strata");
  const auto member = open_volume(url, 1);
  const ContainerReader local(dir_ / "b.strata");
  EXPECT_EQ(member->name(), url + " (volume 1)");
  EXPECT_EQ(member->metadata(), local.metadata());
  EXPECT_EQ(copy(member->payload(member->bricks()[7])), copy(local.payload(local.bricks()[7])));
  EXPECT_TRUE(member->source().remote());
  EXPECT_GT(member->source().transfer_stats().requests, 2u);
}

}  // namespace
}  // namespace strata::store
