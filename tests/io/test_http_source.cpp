// io::open_http_source against tests/support/range_server.py: exact ranges, the cache, coalesced
// prefetches, retries, and the errors of a server that ignores ranges, a missing file and a
// connection reset on every attempt.
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <vector>

#include "strata/core/error.hpp"
#include "strata/io/http_source.hpp"
#include "support/range_server.hpp"
#include "support/test_support.hpp"

namespace strata::io {
namespace {

using test::error_of;
using test::RangeServer;
using test::TempDir;

constexpr std::size_t kFileBytes = 300'000;

class IoHttpSource : public ::testing::Test {
 protected:
  IoHttpSource() {
    bytes_.resize(kFileBytes);
    for (std::size_t i = 0; i < bytes_.size(); ++i) bytes_[i] = std::byte((i * 7919) >> 3);
    std::ofstream(dir_ / "f.bin", std::ios::binary)
        .write(reinterpret_cast<const char*>(bytes_.data()), std::streamsize(bytes_.size()));
    options_.backoff_ms = 10;
    options_.attempts = 3;
    options_.head_bytes = 4096;
  }
  std::vector<std::byte> expected(std::uint64_t offset, std::uint64_t size) const {
    return {bytes_.begin() + std::ptrdiff_t(offset), bytes_.begin() + std::ptrdiff_t(offset + size)};
  }
  static std::vector<std::byte> copy(const SharedBytes& b) { return {b.begin(), b.end()}; }

  TempDir dir_;
  std::vector<std::byte> bytes_;
  RangeServer server_{dir_.path()};
  HttpOptions options_;
};

TEST_F(IoHttpSource, ReadsExactRangesAndCachesThem) {
  const auto source = open_http_source(server_.url("ok", "f.bin"), options_);
  EXPECT_TRUE(source->remote());
  EXPECT_EQ(source->size(), kFileBytes);
  EXPECT_EQ(source->transfer_stats().requests, 1u);           // the head
  EXPECT_EQ(copy(source->read(10, 100)), expected(10, 100));  // inside the head: no request
  EXPECT_EQ(copy(source->read(150'000, 5000)), expected(150'000, 5000));
  EXPECT_EQ(copy(source->read(151'000, 1000)), expected(151'000, 1000));  // inside a cached range
  const TransferStats s = source->transfer_stats();
  EXPECT_EQ(s.requests, 2u);
  EXPECT_EQ(s.bytes_fetched, 4096u + 5000u);
  EXPECT_EQ(s.cache_hits, 1u);
  EXPECT_EQ(s.retries, 0u);
}

TEST_F(IoHttpSource, PrefetchCoalescesNeighbours) {
  options_.coalesce_gap = 4096;
  const auto source = open_http_source(server_.url("ok", "f.bin"), options_);
  const std::vector<ByteRange> ranges{{200'000, 1000}, {100'000, 1000}, {101'500, 1000}, {100'500, 200}};
  source->prefetch(ranges);
  EXPECT_EQ(source->transfer_stats().requests, 3u);  // the head, 100000..102500, 200000..201000
  for (const ByteRange& r : ranges) EXPECT_EQ(copy(source->read(r.offset, r.size)), expected(r.offset, r.size));
  EXPECT_EQ(source->transfer_stats().requests, 3u);
}

TEST_F(IoHttpSource, SmallFilesOpenWithOneRequest) {
  options_.head_bytes = 1 << 20;  // more than the file holds: the server clips the range
  const auto source = open_http_source(server_.url("ok", "f.bin"), options_);
  EXPECT_EQ(source->size(), kFileBytes);
  EXPECT_EQ(copy(source->read(kFileBytes - 10, 10)), expected(kFileBytes - 10, 10));
  EXPECT_EQ(source->transfer_stats().requests, 1u);
}

TEST_F(IoHttpSource, TransientFailuresAreRetried) {
  const auto source = open_http_source(server_.url("flaky", "f.bin"), options_);
  EXPECT_EQ(copy(source->read(50'000, 3000)), expected(50'000, 3000));
  EXPECT_GT(source->transfer_stats().retries, 0u);
}

TEST_F(IoHttpSource, AServerIgnoringRangesIsRefused) {
  const std::string url = server_.url("norange", "f.bin");
  const std::string message = error_of([&] { open_http_source(url, options_); });
  EXPECT_NE(message.find(url + ": bytes 0-4095: the server answered 200"), std::string::npos) << message;
  EXPECT_NE(message.find("does not support HTTP range requests"), std::string::npos) << message;
}

TEST_F(IoHttpSource, AMissingFileIsNamed) {
  const std::string url = server_.url("ok", "missing.bin");
  const std::string message = error_of([&] { open_http_source(url, options_); });
  EXPECT_NE(message.find(url), std::string::npos) << message;
  EXPECT_NE(message.find("HTTP 404 Not Found"), std::string::npos) << message;
}

TEST_F(IoHttpSource, APersistentResetGivesUpAfterTheAttempts) {
  const std::string url = server_.url("reset", "f.bin");
  const auto start = std::chrono::steady_clock::now();
  const std::string message = error_of([&] { open_http_source(url, options_); });
  EXPECT_NE(message.find(url + ": bytes 0-4095: "), std::string::npos) << message;
  EXPECT_NE(message.find("(failed 3 times; giving up)"), std::string::npos) << message;
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(20));
}

TEST_F(IoHttpSource, AnUnreachableServerFails) {
  options_.attempts = 2;
  const std::string message = error_of([&] { open_http_source("http://127.0.0.1:1/f.bin", options_); });
  EXPECT_NE(message.find("http://127.0.0.1:1/f.bin: bytes 0-4095: "), std::string::npos) << message;
  EXPECT_NE(message.find("(failed 2 times; giving up)"), std::string::npos) << message;
}

TEST(IoByteSource, RecognisesUrls) {
  EXPECT_TRUE(is_url("http://example.org/a.strata"));
  EXPECT_TRUE(is_url("HTTPS://example.org/a.strata"));
  EXPECT_FALSE(is_url("http:/a.strata"));
  EXPECT_FALSE(is_url("data/http://a.strata"));
  EXPECT_FALSE(is_url("ftp://example.org/a.strata"));
}

}  // namespace
}  // namespace strata::io
