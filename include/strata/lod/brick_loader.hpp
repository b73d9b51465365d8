#pragma once
/// @file
/// @brief The asynchronous loader (paper 1, §3 and §6.1): worker threads (std::jthread) take brick
/// requests from a priority queue, coarse levels first and nearest first within a level, and run
/// a job that fetches, dequantizes and reconstructs into the caches. Each worker owns its
/// BrickReconstructor and decode scratch. A new frame's requests replace the queued ones, so
/// work for views the user has left is dropped; requests already running finish.
#include <condition_variable>
#include <cstdint>
#include <exception>
#include <functional>
#include <mutex>
#include <stop_token>
#include <thread>
#include <unordered_set>
#include <vector>

#include "strata/lod/brick_cache.hpp"
#include "strata/ta/brick_codec.hpp"
#include "strata/tensor/reconstruct.hpp"

namespace strata::lod {

/// @brief One brick to load at one rank, with its view depth (nearer first within a level).
struct LoadRequest {
  RankedKey key;
  double depth = 0;  // view depth of the brick (or of the cut brick it stands in for)
};

/// @brief Loader threads when the caller does not choose: one per spare core, at most two, so the
/// render threads keep the rest of the machine.
int default_loader_threads();

/// @brief The loader itself (see the file comment).
class BrickLoader {
 public:
  using Job = std::function<void(const LoadRequest&, tensor::BrickReconstructor&, ta::DecodeScratch&)>;

  /// @brief threads = 0: default_loader_threads(). `job` must be thread-safe.
  BrickLoader(Job job, int threads = 0);
  ~BrickLoader();  // drops the queue, lets running jobs finish, joins the workers
  BrickLoader(const BrickLoader&) = delete;
  BrickLoader& operator=(const BrickLoader&) = delete;

  /// @brief Replaces the queue by `requests` (duplicates and requests already running are skipped).
  void submit(const std::vector<LoadRequest>& requests);
  /// @brief Runs queued requests on the calling thread too, until the queue is empty (exact frames).
  void drain(tensor::BrickReconstructor& reconstructor, ta::DecodeScratch& scratch);
  /// @brief Blocks until nothing is queued or running; rethrows the first failure of a job since the
  /// last call (a corrupt brick), so errors reach the caller instead of dying in a thread.
  void wait_idle();
  /// @brief Rethrows a pending job failure without waiting.
  void rethrow_failure();

  std::size_t queued() const;
  std::size_t running() const;

 private:
  void work(std::stop_token stop);
  bool pop(LoadRequest& out);  // under mutex_
  void run(const LoadRequest& request, tensor::BrickReconstructor& reconstructor, ta::DecodeScratch& scratch);

  Job job_;
  mutable std::mutex mutex_;
  std::condition_variable_any wake_;  // work arrived or stop requested
  std::condition_variable idle_;      // a job finished
  std::vector<LoadRequest> heap_;     // std::push_heap order: coarse, then near, on top
  std::unordered_set<RankedKey, RankedKeyHash> running_;
  std::exception_ptr failure_;
  std::vector<std::jthread> workers_;  // last: stopped and joined before the rest goes
};

}  // namespace strata::lod
