// The one way the package runs work on several threads: items 0..n-1 (blocks
// of runs, grid points) shared by `threads` OpenMP threads, in waves, with a
// check for a user interrupt on the main thread between waves (R's API is
// never called from a parallel region). Each item must be computed the same
// way whichever thread takes it, so results do not depend on the number of
// threads; `body(item, thread)` gets the thread's number (0-based) to pick
// its own workspace, and must not throw. Without OpenMP, one thread.
#ifndef GRIDDY_PARALLEL_WAVES_H
#define GRIDDY_PARALLEL_WAVES_H

#include <Rcpp.h>
#include <algorithm>
#ifdef _OPENMP
#include <omp.h>
#endif

// A loop over the runs of a block in vector instructions (an OpenMP simd
// loop); without OpenMP, left to the compiler.
#ifdef _OPENMP
#define GRIDDY_SIMD _Pragma("omp simd")
#else
#define GRIDDY_SIMD
#endif

namespace griddy {

// The threads a parallel region may use: at least 1, and 1 without OpenMP.
inline int usable_threads(int threads) {
#ifdef _OPENMP
  return std::max(1, threads);
#else
  (void)threads;
  return 1;
#endif
}

template <typename Body>
void parallel_waves(long long n, long long wave, int threads, Body body) {
  threads = usable_threads(threads);
  wave = std::max(1LL, wave);
  for (long long first = 0; first < n; first += wave) {
    Rcpp::checkUserInterrupt();
    const long long last = std::min(n, first + wave);
#ifdef _OPENMP
#pragma omp parallel for num_threads(threads) schedule(dynamic)
    for (long long item = first; item < last; ++item) body(item, omp_get_thread_num());
#else
    for (long long item = first; item < last; ++item) body(item, 0);
#endif
  }
}

}  // namespace griddy

#endif
