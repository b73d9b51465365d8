// The real HTTP server on loopback (httplib::Client): responses and headers on the wire,
// traversal attempts in raw and encoded form, the body limit, shutdown by SIGTERM, and a bounded
// load test (1,000 requests from 32 concurrent clients) that checks for failures and memory growth.
// Like the server itself, this file includes httplib.h and nothing that pulls in Eigen.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <thread>

#include <httplib.h>

#include "server/live_server.hpp"
#include "server/server_test_util.hpp"
#include "strata/server/api.hpp"
#include "strata/server/http_server.hpp"

namespace strata::server {
namespace {

using namespace testing;
using namespace std::chrono_literals;

// An HTTP client of `live` with generous time-outs.
httplib::Client client(const LiveServer& live) {
  httplib::Client c("127.0.0.1", live.port());
  c.set_connection_timeout(5);
  c.set_read_timeout(30);
  return c;
}

TEST(ServerHttp, ServesTheApiOnLoopback) {
  const auto api = make_api();
  LiveServer live(*api);
  httplib::Client c = client(live);
  const auto list = c.Get("/api/datasets");
  ASSERT_TRUE(list) << httplib::to_string(list.error());
  EXPECT_EQ(list->status, 200);
  EXPECT_EQ(list->get_header_value("Cache-Control"), "no-store");
  EXPECT_EQ(list->get_header_value("Content-Type"), "application/json");
  EXPECT_EQ(nlohmann::json::parse(list->body).size(), 3u);

  const auto frame = c.Get("/api/datasets/0/render?w=40&h=30&quality=coarse");
  ASSERT_TRUE(frame);
  EXPECT_EQ(frame->status, 200);
  EXPECT_EQ(frame->get_header_value("Content-Type"), "image/jpeg");
  EXPECT_EQ(jpeg_size(frame->body), (std::pair{40, 30}));
  EXPECT_TRUE(nlohmann::json::parse(frame->get_header_value("X-Strata-Stats")).contains("frame_ms"));

  const auto slice = c.Get("/api/datasets/2/slice?axis=z&index=3&format=raw");
  ASSERT_TRUE(slice);
  EXPECT_EQ(slice->get_header_value("X-Strata-Dims"), "24,20");
  EXPECT_EQ(slice->body.size(), 24u * 20u * 4u);

  const auto bad = c.Get("/api/datasets/0/render?w=99999");
  ASSERT_TRUE(bad);
  EXPECT_EQ(bad->status, 400);
  EXPECT_EQ(nlohmann::json::parse(bad->body)["parameter"], "w");

  const auto palette = c.Post("/api/datasets/1/palette", R"({"default": "hash", "opacity": 0.8})", "application/json");
  ASSERT_TRUE(palette);
  EXPECT_EQ(palette->status, 200) << palette->body;
  // The body is JSON whatever the content type says (curl -d sends it as a form).
  const auto form = c.Post("/api/datasets/1/palette", R"({"opacity": 0.5})", "application/x-www-form-urlencoded");
  ASSERT_TRUE(form);
  EXPECT_EQ(form->status, 200) << form->body;
  // Query parameters still arrive percent-decoded.
  const auto encoded = c.Get("/api/datasets/0/render?w=32&h=24&tf=%67rayscale");
  ASSERT_TRUE(encoded);
  EXPECT_EQ(encoded->status, 200) << encoded->body;

  const auto root = c.Get("/");
  ASSERT_TRUE(root);
  EXPECT_EQ(root->status, 200);
  EXPECT_EQ(root->get_header_value("Content-Type"), "text/html; charset=utf-8");
}

TEST(ServerHttp, TraversalAttemptsAre404OnTheWire) {
  const auto api = make_api();
  LiveServer live(*api);
  httplib::Client c = client(live);
  c.set_url_encode(false);  // send the paths exactly as written
  for (const std::string path :
       {"/static/../CMakeLists.txt", "/static/%2e%2e/CMakeLists.txt", "/static/%2E%2E/%2E%2E/etc/passwd",
        "/static/..%2f..%2fetc%2fpasswd", "/../../etc/passwd", "/static/%2e%2e%5c%2e%2e%5cetc%5cpasswd",
        "/static//etc/passwd", "/api/datasets/0/../../../etc/passwd", "/static/.%2e/README.md"}) {
    const auto r = c.Get(path);
    ASSERT_TRUE(r) << path << ": " << httplib::to_string(r.error());
    EXPECT_EQ(r->status, 404) << path;
    EXPECT_EQ(r->body.find("root:"), std::string::npos) << path;
  }
}

TEST(ServerHttp, LargeBodiesAreRefused) {
  const auto api = make_api();
  ServerOptions options;
  options.max_body_bytes = 4096;
  LiveServer live(*api, options);
  httplib::Client c = client(live);
  const auto r = c.Post("/api/datasets/1/palette", std::string(10000, ' '), "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 413);
}

TEST(ServerHttp, SigtermStopsTheServerCleanly) {
  const auto api = make_api();
  ServerOptions options;
  options.port = 0;
  HttpServer server(*api, options);
  const int port = server.bind();
  std::atomic<bool> returned{false};
  std::thread serving([&] {
    serve_until_signal(server);
    returned = true;
  });
  const bool started = eventually([&] { return server.running(); });
  EXPECT_TRUE(started) << "the server did not start listening";
  if (started) {
    httplib::Client c("127.0.0.1", port);
    EXPECT_TRUE(c.Get("/api/datasets"));
    std::raise(SIGTERM);  // the handler only signals the watcher thread, which stops the server
    EXPECT_TRUE(eventually([&] { return returned.load(); })) << "serve_until_signal returns after SIGTERM";
  }
  if (!returned) server.stop();  // so the thread can be joined either way
  serving.join();
  EXPECT_FALSE(server.running());
  httplib::Client after("127.0.0.1", port);
  after.set_connection_timeout(1);
  EXPECT_FALSE(after.Get("/api/datasets")) << "nothing listens any more";
}

// What one load-test client asks for, by request number: a mix of every endpoint.
std::string load_target(int client, int i) {
  const std::string c = std::to_string(client), n = std::to_string(i);
  switch (i % 10) {
    case 0: return "/api/datasets";
    case 1: return "/api/datasets/0/render?w=64&h=48&quality=coarse&az=" + std::to_string(i * 7 % 360) +
                   "&client=load-" + c + "&seq=" + n;
    case 2: return "/api/datasets/" + std::to_string(i % 3) + "/slice?axis=z&index=" + std::to_string(i % 16) + "&zoom=0.5";
    case 3: return "/api/datasets/0/slice?axis=x&index=" + std::to_string(i % 48) + "&format=raw&rank=" + std::to_string(1 + i % 8);
    case 4: return "/api/datasets/1/value?x=" + std::to_string(i % 40) + "&y=3&z=4";
    case 5: return "/api/datasets/1/query?box=0,0,0,20,20,20&method=" + std::string(i % 20 < 10 ? "hybrid" : "naive");
    case 6: return "/api/datasets/2/render?w=48&h=36&quality=coarse&client=load-" + c + "&seq=" + n;
    case 7: return "/api/datasets/0/value?x=7&y=8&z=" + std::to_string(i % 36);
    case 8: return "/";
    default: return "/api/datasets/1/render?w=40&h=30&az=" + std::to_string(i % 360);
  }
}

TEST(ServerHttp, LoadOf1000RequestsFrom32Clients) {
  constexpr int kClients = 32, kRequests = 1000;
  constexpr std::uint64_t kCacheBytes = 64ull << 20;
  // Allocator arenas of 48 threads, thread stacks and encoder buffers on top of the caches.
  constexpr std::uint64_t kMargin = 96ull << 20;
  ApiOptions options;
  options.cache_bytes = kCacheBytes;
  const auto api = make_api(options);
  LiveServer live(*api);
  {  // warm-up: the first frame of each dataset and the label lookup, so RSS starts settled
    httplib::Client c = client(live);
    for (const char* path : {"/api/datasets/0/render?w=64&h=48", "/api/datasets/1/render?w=40&h=30",
                             "/api/datasets/2/render?w=48&h=36", "/api/datasets/1/query?box=0,0,0,2,2,2"})
      ASSERT_TRUE(c.Get(path));
  }
  const std::uint64_t rss_before = resident_bytes();
  std::atomic<int> next{0}, ok{0}, superseded{0}, busy{0}, failed{0};
  std::vector<std::string> failures;
  std::mutex failures_mutex;
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<std::thread> clients;
  for (int id = 0; id < kClients; ++id)
    clients.emplace_back([&, id] {
      httplib::Client c = client(live);
      for (int i = next++; i < kRequests; i = next++) {
        const std::string target = load_target(id, i);
        const auto r = c.Get(target);
        const int status = r ? r->status : -1;
        if (status == 200) ++ok;
        else if (status == 204) ++superseded;
        else if (status == 503) ++busy;
        else {
          ++failed;
          std::lock_guard lock(failures_mutex);
          failures.push_back(target + " -> " + (r ? std::to_string(status) + " " + r->body : httplib::to_string(r.error())));
        }
      }
    });
  for (auto& t : clients) t.join();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const std::uint64_t rss_after = resident_bytes();
  const std::int64_t growth = std::int64_t(rss_after) - std::int64_t(rss_before);
  std::printf("load: %d requests in %.1f s: %d ok, %d superseded, %d busy (503), %d failed; RSS %+.1f MiB\n", kRequests,
              seconds, ok.load(), superseded.load(), busy.load(), failed.load(), double(growth) / (1 << 20));
  EXPECT_EQ(failed, 0) << (failures.empty() ? "" : failures.front());
  EXPECT_EQ(ok + superseded + busy + failed, kRequests);
  EXPECT_GT(ok, kRequests / 2) << "most requests are not frames and never wait for the queue";
  EXPECT_LT(growth, std::int64_t(kCacheBytes + kMargin)) << "memory stays within the cache budget plus a margin";
  httplib::Client c = client(live);
  EXPECT_EQ(c.Get("/api/datasets")->status, 200) << "still serving";
}

}  // namespace
}  // namespace strata::server
