#pragma once
// malloc settings for the codecs, shared by `strata` and `strata-mpi`.
#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace strata::cli {

// The codecs allocate and free brick-sized buffers (B^3 floats = 128 KiB at B = 32, glibc's
// default mmap threshold) on every worker thread for every brick. With glibc's defaults those
// come from fresh mappings or from arena memory just returned to the kernel, and each brick pays
// its page faults again: on a 35 Mvoxel MRI the error-target encoder took 76 k page faults and
// 4.9 s of CPU, against 16.5 k and 3.7 s with the thresholds below (perf stat, same output).
// Large buffers (volumes, slabs) are still mapped and returned.
inline void keep_brick_buffers_mapped() {
#if defined(__GLIBC__)
  mallopt(M_MMAP_THRESHOLD, 64 << 20);
  mallopt(M_TRIM_THRESHOLD, 256 << 20);
#endif
}

}  // namespace strata::cli
