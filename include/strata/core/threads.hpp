#pragma once

namespace strata {

// The single place that decides how many threads data-parallel work uses. Default: the
// machine's hardware threads. `strata --threads N` calls set_thread_count(N).
int thread_count();
/// @brief The machine's hardware threads (at least 1).
int hardware_threads();
/// @brief Threads per hardware thread set_thread_count accepts at most: more only adds
/// scheduling and per-thread buffers, and the runtimes fail (crash or abort) long before
/// 100000 threads.
inline constexpr int kMaxThreadsPerHardwareThread = 4;
/// @brief The largest count set_thread_count accepts: kMaxThreadsPerHardwareThread x hardware_threads().
int max_thread_count();
/// @brief n == 0 restores the default. Applies to OpenMP loops and to our own worker pools.
/// Throws ParameterError("n"), changing nothing, when n < 0 or n > max_thread_count().
void set_thread_count(int n);

}  // namespace strata
