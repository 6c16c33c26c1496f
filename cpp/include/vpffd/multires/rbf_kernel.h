#pragma once
/// @file rbf_kernel.h
/// The inner loop of a solved triharmonic RBF map (rbf.h), a few points at a time:
/// r(x) = sum_j w_j |x - c_j|^3 + A x + b and J_r(x) = sum_j 3 |x - c_j| w_j (x - c_j)^T + A.
///
/// The points of a lane group share each centre's loads, and every operation is on
/// Eigen fixed-size arrays of kRbfLanes doubles, which Eigen maps onto SIMD
/// registers itself (sqrt included, which a plain loop only vectorises under
/// -fno-math-errno). Each lane sums its centres in the same order whatever its
/// position, and the last group of a range is padded with copies of its last point,
/// so a point's value does not depend on the chunking or the thread count.

#include <array>
#include <vector>

#include "vpffd/core/parallel.h"
#include "vpffd/core/types.h"

namespace vpffd {

/// Points per lane group: one AVX register of doubles; 9 Jacobian and 3 value
/// accumulators plus temporaries stay within 16 registers.
inline constexpr int kRbfLanes = 4;
using RbfLane = Eigen::Array<double, kRbfLanes, 1>;
/// Points per parallel work item (lane groups share nothing, so any size works).
inline constexpr Index kRbfChunk = 256;

/// One solved map laid out for the kernel: centres and weights as structure of
/// arrays, in the normalised coordinates x_n = (x - centre) / scale.
struct RbfTerms {
  std::array<std::vector<double>, 3> c;  ///< H normalised centres per axis
  std::array<std::vector<double>, 3> w;  ///< H kernel weights per output axis
  Matrix3d A = Matrix3d::Identity();     ///< linear part (on normalised coordinates)
  Vector3d b = Vector3d::Zero();
  Vector3d centre = Vector3d::Zero();    ///< world point of x_n = 0
  double scale = 1;                      ///< world length of x_n's unit
  Index size() const { return static_cast<Index>(c[0].size()); }
};

/// r and, if kJacobian, J_r for one lane group of normalised points xn[3].
/// @param[out] s  values (world units), per axis
/// @param[out] g  Jacobians row-major (g[3a+c] = dr_a/dx_c, world/world), if kJacobian
template <bool kJacobian>
VPFFD_ALWAYS_INLINE void rbf_lanes(const RbfTerms& t, const RbfLane xn[3], RbfLane s[3], RbfLane g[9]) {
  RbfLane s0 = RbfLane::Zero(), s1 = RbfLane::Zero(), s2 = RbfLane::Zero();
  RbfLane g0 = RbfLane::Zero(), g1 = RbfLane::Zero(), g2 = RbfLane::Zero(), g3 = RbfLane::Zero(),
          g4 = RbfLane::Zero(), g5 = RbfLane::Zero(), g6 = RbfLane::Zero(), g7 = RbfLane::Zero(),
          g8 = RbfLane::Zero();
  const double *cx = t.c[0].data(), *cy = t.c[1].data(), *cz = t.c[2].data();
  const double *w0 = t.w[0].data(), *w1 = t.w[1].data(), *w2 = t.w[2].data();
  const Index H = t.size();
  for (Index j = 0; j < H; ++j) {
    const RbfLane dx = xn[0] - cx[j], dy = xn[1] - cy[j], dz = xn[2] - cz[j];
    const RbfLane r2 = dx * dx + dy * dy + dz * dz;
    const RbfLane r = r2.sqrt();
    const RbfLane r3 = r2 * r;
    s0 += r3 * w0[j];
    s1 += r3 * w1[j];
    s2 += r3 * w2[j];
    if constexpr (kJacobian) {
      const RbfLane t0 = r * (3 * w0[j]), t1 = r * (3 * w1[j]), t2 = r * (3 * w2[j]);
      g0 += t0 * dx;
      g1 += t0 * dy;
      g2 += t0 * dz;
      g3 += t1 * dx;
      g4 += t1 * dy;
      g5 += t1 * dz;
      g6 += t2 * dx;
      g7 += t2 * dy;
      g8 += t2 * dz;
    }
  }
  const RbfLane* acc[3] = {&s0, &s1, &s2};
  for (int a = 0; a < 3; ++a)
    s[a] = *acc[a] + t.A(a, 0) * xn[0] + t.A(a, 1) * xn[1] + t.A(a, 2) * xn[2] + t.b[a];
  if constexpr (kJacobian) {
    const RbfLane* gacc[9] = {&g0, &g1, &g2, &g3, &g4, &g5, &g6, &g7, &g8};
    const double inv = 1.0 / t.scale;  // d x_n / d x
    for (int k = 0; k < 9; ++k) g[k] = (*gacc[k] + t.A(k / 3, k % 3)) * inv;
  }
}

/// Loads points first..first+kRbfLanes-1 of the row-major #X x 3 array X (world)
/// into normalised lanes, padding past `last` (inclusive) with point `last`.
VPFFD_ALWAYS_INLINE void rbf_load_lanes(const RbfTerms& t, const double* X, Index first, Index last, RbfLane xn[3]) {
  const double inv = 1.0 / t.scale;
  for (int l = 0; l < kRbfLanes; ++l) {
    const Index i = std::min(first + l, last);
    for (int a = 0; a < 3; ++a) xn[a][l] = (X[3 * i + a] - t.centre[a]) * inv;
  }
}

/// r (and J_r) at the n rows of X (row-major n x 3, world units): `values` n x 3,
/// `J` n x 9 row-major (may be null). Work items of kRbfChunk points run in
/// parallel once n * H is worth it (parallel_items).
inline void rbf_eval_points(const RbfTerms& t, const double* X, Index n, double* values, double* J, int threads = 0) {
  const Index chunks = (n + kRbfChunk - 1) / kRbfChunk;
  parallel_items(chunks, n * t.size(), threads, [&](Index c) {
    const Index b = c * kRbfChunk, e = std::min(n, b + kRbfChunk);
    RbfLane xn[3], s[3], g[9];
    for (Index i = b; i < e; i += kRbfLanes) {
      rbf_load_lanes(t, X, i, e - 1, xn);
      if (J)
        rbf_lanes<true>(t, xn, s, g);
      else
        rbf_lanes<false>(t, xn, s, g);
      for (int l = 0; l < kRbfLanes && i + l < e; ++l) {
        for (int a = 0; a < 3; ++a) values[3 * (i + l) + a] = s[a][l];
        if (J)
          for (int k = 0; k < 9; ++k) J[9 * (i + l) + k] = g[k][l];
      }
    }
  });
}

}  // namespace vpffd
