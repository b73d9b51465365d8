#pragma once
// Bulk fetching of a remote file's brick payloads on a thread of its own, so a progressive frame
// hands its misses over and draws its stand-ins at once; the loader threads then find the bytes in
// the file's range cache instead of paying a round trip per brick (BrickProvider).
#include <condition_variable>
#include <mutex>
#include <stop_token>
#include <thread>
#include <vector>

#include "strata/store/container.hpp"

namespace strata::lod {

class PayloadPrefetcher {
 public:
  /// `container` must outlive the prefetcher.
  explicit PayloadPrefetcher(const store::ContainerReader& container);
  ~PayloadPrefetcher();  // a fetch under way finishes first
  PayloadPrefetcher(const PayloadPrefetcher&) = delete;
  PayloadPrefetcher& operator=(const PayloadPrefetcher&) = delete;

  /// Fetches `entries` soon; replaces a batch not yet started (the view has moved on).
  void post(std::vector<const store::BrickEntry*> entries);

 private:
  void run(std::stop_token stop);

  const store::ContainerReader& container_;
  std::mutex mutex_;
  std::condition_variable_any wake_;
  std::vector<const store::BrickEntry*> pending_;
  std::jthread thread_;  // last: stopped and joined before the rest goes
};

}  // namespace strata::lod
