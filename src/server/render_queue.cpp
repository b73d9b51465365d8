#include "strata/server/render_queue.hpp"

#include <exception>
#include <future>

#include "strata/core/error.hpp"

namespace strata::server {

struct RenderQueue::Entry {
  std::string client;
  Job job;
  std::promise<HttpResponse> done;
};

namespace {

// Forgetting the clients' newest numbers only lets a stale frame through once; it bounds the
// table when many short-lived clients come and go.
constexpr std::size_t kMaxClients = 4096;

}  // namespace

RenderQueue::RenderQueue(std::size_t capacity) : capacity_(capacity) {
  if (capacity == 0) throw ParameterError("capacity", "the render queue needs room for at least one job");
  worker_ = std::thread([this] { work(); });
}

RenderQueue::~RenderQueue() {
  stop();
  worker_.join();
}

HttpResponse RenderQueue::superseded() {
  HttpResponse r;
  r.status = 204;
  r.content_type.clear();
  return r;
}

HttpResponse RenderQueue::unavailable(const std::string& why) {
  HttpResponse r = error_response(503, why);
  r.set_header("Retry-After", "1");
  return r;
}

HttpResponse RenderQueue::run(const std::string& client, std::optional<std::uint64_t> seq, Job job) {
  auto entry = std::make_shared<Entry>();
  entry->client = client;
  entry->job = std::move(job);
  std::future<HttpResponse> result = entry->done.get_future();
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return unavailable("the server is shutting down");
    if (!client.empty()) {
      const auto newest = newest_.find(client);
      if (newest != newest_.end() && seq.value_or(0) <= newest->second) return superseded();
      for (auto it = queue_.begin(); it != queue_.end();) {
        if ((*it)->client != client) {
          ++it;
          continue;
        }
        (*it)->done.set_value(superseded());
        it = queue_.erase(it);
      }
    }
    if (queue_.size() >= capacity_) return unavailable("the render queue is full");
    if (!client.empty()) {
      if (newest_.size() >= kMaxClients) newest_.clear();
      newest_[client] = seq.value_or(0);
    }
    queue_.push_back(entry);
  }
  wake_.notify_all();
  return result.get();
}

void RenderQueue::work() {
  std::unique_lock lock(mutex_);
  for (;;) {
    wake_.wait(lock, [this] { return stopping_ || (!paused_ && !queue_.empty()); });
    if (queue_.empty()) return;  // stopping, and stop() has answered the rest
    std::shared_ptr<Entry> entry = queue_.front();
    queue_.pop_front();
    lock.unlock();
    HttpResponse response;
    try {
      response = entry->job();
    } catch (const std::exception& e) {
      response = internal_error_response(e);
    }
    entry->done.set_value(std::move(response));
    lock.lock();
  }
}

void RenderQueue::pause() {
  std::lock_guard lock(mutex_);
  paused_ = true;
}

void RenderQueue::resume() {
  {
    std::lock_guard lock(mutex_);
    paused_ = false;
  }
  wake_.notify_all();
}

void RenderQueue::stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    for (const auto& entry : queue_) entry->done.set_value(unavailable("the server is shutting down"));
    queue_.clear();
  }
  wake_.notify_all();
}

std::size_t RenderQueue::queued() const {
  std::lock_guard lock(mutex_);
  return queue_.size();
}

}  // namespace strata::server
