#include "strata/core/progress.hpp"

#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <mutex>
#include <string>

#include "strata/core/error.hpp"

namespace strata {

namespace {

using Clock = std::chrono::steady_clock;

class SilentSink final : public ProgressSink {
 public:
  void begin(std::string_view, std::uint64_t, std::string_view) override {}
  void advance(std::uint64_t) override {}
  void end() override {}
};

// Shared bookkeeping: counts units atomically and lets one thread at a time print, at most
// every `interval`, so hot loops can call advance() freely.
class ThrottledSink : public ProgressSink {
 public:
  explicit ThrottledSink(std::chrono::milliseconds interval) : interval_(interval) {}

  void begin(std::string_view task, std::uint64_t total, std::string_view unit) override {
    std::lock_guard lock(mutex_);
    task_ = task;
    unit_ = unit;
    total_ = total;
    done_ = 0;
    start_ = last_print_ = Clock::now();
    on_begin();
  }
  void advance(std::uint64_t units) override {
    done_ += units;
    auto now = Clock::now();
    if (now - last_print_ < interval_) return;
    std::unique_lock lock(mutex_, std::try_to_lock);
    if (!lock.owns_lock()) return;
    last_print_ = now;
    on_update(false);
  }
  void end() override {
    std::lock_guard lock(mutex_);
    on_update(true);
  }

 protected:
  virtual void on_begin() {}
  virtual void on_update(bool finished) = 0;
  double elapsed_seconds() const { return std::chrono::duration<double>(Clock::now() - start_).count(); }

  std::string task_, unit_;
  std::uint64_t total_ = 0;
  std::atomic<std::uint64_t> done_{0};

 private:
  std::chrono::milliseconds interval_;
  std::mutex mutex_;
  Clock::time_point start_, last_print_;
};

std::string human_rate(double per_second) {
  const char* suffixes[] = {"", "k", "M", "G", "T"};
  int i = 0;
  while (per_second >= 1000.0 && i < 4) {
    per_second /= 1000.0;
    ++i;
  }
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f %s", per_second, suffixes[i]);
  return buf;
}

std::string human_duration(double seconds) {
  if (!(seconds >= 0) || seconds > 1e7) return "--:--";
  long s = long(seconds + 0.5);
  char buf[32];
  if (s >= 3600) std::snprintf(buf, sizeof buf, "%ld:%02ld:%02ld", s / 3600, (s / 60) % 60, s % 60);
  else std::snprintf(buf, sizeof buf, "%02ld:%02ld", s / 60, s % 60);
  return buf;
}

// "compress [#########.........]  45.0%  12.3 Mvox/s  ETA 00:07" redrawn in place on stderr.
class TerminalBarSink final : public ThrottledSink {
 public:
  TerminalBarSink() : ThrottledSink(std::chrono::milliseconds(100)) {}

 protected:
  void on_update(bool finished) override {
    const std::uint64_t done = finished ? total_ : done_.load();
    const double fraction = total_ ? std::min(1.0, double(done) / double(total_)) : 1.0;
    const double seconds = elapsed_seconds();
    const double rate = seconds > 0 ? double(done) / seconds : 0;
    const double eta = rate > 0 ? double(total_ - std::min(done, total_)) / rate : -1;
    constexpr int kWidth = 30;
    std::string bar(kWidth, '.');
    for (int i = 0; i < int(fraction * kWidth); ++i) bar[i] = '#';
    std::fprintf(stderr, "\r%-12s [%s] %5.1f%%  %s%s/s  %s %s\x1b[K", task_.c_str(), bar.c_str(), 100 * fraction,
                 human_rate(rate).c_str(), unit_.c_str(), finished ? "in" : "ETA",
                 human_duration(finished ? seconds : eta).c_str());
    if (finished) std::fputc('\n', stderr);
    std::fflush(stderr);
  }
};

// One JSON object per line on stderr, for GUIs and scripts (--progress=json).
class JsonLinesSink final : public ThrottledSink {
 public:
  JsonLinesSink() : ThrottledSink(std::chrono::milliseconds(500)) {}

 protected:
  void on_begin() override { print("begin", 0); }
  void on_update(bool finished) override { print(finished ? "end" : "progress", finished ? total_ : done_.load()); }

 private:
  void print(const char* event, std::uint64_t done) {
    std::fprintf(stderr, "{\"event\":\"%s\",\"task\":\"%s\",\"done\":%llu,\"total\":%llu,\"unit\":\"%s\",\"seconds\":%.3f}\n",
                 event, task_.c_str(), (unsigned long long)done, (unsigned long long)total_, unit_.c_str(),
                 elapsed_seconds());
    std::fflush(stderr);
  }
};

}  // namespace

ProgressSink& silent_progress() {
  static SilentSink sink;
  return sink;
}

std::unique_ptr<ProgressSink> make_progress_sink(ProgressMode mode) {
  if (mode == ProgressMode::automatic) mode = isatty(STDERR_FILENO) ? ProgressMode::bar : ProgressMode::silent;
  switch (mode) {
    case ProgressMode::bar: return std::make_unique<TerminalBarSink>();
    case ProgressMode::json: return std::make_unique<JsonLinesSink>();
    default: return std::make_unique<SilentSink>();
  }
}

ProgressMode parse_progress_mode(std::string_view progress_mode) {
  if (progress_mode == "auto") return ProgressMode::automatic;
  if (progress_mode == "bar") return ProgressMode::bar;
  if (progress_mode == "json") return ProgressMode::json;
  if (progress_mode == "none" || progress_mode == "off") return ProgressMode::silent;
  throw ParameterError("progress_mode", "expected auto, bar, json or none, got '" + std::string(progress_mode) + "'");
}

}  // namespace strata
