// The HTTP server against clients that misbehave or push it, over raw loopback connections:
// 200 connections trickling request heads while probes are answered, pipelined requests on one
// connection, framing the server must refuse (conflicting Content-Length and the like), and a
// second server on a busy port.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "server/live_server.hpp"
#include "server/server_test_util.hpp"
#include "strata/server/api.hpp"
#include "strata/server/http_server.hpp"
#include "strata/server/render_queue.hpp"
#include "support/raw_http.hpp"
#include "support/test_support.hpp"

namespace strata::server {
namespace {

using namespace testing;
using test::RawHttp;
using test::RawResponse;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// A live server over a fresh Api, its options as `set` leaves them.
struct Served {
  explicit Served(const std::function<void(ServerOptions&)>& set = {}) {
    ServerOptions options;
    if (set) set(options);
    live = std::make_unique<LiveServer>(*api, options);
  }
  int port() const { return live->port(); }
  std::unique_ptr<Api> api = make_api();
  std::unique_ptr<LiveServer> live;
};

// Slow clients must not stall the server: 200 connections each send a request line, then one
// header line after another, never the blank line that ends the head. Meanwhile probes on new
// connections are answered at once; afterwards the slow connections are still open (the server
// served the probes beside them, it did not shed them) and each gets its answer once its head
// is complete.
TEST(ServerHttpLimits, AnswersProbesWhile200SlowClientsTrickleHeaders) {
  constexpr int kSlow = 200, kProbes = 7;
  // The slow heads stay open for the whole test, however loaded the machine.
  const Served live([](ServerOptions& o) { o.head_timeout_s = 120; });
  std::vector<RawHttp> slow;
  for (int i = 0; i < kSlow; ++i) {
    slow.emplace_back(live.port());
    ASSERT_TRUE(slow.back().connected()) << "slow connection " << i;
    ASSERT_TRUE(slow.back().send("GET /api/datasets HTTP/1.1\r\nHost: 127.0.0.1\r\n"));
  }
  std::atomic<bool> done{false};
  std::thread trickle([&] {  // one header line per connection every ~2 s, spread over the interval
    for (int line = 0; !done; ++line)
      for (int i = 0; i < kSlow && !done; ++i) {
        slow[std::size_t(i)].send("X-Slow-" + std::to_string(line) + ": " + std::to_string(i) + "\r\n", 1);
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
      }
  });
  std::vector<double> latencies;
  int answered = 0;
  for (int p = 0; p < kProbes; ++p) {
    std::this_thread::sleep_for(std::chrono::milliseconds(150));
    const auto t0 = Clock::now();
    RawHttp probe(live.port());
    const bool sent = probe.connected() && probe.send("GET /api/datasets HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n");
    const auto r = sent ? probe.read_response(5) : std::nullopt;
    latencies.push_back(seconds_since(t0));
    if (r && r->status == 200) ++answered;
  }
  done = true;
  trickle.join();
  std::vector<double> sorted = latencies;
  std::sort(sorted.begin(), sorted.end());
  std::printf("probes beside %d slow connections: %d of %d answered; latency min %.1f ms, median %.1f ms, max %.1f ms\n",
              kSlow, answered, kProbes, sorted.front() * 1e3, sorted[sorted.size() / 2] * 1e3, sorted.back() * 1e3);
  EXPECT_EQ(answered, kProbes);
  // Under a second each; one probe may miss it on a loaded machine (scheduling, not the server).
  const auto within = std::count_if(latencies.begin(), latencies.end(), [](double s) { return s < 1.0; });
  EXPECT_GE(within, kProbes - 1) << "probes answered within 1 s";

  int still_open = 0, served_late = 0;
  for (RawHttp& s : slow) still_open += s.silent_and_open() ? 1 : 0;
  EXPECT_EQ(still_open, kSlow) << "the slow connections were kept, not dropped";
  for (RawHttp& s : slow) {
    if (!s.send("\r\n")) continue;
    const auto r = s.read_response(10);
    served_late += r && r->status == 200 ? 1 : 0;
  }
  EXPECT_EQ(served_late, kSlow) << "each slow request is answered once its head is complete";
}

// A head that keeps trickling in is cut off at the head deadline, not kept alive by each line.
TEST(ServerHttpLimits, AHeadMustArriveWithinItsDeadline) {
  const Served live([](ServerOptions& o) { o.head_timeout_s = 1; });
  RawHttp c(live.port());
  ASSERT_TRUE(c.send("GET /api/datasets HTTP/1.1\r\n"));
  const auto t0 = Clock::now();
  bool closed = false;
  for (int i = 0; i < 100 && !closed; ++i) {  // a line every 100 ms: each one long before any per-read time-out
    c.send("X-Slow: " + std::to_string(i) + "\r\n", 1);
    closed = c.closed_by_peer(0.1);
  }
  EXPECT_TRUE(closed) << "the server keeps a head open that takes longer than its deadline";
  EXPECT_LT(seconds_since(t0), 8) << "closed at the head deadline (1 s), give or take a loaded machine";
  const auto r = c.read_response(1);
  ASSERT_TRUE(r) << "a 408 before the close";
  EXPECT_EQ(r->status, 408);
}

// Pipelined requests on one connection are each answered, in order: 50 sent at once, GETs and
// POSTs with bodies mixed, the last one asking to close.
TEST(ServerHttpLimits, PipelinedRequestsAreEachAnsweredInOrder) {
  constexpr int kRequests = 50;
  const Served live;
  std::string wire;
  std::vector<std::string> expected;
  for (int i = 0; i < kRequests; ++i) {
    const std::string close = i == kRequests - 1 ? "Connection: close\r\n" : "";
    if (i % 10 == 5) {
      const std::string body = R"({"opacity": 0.5})";
      wire += "POST /api/datasets/1/palette HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n" + close +
              "Content-Length: " + std::to_string(body.size()) + "\r\n\r\n" + body;
      expected.push_back("palette");
    } else {
      const std::string target = "/api/datasets/2/value?x=" + std::to_string(i % 24) + "&y=" + std::to_string(i % 20) +
                                 "&z=" + std::to_string(i % 16);
      wire += "GET " + target + " HTTP/1.1\r\nHost: 127.0.0.1\r\n" + close + "\r\n";
      expected.push_back(get(*live.api, target).body);
    }
  }
  RawHttp c(live.port());
  ASSERT_TRUE(c.send(wire));
  int answered = 0;
  for (int i = 0; i < kRequests; ++i) {
    const auto r = c.read_response(10);
    if (!r) break;
    ++answered;
    EXPECT_EQ(r->status, 200) << "request " << i << ": " << r->body;
    if (expected[std::size_t(i)] == "palette") EXPECT_TRUE(nlohmann::json::parse(r->body).contains("palette_ms")) << i;
    else EXPECT_EQ(r->body, expected[std::size_t(i)]) << "response " << i << " answers request " << i;
  }
  EXPECT_EQ(answered, kRequests) << "every pipelined request is answered";
  EXPECT_TRUE(c.closed_by_peer(5)) << "closed after the request that asked for it";
}

// Framing a proxy and the server could read differently (request smuggling) is refused with 400
// and the connection closed: conflicting or malformed Content-Length, Content-Length beside
// Transfer-Encoding.
TEST(ServerHttpLimits, ConflictingOrMalformedFramingIs400) {
  const Served live;
  const std::string post = "POST /api/datasets/1/palette HTTP/1.1\r\nHost: 127.0.0.1\r\n";
  const std::string body = R"({"opacity": 1})";  // 14 bytes
  for (const std::string& framing :
       {std::string("Content-Length: 14\r\nContent-Length: 15\r\n"), std::string("Content-Length: 14, 15\r\n"),
        std::string("Content-Length: 15\r\nContent-Length: 14\r\n"), std::string("Content-Length: +14\r\n"),
        std::string("Content-Length: 0x0e\r\n"), std::string("Content-Length: 14\r\nTransfer-Encoding: chunked\r\n"),
        std::string("Content-Length: 99999999999999999999999\r\n"), std::string("Content-Length : 14\r\n")}) {
    RawHttp c(live.port());
    ASSERT_TRUE(c.send(post + framing + "\r\n" + body));
    const auto r = c.read_response(10);
    ASSERT_TRUE(r) << framing;
    EXPECT_EQ(r->status, 400) << framing;
    EXPECT_EQ(r->header("connection"), "close") << framing;
    EXPECT_TRUE(c.closed_by_peer(5)) << framing;
  }
  // The same value twice is one length (RFC 9112, 6.3).
  RawHttp c(live.port());
  ASSERT_TRUE(c.send(post + "Content-Length: 14\r\nContent-Length: 14\r\n\r\n" + body));
  const auto r = c.read_response(10);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200) << r->body;
}

// At the connection cap a new client still gets in: the connection whose head has been arriving
// the longest makes room. When every connection has a request running, the newcomer gets 503.
TEST(ServerHttpLimits, AtTheConnectionCapTheSlowestHeadMakesRoom) {
  const Served live([](ServerOptions& o) { o.max_connections = 4; });
  Api* api = live.api.get();
  std::vector<RawHttp> slow;
  for (int i = 0; i < 4; ++i) {
    slow.emplace_back(live.port());
    ASSERT_TRUE(slow.back().send("GET /api/datasets HTTP/1.1\r\n"));
    std::this_thread::sleep_for(std::chrono::milliseconds(20));  // so that slow[0] is the oldest head
  }
  RawHttp probe(live.port());
  ASSERT_TRUE(probe.send("GET /api/datasets HTTP/1.1\r\n\r\n"));
  const auto r = probe.read_response(10);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_TRUE(slow[0].closed_by_peer(5)) << "the oldest unfinished head was dropped";
  for (std::size_t i = 1; i < slow.size(); ++i) EXPECT_TRUE(slow[i].silent_and_open()) << i;

  // Four frames held by a paused render queue: no connection may be dropped, so a fifth gets 503.
  api->render_queue().pause();
  std::vector<RawHttp> busy;
  for (int i = 0; i < 4; ++i) {
    busy.emplace_back(live.port());
    ASSERT_TRUE(busy.back().send("GET /api/datasets/0/render?w=16&h=16 HTTP/1.1\r\n\r\n"));
  }
  ASSERT_TRUE(eventually([&] { return api->render_queue().queued() == 4; })) << "the frames wait for the renderer";
  RawHttp late(live.port());
  const auto refused = late.read_response(10);
  ASSERT_TRUE(refused);
  EXPECT_EQ(refused->status, 503);
  api->render_queue().resume();
  for (RawHttp& b : busy) {
    const auto frame = b.read_response(30);
    ASSERT_TRUE(frame);
    EXPECT_EQ(frame->status, 200);
  }
}

// Keep-alive: a connection that sends nothing is closed after the idle time-out, silently.
TEST(ServerHttpLimits, IdleConnectionsAreClosed) {
  const Served live([](ServerOptions& o) { o.idle_timeout_s = 0.3; });
  RawHttp c(live.port());
  ASSERT_TRUE(c.send("GET /api/datasets HTTP/1.1\r\n\r\n"));
  ASSERT_TRUE(c.read_response(10));
  EXPECT_TRUE(c.closed_by_peer(10));
  EXPECT_FALSE(c.read_response(0.1)) << "no answer to a request never sent";
}

// "Expect: 100-continue" gets its interim answer before the body is sent; HEAD answers carry the
// length of the body they leave out, and the next answer on the connection follows at once.
TEST(ServerHttpLimits, ContinueAndHeadOnTheWire) {
  const Served live;
  RawHttp c(live.port());
  const std::string body = R"({"opacity": 0.25})";
  ASSERT_TRUE(c.send("POST /api/datasets/1/palette HTTP/1.1\r\nExpect: 100-continue\r\nContent-Length: " +
                     std::to_string(body.size()) + "\r\n\r\n"));
  const auto interim = c.read_response(10);
  ASSERT_TRUE(interim);
  EXPECT_EQ(interim->status, 100);
  ASSERT_TRUE(c.send(body));
  const auto done = c.read_response(10);
  ASSERT_TRUE(done);
  EXPECT_EQ(done->status, 200) << done->body;

  ASSERT_TRUE(c.send("HEAD /zarr/cells/.zattrs HTTP/1.1\r\n\r\nGET /zarr/cells/.zattrs HTTP/1.1\r\n\r\n"));
  const auto head = c.read_response(10, true);
  const auto get = c.read_response(10);
  ASSERT_TRUE(head && get);
  EXPECT_EQ(head->status, 200);
  EXPECT_TRUE(head->body.empty());
  EXPECT_EQ(head->header("content-length"), std::to_string(get->body.size()));
  EXPECT_NE(get->body.find("multiscales"), std::string::npos);
}

// A second server on a port that one already listens on does not start beside it (and take a
// share of its connections): bind() fails naming the address and the reason.
TEST(ServerHttpLimits, ASecondServerOnABusyPortFailsToBind) {
  const Served first;
  ServerOptions options;
  options.port = first.port();
  HttpServer second(*first.api, options);
  const std::string message = test::error_of([&] { second.bind(); });
  EXPECT_NE(message.find("127.0.0.1:" + std::to_string(first.port())), std::string::npos) << message;
  EXPECT_NE(message.find("address already in use"), std::string::npos) << message;
  RawHttp c(first.port());
  ASSERT_TRUE(c.send("GET /api/datasets HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n"));
  const auto r = c.read_response(10);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200) << "the first server still answers";
}

}  // namespace
}  // namespace strata::server
