#pragma once
/// @file solve.h
/// The closed-form least-squares offsets of one axis step.
///
/// minimise sum_c w_c delta_c^2 subject to r_p . delta = b_p for a few rows r_p:
/// the volume row alpha (eq. 23) and one row B(u_s) per point constraint (eq. 29).
/// The minimiser is delta = W^-1 R^T lambda with (R W^-1 R^T) lambda = b: eq. 24
/// when only the volume row is present, eqs. 32-35 with one constraint, and a
/// small dense system for several constraints. Fixed control points have
/// W^-1 = 0, which removes them from the problem.

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "vpffd/correction/errors.h"
#include "vpffd/core/check.h"
#include "vpffd/core/types.h"

namespace vpffd {

struct SparseVec {
  std::vector<std::int32_t> index;
  std::vector<double> value;
};

/// Control points that may move (inverse weight > 0).
inline Index count_free_points(const VectorXd& inv_weight) {
  Index free_points = 0;
  for (Index c = 0; c < inv_weight.size(); ++c) free_points += inv_weight[c] > 0;
  return free_points;
}

/// @throws SolverError when an axis step has more conditions (`n_volume` volume
/// rows, one per part, and `n_constraints` rows) than free control points. Shared
/// so that every backend, and a check made before any step runs, says the same.
inline void check_free_points(int n_volume, size_t n_constraints, Index free_points, char axis) {
  const Index m = n_volume + static_cast<Index>(n_constraints);
  if (m > free_points) {
    const std::string volume = n_volume == 0   ? std::string()
                               : n_volume == 1 ? std::string("volume + ")
                                               : detail::concat(n_volume, " part volumes + ");
    throw SolverError(detail::concat("correction along ", axis, ": ", m, " conditions (", volume, n_constraints,
                                     " point constraints) but only ", free_points, " free control points"));
  }
}

namespace detail {

inline SolverError overflow_error(char axis) {
  return SolverError(detail::concat("correction along ", axis,
                                    ": the coefficients or targets overflow double precision (control points, "
                                    "mesh or target volume too large)"));
}

/// solve_axis_offsets_parts with the volume row alone (the common frame): the same
/// scalings, checks, errors and refinement step written out for one row, where the
/// Gram matrix is the number G = alpha^T W^-1 alpha and lambda = b / G. Five passes
/// over the N control points and one array instead of the general path's dense
/// matrices, eigensolver and temporaries: a 2,562-vertex sphere's three solves took
/// 0.015 ms a frame, now 0.009-0.010 (bench/results/vm/first_step_vm.md).
inline VectorXd solve_volume_row(const double* alpha, double rhs, const VectorXd& inv_weight, char axis,
                                 double* sum_squares) {
  const Index N = inv_weight.size();
  check_free_points(1, 0, count_free_points(inv_weight), axis);
  double big = 0;
  bool finite = std::isfinite(rhs);
  for (Index c = 0; c < N; ++c) {
    finite &= std::isfinite(alpha[c]);
    big = std::max(big, std::abs(alpha[c]));
  }
  if (!finite) throw overflow_error(axis);
  // As the general path: weights scaled to a largest inverse of 1, the row and its
  // right-hand side by a power of two (exact), so that the sums stay in range.
  const double wmax = inv_weight.maxCoeff();
  const int e = big > 0 ? std::ilogb(big) : 0;
  const double s = std::ldexp(1.0, -e);
  const double b = std::ldexp(rhs, -e);
  VectorXd wr(N);  // W^-1 r, r the scaled row
  double G = 0, scale = 0;
  for (Index c = 0; c < N; ++c) {
    const double r = alpha[c] * s;
    wr[c] = (inv_weight[c] / wmax) * r;
    G += wr[c] * r;
    scale += r * r;
  }
  if (sum_squares) *sum_squares = std::ldexp(G * wmax, 2 * e);
  if (!(scale > 0) || !(G > 1e-24 * scale)) throw zero_volume_row_error(axis);
  VectorXd delta = wr * (b / G);
  // One step of iterative refinement, as the general path.
  double residual = b;
  for (Index c = 0; c < N; ++c) residual -= alpha[c] * s * delta[c];
  delta += wr * (residual / G);
  return delta;
}

}  // namespace detail

/// One axis step with K volume rows (one per part of the mesh; K = 0: none).
/// @param alphas      K x N row-major volume coefficients (null when K = 0)
/// @param volume_rhs  K volume changes the step must make
/// @param inv_weight  N entries, 0 for fixed control points
/// @param[out] sum_squares  t^T W^-1 t for t the sum of the K rows (the whole
///                          mesh's coefficients; 0 without a volume row)
/// @throws SolverError when the system has no solution, saying why (naming the
///         parts and constraints whose rows are zero or dependent).
inline VectorXd solve_axis_offsets_parts(const double* alphas, int K, const double* volume_rhs,
                                         const std::vector<SparseVec>& rows, const std::vector<double>& rows_rhs,
                                         const VectorXd& inv_weight, char axis, double* sum_squares = nullptr) {
  const Index N = inv_weight.size();
  if (K == 1 && rows.empty()) return detail::solve_volume_row(alphas, volume_rhs[0], inv_weight, axis, sum_squares);
  const int nv = K;
  const int m = nv + static_cast<int>(rows.size());
  RowMatrixXd R = RowMatrixXd::Zero(m, N);
  Eigen::VectorXd b(m);
  for (int k = 0; k < K; ++k) {
    R.row(k) = Eigen::Map<const Eigen::RowVectorXd>(alphas + static_cast<size_t>(k) * N, N);
    b[k] = volume_rhs[k];
  }
  for (size_t s = 0; s < rows.size(); ++s) {
    for (size_t q = 0; q < rows[s].index.size(); ++q) R(nv + s, rows[s].index[q]) += rows[s].value[q];
    b[nv + s] = rows_rhs[s];
  }
  check_free_points(K, rows.size(), count_free_points(inv_weight), axis);
  if (!R.allFinite() || !b.allFinite()) throw detail::overflow_error(axis);
  // Scaling all weights alike does not change the minimiser; scaling them to a
  // largest inverse of 1 keeps the sums below in range whatever the user's units.
  const double wmax = inv_weight.maxCoeff();
  const VectorXd iw = inv_weight / wmax;
  if (sum_squares) {
    *sum_squares = 0.0;
    if (K > 1) {
      // Scaled by a power of two as the rows below, so the square cannot overflow.
      Eigen::RowVectorXd t = R.topRows(K).colwise().sum();
      const double big = t.cwiseAbs().maxCoeff();
      const int e = big > 0 ? std::ilogb(big) : 0;
      t *= std::ldexp(1.0, -e);
      *sum_squares = std::ldexp((t.array().square() * iw.transpose().array()).sum() * wmax, 2 * e);
    }
  }
  // Scaling a row and its right-hand side by the same power of two changes neither the
  // minimiser nor any rounding, but keeps the sums of squares below in range: volume
  // coefficients grow with the square of the mesh's size, and for meshes of size 1e100 or
  // 1e-100 their squares would overflow or underflow (a "flat" mesh that is not flat).
  std::vector<int> row_exponent(m, 0);
  for (int p = 0; p < m; ++p) {
    const double big = R.row(p).cwiseAbs().maxCoeff();
    if (big > 0) {
      row_exponent[p] = std::ilogb(big);
      R.row(p) *= std::ldexp(1.0, -row_exponent[p]);
      b[p] = std::ldexp(b[p], -row_exponent[p]);
    }
  }
  const RowMatrixXd RW = R * iw.asDiagonal();
  Eigen::MatrixXd G;
  if (K <= 1) {
    G = RW * R.transpose();
  } else {
    // Each part's row is non-zero only at the control points near it: summed column
    // by column over the rows present there, G costs sum_c (rows at c)^2 instead of
    // m^2 N, and never starts Eigen's threaded product (a loaded machine makes each
    // of its parallel regions cost a time slice).
    G = Eigen::MatrixXd::Zero(m, m);
    std::vector<int> at;
    at.reserve(m);
    for (Index c = 0; c < N; ++c) {
      if (!(iw[c] > 0)) continue;
      at.clear();
      for (int p = 0; p < m; ++p)
        if (R(p, c) != 0) at.push_back(p);
      for (int p : at)
        for (int q : at) G(p, q) += RW(p, c) * R(q, c);
    }
  }
  if (sum_squares && K == 1) *sum_squares = std::ldexp(G(0, 0) * wmax, 2 * row_exponent[0]);
  const auto row_name = [&](int p) {
    return p < nv ? detail::concat("part ", p) : detail::concat("point constraint ", p - nv);
  };
  for (int p = 0; p < m; ++p) {
    // A zero row means nothing free can move that condition; relative to the
    // row's unweighted norm, so the test does not depend on units.
    const double scale = R.row(p).squaredNorm();
    if (!(scale > 0) || !(G(p, p) > 1e-24 * scale)) {
      if (K == 1 && p == 0)
        throw zero_volume_row_error(axis);
      if (p < nv)
        throw SolverError(detail::concat("correction along ", axis, ": the volume coefficients of part ", p,
                                         " are zero at every free control point (the part is flat along this "
                                         "axis, outside the lattice's reach, or every control point that "
                                         "influences it is fixed)"));
      throw SolverError(detail::concat("correction along ", axis, ": point constraint ", p - nv,
                                       " cannot move: every control point that influences it is fixed"));
    }
  }
  // Conditioning of the unit-diagonal system decides whether the rows are independent.
  const Eigen::VectorXd d = G.diagonal().cwiseSqrt().cwiseInverse();
  const Eigen::MatrixXd Gn = d.asDiagonal() * G * d.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(Gn);
  const double lo = eig.eigenvalues().minCoeff(), hi = eig.eigenvalues().maxCoeff();
  if (!(lo > 1e-12 * hi)) {
    if (K <= 1)
      throw dependent_rows_error(axis, nv > 0, lo > 0 ? hi / lo : INFINITY);
    // The eigenvector of the smallest eigenvalue is the combination of rows that
    // (nearly) vanishes: its large entries name the rows that depend on each other.
    Eigen::Index lowest = 0;
    eig.eigenvalues().minCoeff(&lowest);
    const Eigen::VectorXd z = eig.eigenvectors().col(lowest).cwiseAbs();
    std::string names;
    int listed = 0;
    for (int p = 0; p < m; ++p)
      if (z[p] >= 0.1 * z.maxCoeff() && listed < 8) names += (listed++ ? ", " : "") + row_name(p);
    throw SolverError(detail::concat("correction along ", axis, ": the volume rows of the parts and the point "
                                     "constraints are linearly dependent (condition number ",
                                     lo > 0 ? hi / lo : INFINITY, "): ", names,
                                     " cannot be met independently (parts moved by the same few control points "
                                     "once the others are fixed, or a constraint a volume row already fixes?)"));
  }
  const auto solve = [&](const Eigen::VectorXd& rhs) -> Eigen::VectorXd {
    return d.asDiagonal() * (eig.eigenvectors() * (eig.eigenvalues().cwiseInverse().asDiagonal() *
                                                   (eig.eigenvectors().transpose() * (d.asDiagonal() * rhs))));
  };
  VectorXd delta = RW.transpose() * solve(b);
  // One step of iterative refinement brings the conditions to rounding level
  // even when the rows are far from orthogonal.
  const Eigen::VectorXd residual = b - R * delta;
  delta += RW.transpose() * solve(residual);
  return delta;
}

/// One axis step with at most one volume row. `alpha` may be null (no volume row).
/// `inv_weight` has N entries, 0 for fixed control points.
/// @param[out] sum_squares  alpha^T W^-1 alpha (0 without a volume row)
/// @throws SolverError when the system has no solution, saying why.
inline VectorXd solve_axis_offsets(const VectorXd* alpha, double volume_rhs, const std::vector<SparseVec>& rows,
                                   const std::vector<double>& rows_rhs, const VectorXd& inv_weight, char axis,
                                   double* sum_squares = nullptr) {
  return solve_axis_offsets_parts(alpha ? alpha->data() : nullptr, alpha ? 1 : 0, &volume_rhs, rows, rows_rhs,
                                  inv_weight, axis, sum_squares);
}

}  // namespace vpffd
