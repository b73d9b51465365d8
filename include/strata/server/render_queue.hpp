#pragma once
/// @file
/// @brief The bounded queue of render jobs behind `GET /api/datasets/{id}/render`: one worker
/// thread runs them in arrival order (each frame already uses every core), so a frame never
/// competes with another for the CPU.
///
/// Supersession (docs/viewer.md): jobs carrying the same client id are ordered by their
/// sequence number. When a job arrives, queued jobs of its client are answered 204 at once (a
/// viewer shows only its newest frame, so older ones are dropped, never rendered); a job whose
/// number is not above the newest accepted one of its client is answered 204 without queueing.
/// A job that finds the queue full is answered 503 with `Retry-After: 1`. A running job is never
/// interrupted.
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <unordered_map>

#include "strata/server/http_message.hpp"

namespace strata::server {

class RenderQueue {
 public:
  using Job = std::function<HttpResponse()>;

  /// @brief At most `capacity` jobs wait (>= 1; the running one is not counted).
  explicit RenderQueue(std::size_t capacity);
  ~RenderQueue();  // stop(), then joins the worker
  RenderQueue(const RenderQueue&) = delete;
  RenderQueue& operator=(const RenderQueue&) = delete;

  /// @brief Queues `job` and blocks until it has run (its response; an exception becomes a 500
  /// JSON error), was superseded (204) or could not be queued (503, Retry-After: 1). `client`
  /// empty: no supersession. Thread-safe.
  HttpResponse run(const std::string& client, std::optional<std::uint64_t> seq, Job job);

  /// @brief While paused the worker starts no job (queued jobs wait; tests use it to fill the
  /// queue deterministically).
  void pause();
  void resume();
  /// @brief Answers every queued job 503 and refuses new ones; the running job finishes.
  void stop();

  std::size_t queued() const;
  std::size_t capacity() const { return capacity_; }

 private:
  struct Entry;
  void work();
  static HttpResponse superseded();
  static HttpResponse unavailable(const std::string& why);

  const std::size_t capacity_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::shared_ptr<Entry>> queue_;
  std::unordered_map<std::string, std::uint64_t> newest_;  // newest accepted seq per client
  bool paused_ = false, stopping_ = false;
  std::thread worker_;  // last: started after everything it uses
};

}  // namespace strata::server
