// The render queue on its own, with jobs the test controls: supersession per client, stale
// sequence numbers, the capacity bound (503), shutdown and failing jobs.
#include <gtest/gtest.h>

#include <atomic>
#include <future>
#include <new>
#include <stdexcept>
#include <thread>

#include "server/server_test_util.hpp"
#include "strata/core/error.hpp"
#include "strata/server/render_queue.hpp"

namespace strata::server {
namespace {

RenderQueue::Job body(std::string text, std::atomic<int>* runs = nullptr) {
  return [text = std::move(text), runs] {
    if (runs) ++*runs;
    HttpResponse r;
    r.body = text;
    return r;
  };
}

void wait_queued(const RenderQueue& q, std::size_t n) {
  ASSERT_TRUE(testing::eventually([&] { return q.queued() >= n; })) << "expected " << n << " queued jobs";
}

TEST(ServerRenderQueue, RunsJobsAndReturnsTheirResponses) {
  RenderQueue q(2);
  const HttpResponse r = q.run("", std::nullopt, body("frame"));
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.body, "frame");
}

TEST(ServerRenderQueue, NewerRequestOfAClientSupersedesItsQueuedOne) {
  RenderQueue q(4);
  q.pause();
  std::atomic<int> old_runs{0}, other_runs{0};
  auto older = std::async(std::launch::async, [&] { return q.run("a", 1, body("old", &old_runs)); });
  auto other = std::async(std::launch::async, [&] { return q.run("b", 1, body("other", &other_runs)); });
  wait_queued(q, 2);
  auto newer = std::async(std::launch::async, [&] { return q.run("a", 2, body("new")); });
  const HttpResponse dropped = older.get();  // answered while paused: never run
  EXPECT_EQ(dropped.status, 204);
  EXPECT_TRUE(dropped.body.empty());
  wait_queued(q, 2);
  EXPECT_EQ(q.queued(), 2u) << "client b's frame and client a's newest";
  q.resume();
  EXPECT_EQ(newer.get().body, "new");
  EXPECT_EQ(other.get().body, "other") << "other clients are not superseded";
  EXPECT_EQ(old_runs, 0);
  EXPECT_EQ(other_runs, 1);
}

TEST(ServerRenderQueue, StaleSequenceNumbersAreDroppedWithoutQueueing) {
  RenderQueue q(1);
  EXPECT_EQ(q.run("a", 5, body("five")).status, 200);
  std::atomic<int> runs{0};
  EXPECT_EQ(q.run("a", 3, body("three", &runs)).status, 204);
  EXPECT_EQ(q.run("a", 5, body("again", &runs)).status, 204) << "a repeated number is not newer";
  EXPECT_EQ(runs, 0);
  EXPECT_EQ(q.run("a", 6, body("six")).body, "six");
}

TEST(ServerRenderQueue, FullQueueAnswers503WithRetryAfter) {
  RenderQueue q(2);
  q.pause();
  auto a = std::async(std::launch::async, [&] { return q.run("", std::nullopt, body("1")); });
  auto b = std::async(std::launch::async, [&] { return q.run("x", 1, body("2")); });
  wait_queued(q, 2);
  const HttpResponse refused = q.run("", std::nullopt, body("3"));
  EXPECT_EQ(refused.status, 503);
  EXPECT_EQ(refused.header("Retry-After"), "1");
  EXPECT_NE(refused.body.find("\"error\""), std::string::npos);
  // A superseding request frees its client's slot first, so it is not refused.
  auto c = std::async(std::launch::async, [&] { return q.run("x", 2, body("4")); });
  EXPECT_EQ(b.get().status, 204);
  q.resume();
  EXPECT_EQ(a.get().body, "1");
  EXPECT_EQ(c.get().body, "4");
}

TEST(ServerRenderQueue, StopAnswersQueuedJobs503AndRefusesNewOnes) {
  RenderQueue q(3);
  q.pause();
  auto a = std::async(std::launch::async, [&] { return q.run("", std::nullopt, body("1")); });
  wait_queued(q, 1);
  q.stop();
  EXPECT_EQ(a.get().status, 503);
  EXPECT_EQ(q.run("", std::nullopt, body("2")).status, 503);
}

// A failing job is a 500. Our errors name the file and field and are sent; another library's
// text (which may quote anything) is not: the client reads that the request failed.
TEST(ServerRenderQueue, FailingJobIs500InOurWords) {
  RenderQueue q(1);
  HttpResponse r = q.run("", std::nullopt, []() -> HttpResponse { throw FormatError("a.strata", "brick (0, 0,0,0)", "broken brick"); });
  EXPECT_EQ(r.status, 500);
  EXPECT_NE(r.body.find("a.strata: brick (0, 0,0,0): broken brick"), std::string::npos) << r.body;
  r = q.run("", std::nullopt, []() -> HttpResponse { throw std::out_of_range("json.exception.out_of_range.401: array index 7"); });
  EXPECT_EQ(r.status, 500);
  EXPECT_EQ(r.body.find("json.exception"), std::string::npos) << r.body;
  EXPECT_NE(r.body.find("internal error while answering the request"), std::string::npos) << r.body;
  r = q.run("", std::nullopt, []() -> HttpResponse { throw std::bad_alloc(); });
  EXPECT_EQ(r.status, 500);
  EXPECT_NE(r.body.find("out of memory"), std::string::npos) << r.body;
  EXPECT_EQ(r.body.find("std::bad_alloc"), std::string::npos) << r.body;
  EXPECT_EQ(q.run("", std::nullopt, body("next")).body, "next") << "the worker survives";
}

}  // namespace
}  // namespace strata::server
