#include "strata/core/threads.hpp"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <thread>

namespace strata {

namespace {
std::atomic<int> g_thread_count{0};  // 0 = not set: use the hardware default

int hardware_threads() { return std::max(1, int(std::thread::hardware_concurrency())); }
}  // namespace

int thread_count() {
  int n = g_thread_count.load();
  return n > 0 ? n : hardware_threads();
}

void set_thread_count(int n) {
  g_thread_count.store(n > 0 ? n : 0);
  omp_set_num_threads(thread_count());
}

}  // namespace strata
