#include "strata/core/threads.hpp"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <string>
#include <thread>

#include "strata/core/error.hpp"

namespace strata {

namespace {
std::atomic<int> g_thread_count{0};  // 0 = not set: use the hardware default
}  // namespace

int hardware_threads() { return std::max(1, int(std::thread::hardware_concurrency())); }

int max_thread_count() { return kMaxThreadsPerHardwareThread * hardware_threads(); }

int thread_count() {
  int n = g_thread_count.load();
  return n > 0 ? n : hardware_threads();
}

void set_thread_count(int n) {
  if (n < 0)
    throw ParameterError("n", "the thread count must be 0 (all hardware threads) or more, got " + std::to_string(n));
  if (n > max_thread_count())
    throw ParameterError("n", "the thread count may be at most " + std::to_string(max_thread_count()) + " (" +
                                  std::to_string(kMaxThreadsPerHardwareThread) + " x the " +
                                  std::to_string(hardware_threads()) + " hardware threads of this machine), got " +
                                  std::to_string(n));
  g_thread_count.store(n);
  omp_set_num_threads(thread_count());
}

}  // namespace strata
