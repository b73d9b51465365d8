// RemovedOnSignal and install_signal_cleanup (include/strata/io/signal_cleanup.hpp). The handler
// may run on any thread at any instant, so the registry is a fixed table of slots changed only by
// atomic compare-and-swap, and the removal uses system calls alone (unlinkat, openat, getdents64,
// rmdir: async-signal-safe, no allocation, no locks).
#include "strata/io/signal_cleanup.hpp"

#include <fcntl.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <cstring>

namespace strata::io {

namespace {

// A slot's states. Only the owner moves it free -> filling -> active -> releasing -> free; the
// handler moves active -> claimed, after which the owner leaves it alone (the process is ending).
enum SlotState : int { kFree = 0, kFilling = 1, kActive = 2, kReleasing = 3, kClaimed = 4 };

struct Slot {
  std::atomic<int> state{kFree};
  std::atomic<char*> path{nullptr};
};
static_assert(std::atomic<int>::is_always_lock_free && std::atomic<char*>::is_always_lock_free,
              "the signal handler needs lock-free atomics");

constexpr int kSlots = 4096;
Slot g_slots[kSlots];
std::atomic<int> g_next{0};          // where the search for a free slot starts
std::atomic<bool> g_cleaning{false};  // a handler is removing the paths

// Folders nest this deep at most in what Strata writes (an OME-Zarr level's chunk keys).
constexpr int kMaxDepth = 12;
constexpr std::size_t kDirBuffer = 4096;
alignas(8) char g_dir_buffers[kMaxDepth][kDirBuffer];

struct LinuxDirent64 {
  ino64_t d_ino;
  off64_t d_off;
  unsigned short d_reclen;
  unsigned char d_type;
  char d_name[1];
};

// Removes `name` (relative to the folder `parent`): a file, or a folder and what it holds.
void remove_entry(int parent, const char* name, int depth) {
  if (::unlinkat(parent, name, 0) == 0 || errno == ENOENT) return;
  if (errno != EISDIR && errno != EPERM) return;
  if (depth >= kMaxDepth) return;
  const int dir = ::openat(parent, name, O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  if (dir < 0) return;
  char* buffer = g_dir_buffers[depth];
  // Entries removed while a folder is listed may shift the listing: list it again until a pass
  // finds nothing left to remove.
  for (int pass = 0; pass < 64; ++pass) {
    ::lseek(dir, 0, SEEK_SET);
    bool removed = false;
    for (long n; (n = ::syscall(SYS_getdents64, dir, buffer, kDirBuffer)) > 0;) {
      for (long at = 0; at < n;) {
        const auto* entry = reinterpret_cast<const LinuxDirent64*>(buffer + at);
        at += entry->d_reclen;
        const char* child = entry->d_name;
        if (std::strcmp(child, ".") == 0 || std::strcmp(child, "..") == 0) continue;
        remove_entry(dir, child, depth + 1);
        removed = true;
      }
    }
    if (!removed) break;
  }
  ::close(dir);
  ::unlinkat(parent, name, AT_REMOVEDIR);
}

void remove_registered() {
  for (Slot& slot : g_slots) {
    int expected = kActive;
    if (!slot.state.compare_exchange_strong(expected, kClaimed)) continue;
    if (const char* path = slot.path.load()) remove_entry(AT_FDCWD, path, 0);
  }
}

constexpr int kSignals[] = {SIGINT, SIGTERM, SIGHUP};

extern "C" void strata_io_remove_on_signal(int sig) {
  const int saved_errno = errno;
  if (g_cleaning.exchange(true)) {
    // Another thread is cleaning up for an earlier signal and will end the process.
    for (;;) ::pause();
  }
  remove_registered();
  // End by the same signal: restore its default action; it is blocked while this handler runs,
  // so it is delivered (and ends the process) as the handler returns.
  struct sigaction dfl {};
  dfl.sa_handler = SIG_DFL;
  sigemptyset(&dfl.sa_mask);
  ::sigaction(sig, &dfl, nullptr);
  ::raise(sig);
  errno = saved_errno;
}

}  // namespace

RemovedOnSignal::RemovedOnSignal(const std::filesystem::path& path) {
  if (path.empty()) return;
  std::error_code ec;
  std::filesystem::path absolute = std::filesystem::absolute(path, ec);
  if (ec) absolute = path;
  char* copy = ::strdup(absolute.c_str());
  if (!copy) return;
  const int start = g_next.fetch_add(1, std::memory_order_relaxed);
  for (int i = 0; i < kSlots; ++i) {
    const int index = int((unsigned(start) + unsigned(i)) % unsigned(kSlots));
    Slot& slot = g_slots[index];
    int expected = kFree;
    if (!slot.state.compare_exchange_strong(expected, kFilling)) continue;
    slot.path.store(copy);
    slot.state.store(kActive);
    slot_ = index;
    return;
  }
  std::free(copy);  // the table is full: this path is not covered
}

RemovedOnSignal& RemovedOnSignal::operator=(RemovedOnSignal&& other) noexcept {
  if (this != &other) {
    release();
    slot_ = other.slot_;
    other.slot_ = -1;
  }
  return *this;
}

void RemovedOnSignal::release() noexcept {
  if (slot_ < 0) return;
  Slot& slot = g_slots[slot_];
  slot_ = -1;
  int expected = kActive;
  // A slot the handler has claimed is its own now (the process is ending): leave it be.
  if (!slot.state.compare_exchange_strong(expected, kReleasing)) return;
  std::free(slot.path.exchange(nullptr));
  slot.state.store(kFree);
}

void install_signal_cleanup() {
  struct sigaction action {};
  action.sa_handler = strata_io_remove_on_signal;
  sigemptyset(&action.sa_mask);
  for (const int sig : kSignals) sigaddset(&action.sa_mask, sig);  // one handler at a time per thread
  action.sa_flags = SA_RESTART;
  for (const int sig : kSignals) {
    struct sigaction old {};
    // A signal ignored by whoever started the process (nohup's SIGHUP) stays ignored.
    if (::sigaction(sig, nullptr, &old) == 0 && old.sa_handler == SIG_IGN) continue;
    ::sigaction(sig, &action, nullptr);
  }
}

}  // namespace strata::io
