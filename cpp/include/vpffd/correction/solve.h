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
#include <cmath>
#include <string>
#include <vector>

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

/// @throws SolverError when an axis step has more conditions (the volume row if
/// `volume`, and `n_constraints` rows) than free control points. Shared so that
/// every backend, and a check made before any step runs, says the same.
inline void check_free_points(bool volume, size_t n_constraints, Index free_points, char axis) {
  const Index m = (volume ? 1 : 0) + static_cast<Index>(n_constraints);
  if (m > free_points)
    throw SolverError(detail::concat("correction along ", axis, ": ", m, " conditions (", volume ? "volume + " : "",
                                     n_constraints, " point constraints) but only ", free_points,
                                     " free control points"));
}

/// One axis step. `alpha` may be null (no volume row). `inv_weight` has N
/// entries, 0 for fixed control points.
/// @param[out] sum_squares  alpha^T W^-1 alpha (0 without a volume row)
/// @throws SolverError when the system has no solution, saying why.
inline VectorXd solve_axis_offsets(const VectorXd* alpha, double volume_rhs, const std::vector<SparseVec>& rows,
                                   const std::vector<double>& rows_rhs, const VectorXd& inv_weight, char axis,
                                   double* sum_squares = nullptr) {
  const Index N = inv_weight.size();
  const int nv = alpha ? 1 : 0;
  const int m = nv + static_cast<int>(rows.size());
  RowMatrixXd R = RowMatrixXd::Zero(m, N);
  Eigen::VectorXd b(m);
  if (alpha) {
    R.row(0) = alpha->transpose();
    b[0] = volume_rhs;
  }
  for (size_t s = 0; s < rows.size(); ++s) {
    for (size_t q = 0; q < rows[s].index.size(); ++q) R(nv + s, rows[s].index[q]) += rows[s].value[q];
    b[nv + s] = rows_rhs[s];
  }
  check_free_points(alpha != nullptr, rows.size(), count_free_points(inv_weight), axis);
  if (!R.allFinite() || !b.allFinite())
    throw SolverError(detail::concat("correction along ", axis,
                                     ": the coefficients or targets overflow double precision (control points, "
                                     "mesh or target volume too large)"));
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
  // Scaling all weights alike does not change the minimiser; scaling them to a
  // largest inverse of 1 keeps the sums below in range whatever the user's units.
  const double wmax = inv_weight.maxCoeff();
  const VectorXd iw = inv_weight / wmax;
  const RowMatrixXd RW = R * iw.asDiagonal();
  const Eigen::MatrixXd G = RW * R.transpose();
  if (sum_squares) *sum_squares = alpha ? std::ldexp(G(0, 0) * wmax, 2 * row_exponent[0]) : 0.0;
  for (int p = 0; p < m; ++p) {
    // A zero row means nothing free can move that condition; relative to the
    // row's unweighted norm, so the test does not depend on units.
    const double scale = R.row(p).squaredNorm();
    if (!(scale > 0) || !(G(p, p) > 1e-24 * scale)) {
      if (alpha && p == 0)
        throw SolverError(detail::concat("correction along ", axis,
                                         ": the volume coefficients of the free control points are all zero "
                                         "(the mesh is flat along this axis, or every control point that "
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
  if (!(lo > 1e-12 * hi))
    throw SolverError(detail::concat("correction along ", axis, ": the ", nv ? "volume and point" : "point",
                                     " constraints are linearly dependent (condition number ",
                                     lo > 0 ? hi / lo : INFINITY,
                                     "); two constraints on the same point, or a constraint the volume row "
                                     "already fixes?"));
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

}  // namespace vpffd
