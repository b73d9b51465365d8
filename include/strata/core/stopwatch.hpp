#pragma once
/// @file
/// @brief Elapsed wall time for the figures reports and statistics carry (frame ms, encode seconds),
/// and the process's CPU time.
#include <sys/resource.h>

#include <chrono>

namespace strata {

using SteadyClock = std::chrono::steady_clock;

/// @brief Wall seconds (steady clock) since `start`; ms_since gives the same in milliseconds.
inline double seconds_since(SteadyClock::time_point start) {
  return std::chrono::duration<double>(SteadyClock::now() - start).count();
}
inline double ms_since(SteadyClock::time_point start) { return 1e3 * seconds_since(start); }

/// @brief CPU seconds used by the process so far (all threads, user + system; getrusage(RUSAGE_SELF)).
inline double cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

}  // namespace strata
