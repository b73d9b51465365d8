#include "strata/lod/brick_loader.hpp"

#include <algorithm>
#include <utility>

#include "strata/core/threads.hpp"

namespace strata::lod {

namespace {

// Heap order: the top is the coarsest level, then the smallest depth.
bool later(const LoadRequest& a, const LoadRequest& b) {
  if (a.key.brick.level != b.key.brick.level) return a.key.brick.level < b.key.brick.level;
  return a.depth > b.depth;
}

}  // namespace

int default_loader_threads() { return std::clamp(thread_count() - 1, 1, 2); }

BrickLoader::BrickLoader(Job job, int threads) : job_(std::move(job)) {
  const int n = threads > 0 ? threads : default_loader_threads();
  workers_.reserve(std::size_t(n));
  for (int i = 0; i < n; ++i) workers_.emplace_back([this](std::stop_token stop) { work(stop); });
}

BrickLoader::~BrickLoader() {
  {
    std::lock_guard lock(mutex_);
    heap_.clear();
  }
  for (auto& w : workers_) w.request_stop();
  wake_.notify_all();
  workers_.clear();  // joins
}

void BrickLoader::submit(const std::vector<LoadRequest>& requests) {
  {
    std::unordered_set<RankedKey, RankedKeyHash> seen;  // duplicates keep the first request
    std::lock_guard lock(mutex_);
    heap_.clear();
    for (const LoadRequest& r : requests) {
      if (running_.contains(r.key) || !seen.insert(r.key).second) continue;
      heap_.push_back(r);
    }
    std::make_heap(heap_.begin(), heap_.end(), later);
  }
  wake_.notify_all();
  idle_.notify_all();  // an emptied queue may have made the loader idle
}

bool BrickLoader::pop(LoadRequest& out) {
  if (heap_.empty()) return false;
  std::pop_heap(heap_.begin(), heap_.end(), later);
  out = heap_.back();
  heap_.pop_back();
  running_.insert(out.key);
  return true;
}

void BrickLoader::run(const LoadRequest& request, tensor::BrickReconstructor& reconstructor, ta::DecodeScratch& scratch) {
  std::exception_ptr error;
  try {
    job_(request, reconstructor, scratch);
  } catch (...) {
    error = std::current_exception();
  }
  {
    std::lock_guard lock(mutex_);
    running_.erase(request.key);
    if (error && !failure_) failure_ = error;
  }
  idle_.notify_all();
}

void BrickLoader::work(std::stop_token stop) {
  tensor::BrickReconstructor reconstructor;
  ta::DecodeScratch scratch;
  while (true) {
    LoadRequest request;
    {
      std::unique_lock lock(mutex_);
      if (!wake_.wait(lock, stop, [this] { return !heap_.empty(); })) return;
      pop(request);
    }
    run(request, reconstructor, scratch);
  }
}

void BrickLoader::drain(tensor::BrickReconstructor& reconstructor, ta::DecodeScratch& scratch) {
  while (true) {
    LoadRequest request;
    {
      std::lock_guard lock(mutex_);
      if (!pop(request)) return;
    }
    run(request, reconstructor, scratch);
  }
}

void BrickLoader::wait_idle() {
  std::unique_lock lock(mutex_);
  idle_.wait(lock, [this] { return heap_.empty() && running_.empty(); });
  if (failure_) std::rethrow_exception(std::exchange(failure_, nullptr));
}

void BrickLoader::rethrow_failure() {
  std::lock_guard lock(mutex_);
  if (failure_) std::rethrow_exception(std::exchange(failure_, nullptr));
}

std::size_t BrickLoader::queued() const {
  std::lock_guard lock(mutex_);
  return heap_.size();
}

std::size_t BrickLoader::running() const {
  std::lock_guard lock(mutex_);
  return running_.size();
}

}  // namespace strata::lod
