#pragma once
/// @file
/// @brief What a run removes when a signal stops it: the outputs it has in progress
/// (`<name>.tmp`, staging folders `<folder>.tmp`), the members of a volume set (`.<name>.volumeN.part`),
/// named temporaries. The writers register each such path for as long as it exists; a program
/// (the `strata` command line) installs the handlers that remove them, the library never does:
/// a program that embeds it (the Python module) keeps its own signal handling.
///
/// SIGKILL cannot be caught: what a killed run leaves is replaced or removed by the next run
/// that writes the same output (docs/reliability.md, "What happens on a kill").
#include <filesystem>

namespace strata::io {

/// @brief While this object lives (and until release()), `path` — a file, or a folder with
/// everything in it — is removed when the process is stopped by one of the signals
/// install_signal_cleanup() handles. It removes nothing itself: the owner removes or renames the
/// path as it always did, then lets the registration go. Register before the path is created,
/// so no instant exists in which a signal would leave it behind. At most 4096 paths are
/// registered at once; beyond that a path is not covered (nothing fails).
class RemovedOnSignal {
 public:
  RemovedOnSignal() = default;
  explicit RemovedOnSignal(const std::filesystem::path& path);
  ~RemovedOnSignal() { release(); }
  RemovedOnSignal(RemovedOnSignal&& other) noexcept : slot_(other.slot_) { other.slot_ = -1; }
  RemovedOnSignal& operator=(RemovedOnSignal&& other) noexcept;
  RemovedOnSignal(const RemovedOnSignal&) = delete;
  RemovedOnSignal& operator=(const RemovedOnSignal&) = delete;
  /// @brief Forgets the path (after it was renamed into place or removed).
  void release() noexcept;

 private:
  int slot_ = -1;
};

/// @brief Installs handlers for SIGINT, SIGTERM and SIGHUP that remove every registered path
/// and then end the process by the same signal (its default action), so the exit status still
/// tells which one. A handler installed later for one of them (`strata serve` stopping on
/// SIGINT) takes precedence while it is installed.
void install_signal_cleanup();

}  // namespace strata::io
