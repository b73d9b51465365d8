#include "lod/payload_prefetcher.hpp"

namespace strata::lod {

PayloadPrefetcher::PayloadPrefetcher(const store::ContainerReader& container)
    : container_(container), thread_([this](std::stop_token stop) { run(stop); }) {}

PayloadPrefetcher::~PayloadPrefetcher() {
  thread_.request_stop();
  wake_.notify_all();
}

void PayloadPrefetcher::post(std::vector<const store::BrickEntry*> entries) {
  if (entries.empty()) return;
  {
    std::lock_guard lock(mutex_);
    pending_ = std::move(entries);
  }
  wake_.notify_one();
}

void PayloadPrefetcher::run(std::stop_token stop) {
  while (true) {
    std::vector<const store::BrickEntry*> batch;
    {
      std::unique_lock lock(mutex_);
      if (!wake_.wait(lock, stop, [this] { return !pending_.empty(); })) return;  // stop requested
      batch.swap(pending_);
    }
    try {
      container_.prefetch(batch);
    } catch (...) {
      // Dropped: the loader reads each brick itself and reports what fails there.
    }
  }
}

}  // namespace strata::lod
