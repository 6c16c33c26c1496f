#pragma once
/// @file spmv.h
/// y = A x with OpenMP over rows. Each row is summed by one thread in column
/// order, so the result is the same for any thread count.

#include "vpffd/core/parallel.h"
#include "vpffd/sparse/csr.h"

namespace vpffd {

/// @param[in]  x  A.cols values
/// @param[out] y  A.rows values
inline void spmv(const CsrMatrix& A, const double* x, double* y, int threads = 0) {
  threads = resolve_threads(threads);
  const std::int64_t* ip = A.indptr.data();
  const std::int32_t* ix = A.indices.data();
  const double* va = A.values.data();
#ifdef _OPENMP
  // Rows of the paper's matrix differ a lot in length (boundary control points
  // touch few faces): dynamic scheduling balances them without changing sums.
#pragma omp parallel for schedule(dynamic, 16) num_threads(threads) if (threads > 1 && A.nnz() >= kParallelMin)
#endif
  for (Index r = 0; r < A.rows; ++r) {
    double s = 0;
    for (std::int64_t p = ip[r]; p < ip[r + 1]; ++p) s += va[p] * x[ix[p]];
    y[r] = s;
  }
}

}  // namespace vpffd
