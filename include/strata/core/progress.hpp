#pragma once
/// @file
/// @brief Progress reporting: the one ProgressSink interface every long operation reports through,
/// its terminal, JSON-lines and silent implementations, and a scoped task.
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

namespace strata {

/// @brief Every long operation reports through this interface. Implementations: a terminal bar on
/// stderr (percent, rate, ETA), JSON lines, or nothing (tests). advance() is thread-safe.
class ProgressSink {
 public:
  virtual ~ProgressSink() = default;
  /// @brief Starts a task of `total` units (voxels, bricks, bytes...) named `task`, e.g. "compress".
  virtual void begin(std::string_view task, std::uint64_t total, std::string_view unit = "") = 0;
  virtual void advance(std::uint64_t units) = 0;
  virtual void end() = 0;
};

/// @brief Which sink make_progress_sink builds (the CLI's `--progress auto|bar|json|none`).
enum class ProgressMode { automatic, bar, json, silent };

/// @brief automatic: a bar when stderr is a terminal, otherwise silent.
std::unique_ptr<ProgressSink> make_progress_sink(ProgressMode mode);
/// @brief "auto" | "bar" | "json" | "none"; throws ParameterError("progress_mode") otherwise.
ProgressMode parse_progress_mode(std::string_view progress_mode);

/// @brief A sink that discards everything; the default argument of long operations.
ProgressSink& silent_progress();

/// @brief Scoped task: begin() on construction, end() on destruction (also on exceptions).
class ProgressTask {
 public:
  ProgressTask(ProgressSink& sink, std::string_view task, std::uint64_t total, std::string_view unit = "")
      : sink_(sink) {
    sink_.begin(task, total, unit);
  }
  ~ProgressTask() { sink_.end(); }
  ProgressTask(const ProgressTask&) = delete;
  ProgressTask& operator=(const ProgressTask&) = delete;
  void advance(std::uint64_t units) { sink_.advance(units); }

 private:
  ProgressSink& sink_;
};

}  // namespace strata
