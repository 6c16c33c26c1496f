#pragma once
/// @file types.h
/// Scalar, index and matrix aliases shared by the whole core.
///
/// Matrices that cross the Python boundary are row-major so that a C-ordered
/// numpy array of shape (n, 3) maps onto them without a copy.

#include <Eigen/Core>
#include <cstdint>

/// Forces inlining of the small functions inside the per-point loops.
#if defined(__GNUC__) || defined(__clang__)
#define VPFFD_ALWAYS_INLINE inline __attribute__((always_inline))
#elif defined(_MSC_VER)
#define VPFFD_ALWAYS_INLINE __forceinline
#else
#define VPFFD_ALWAYS_INLINE inline
#endif

namespace vpffd {

/// A hint that `p` will be read soon (no effect where the compiler has no such hint).
VPFFD_ALWAYS_INLINE void prefetch(const void* p) {
#if defined(__GNUC__) || defined(__clang__)
  __builtin_prefetch(p);
#else
  (void)p;
#endif
}

using Index = std::int64_t;
using RowMatrixX3d = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
using RowMatrixX3i = Eigen::Matrix<std::int32_t, Eigen::Dynamic, 3, Eigen::RowMajor>;
using RowMatrixXd = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using VectorXd = Eigen::VectorXd;
using Vector3d = Eigen::Vector3d;
using Matrix3d = Eigen::Matrix3d;

}  // namespace vpffd
