#pragma once

namespace strata {

// The single place that decides how many threads data-parallel work uses. Default: the
// machine's hardware threads. `strata --threads N` calls set_thread_count(N).
int thread_count();
// n <= 0 restores the default. Applies to OpenMP loops and to our own worker pools.
void set_thread_count(int n);

}  // namespace strata
