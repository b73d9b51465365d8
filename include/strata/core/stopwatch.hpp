#pragma once
// Elapsed wall time for the figures reports and statistics carry (frame ms, encode seconds).
#include <chrono>

namespace strata {

using SteadyClock = std::chrono::steady_clock;

inline double seconds_since(SteadyClock::time_point start) {
  return std::chrono::duration<double>(SteadyClock::now() - start).count();
}
inline double ms_since(SteadyClock::time_point start) { return 1e3 * seconds_since(start); }

}  // namespace strata
