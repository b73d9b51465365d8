// The asynchronous loader's queue: priority order (coarse first, then nearest), replacement of
// stale requests, and failures reaching the caller.
#include <gtest/gtest.h>

#include <atomic>
#include <condition_variable>
#include <mutex>

#include "strata/core/error.hpp"
#include "strata/lod/brick_loader.hpp"

using namespace strata;
using namespace strata::lod;

namespace {

// A job that blocks on the first request until released, then records the order of the rest.
class GatedJob {
 public:
  void operator()(const LoadRequest& r) {
    std::unique_lock lock(m_);
    if (r.key.rank == 0) {
      gate_running_ = true;
      cv_.notify_all();
      cv_.wait(lock, [this] { return open_; });
      return;
    }
    order_.push_back(r.key.brick);
  }
  void wait_until_gated() {
    std::unique_lock lock(m_);
    cv_.wait(lock, [this] { return gate_running_; });
  }
  void open() {
    std::lock_guard lock(m_);
    open_ = true;
    cv_.notify_all();
  }
  std::vector<store::BrickKey> order() {
    std::lock_guard lock(m_);
    return order_;
  }

 private:
  std::mutex m_;
  std::condition_variable cv_;
  bool gate_running_ = false, open_ = false;
  std::vector<store::BrickKey> order_;
};

LoadRequest request(int level, int x, double depth) { return {{{std::uint8_t(level), x, 0, 0}, 4}, depth}; }

}  // namespace

TEST(LodBrickLoader, RunsCoarseFirstThenNearestAndDropsStaleRequests) {
  GatedJob job;
  BrickLoader loader([&job](const LoadRequest& r, tensor::BrickReconstructor&, ta::DecodeScratch&) { job(r); }, 1);
  loader.submit({{{{0, 99, 0, 0}, 0}, 0}});  // rank 0 = the gate
  job.wait_until_gated();
  loader.submit({request(0, 50, 1.0), request(0, 51, 2.0)});  // a frame the user has left
  loader.submit({request(0, 1, 5.0), request(2, 2, 9.0), request(0, 3, 1.0), request(1, 4, 3.0),
                 request(2, 5, 2.0), request(0, 1, 5.0)});
  EXPECT_EQ(loader.queued(), 5u);  // the duplicate is dropped
  job.open();
  loader.wait_idle();
  const std::vector<store::BrickKey> order = job.order();
  std::vector<int> xs;
  for (const auto& k : order) xs.push_back(k.x);
  EXPECT_EQ(xs, (std::vector<int>{5, 2, 4, 3, 1}));
  EXPECT_EQ(loader.queued(), 0u);
  EXPECT_EQ(loader.running(), 0u);
}

TEST(LodBrickLoader, FailuresReachTheCaller) {
  BrickLoader loader([](const LoadRequest& r, tensor::BrickReconstructor&, ta::DecodeScratch&) {
    if (r.key.brick.x == 3) throw Error("corrupt brick 3");
  }, 2);
  loader.submit({request(0, 1, 1), request(0, 3, 1), request(0, 4, 1)});
  EXPECT_THROW(loader.wait_idle(), Error);
  EXPECT_NO_THROW(loader.wait_idle());  // reported once
}

TEST(LodBrickLoader, DrainRunsRequestsOnTheCallingThread) {
  std::atomic<int> done{0};
  BrickLoader loader([&done](const LoadRequest&, tensor::BrickReconstructor&, ta::DecodeScratch&) { ++done; }, 1);
  std::vector<LoadRequest> many;
  for (int i = 0; i < 200; ++i) many.push_back(request(0, i, i));
  loader.submit(many);
  tensor::BrickReconstructor reconstructor;
  ta::DecodeScratch scratch;
  loader.drain(reconstructor, scratch);
  loader.wait_idle();
  EXPECT_EQ(done.load(), 200);
}
