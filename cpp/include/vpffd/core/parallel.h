#pragma once
/// @file parallel.h
/// Thread count resolution and deterministic chunked loops.
///
/// Work is split into chunks whose number does not depend on the thread count,
/// and partial results are combined in chunk order, so a run on 1 thread and a
/// run on N threads give bit-identical results.

#include <algorithm>

#include "vpffd/core/types.h"

#ifdef _OPENMP
#include <omp.h>
#endif

namespace vpffd {

/// True when the core was compiled with OpenMP.
inline bool has_openmp() {
#ifdef _OPENMP
  return true;
#else
  return false;
#endif
}

/// Threads to use: `requested` if positive, else every hardware thread OpenMP offers.
inline int resolve_threads(int requested) {
#ifdef _OPENMP
  return requested > 0 ? requested : omp_get_max_threads();
#else
  (void)requested;
  return 1;
#endif
}

/// Below this many items a loop runs on the calling thread: a parallel region
/// costs a few microseconds on an idle machine, but up to a scheduler time slice
/// (milliseconds) when the cores are shared, which dwarfs small loops.
inline constexpr Index kParallelMin = 32768;

/// Calls f(begin, end) on contiguous pieces of [0, n), in parallel.
template <class F>
void parallel_range(Index n, int threads, F&& f) {
  threads = resolve_threads(threads);
  if (threads <= 1 || n < kParallelMin) {
    f(Index(0), n);
    return;
  }
#ifdef _OPENMP
#pragma omp parallel num_threads(threads)
  {
    const Index t = omp_get_thread_num(), nt = omp_get_num_threads();
    const Index b = n * t / nt, e = n * (t + 1) / nt;
    if (b < e) f(b, e);
  }
#else
  f(Index(0), n);
#endif
}

/// Calls f(i) for each of `count` items, in parallel (each item on one thread,
/// dynamically scheduled: items of uneven size) when `work`, the items' total size
/// (e.g. their vertices), is at least kParallelMin. Items write results of their own,
/// combined by the caller in item order: the same bits for any thread count.
template <class F>
void parallel_items(Index count, Index work, int threads, F&& f) {
  threads = resolve_threads(threads);
#ifdef _OPENMP
#pragma omp parallel for schedule(dynamic) num_threads(threads) if (threads > 1 && count > 1 && work >= kParallelMin)
#endif
  for (Index i = 0; i < count; ++i) f(i);
}

/// Number of chunks for a reduction over n items: fixed by n alone (not by the
/// thread count), so results are reproducible across thread counts.
inline int chunk_count(Index n, Index min_chunk = 8192, int max_chunks = 64) {
  return static_cast<int>(std::clamp<Index>(n / min_chunk, 1, max_chunks));
}

/// Calls f(chunk, begin, end) for each of `chunks` contiguous pieces of [0, n).
template <class F>
void parallel_chunks(Index n, int chunks, int threads, F&& f) {
  threads = resolve_threads(threads);
#ifdef _OPENMP
#pragma omp parallel for schedule(static) num_threads(threads) if (threads > 1 && chunks > 1 && n >= kParallelMin)
#endif
  for (int c = 0; c < chunks; ++c) f(c, n * c / chunks, n * (c + 1) / chunks);
}

}  // namespace vpffd
