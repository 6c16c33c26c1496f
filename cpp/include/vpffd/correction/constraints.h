#pragma once
/// @file constraints.h
/// Point constraints (Problem 2) between the steps of a frame: their right-hand
/// sides, their error, and the steps of a frame that has constraints but no volume
/// row (solved on the host by every backend).

#include <algorithm>
#include <cmath>
#include <vector>

#include "vpffd/correction/options.h"
#include "vpffd/correction/plan.h"
#include "vpffd/correction/tied_solve.h"
#include "vpffd/lattice/periodic.h"

namespace vpffd {

/// r . x for a sparse row r.
inline double row_dot(const SparseVec& r, const Eigen::Ref<const VectorXd>& x) {
  double s = 0;
  for (size_t q = 0; q < r.index.size(); ++q) s += r.value[q] * x[r.index[q]];
  return s;
}

/// Right-hand sides of the point constraints along axis a: target minus where each
/// constraint point is with control point coordinates `Pa` (earlier steps may have
/// moved it).
inline std::vector<double> constraint_rhs(const std::vector<SparseVec>& rows,
                                          const std::vector<PointConstraint>& constraints, int a,
                                          const Eigen::Ref<const VectorXd>& Pa) {
  std::vector<double> rhs(rows.size());
  for (size_t s = 0; s < rows.size(); ++s) rhs[s] = constraints[s].target[a] - row_dot(rows[s], Pa);
  return rhs;
}

/// Largest coordinate error of the point constraints for control points `CP` (N x 3).
inline double constraint_error(const std::vector<SparseVec>& rows, const Eigen::Ref<const RowMatrixX3d>& CP,
                               const std::vector<PointConstraint>& constraints) {
  double err = 0;
  for (size_t s = 0; s < rows.size(); ++s)
    for (int a = 0; a < 3; ++a) err = std::max(err, std::abs(row_dot(rows[s], CP.col(a)) - constraints[s].target[a]));
  return err;
}

/// The axis steps of a frame with point constraints and no volume row: they do not
/// depend on the mesh, so every backend solves them on the host with this one loop.
/// Adds each step's offsets to `res.offsets` (N x 3, zero on entry) and its record to
/// `res.steps`; the caller moves the vertices by each axis's total.
/// @throws SolverError as solve_axis_offsets
inline void constraint_steps(const FramePlan& plan, const Eigen::Ref<const RowMatrixX3d>& P,
                             const CorrectionOptions& opt, DeformResult& res) {
  static const char axis_name[3] = {'x', 'y', 'z'};
  const int naxes = static_cast<int>(opt.axes.size());
  for (int step = 0; step < naxes * opt.rounds; ++step) {
    const int a = opt.axes[step % naxes];
    AxisStep info;
    info.axis = a;
    const VectorXd Pa = plan.ties ? expand_column(*plan.ties, P.col(a) + res.offsets.col(a), a)
                                  : VectorXd(P.col(a) + res.offsets.col(a));
    const std::vector<double> rhs = constraint_rhs(plan.rows, opt.constraints, a, Pa);
    const VectorXd delta =
        solve_tied(plan.ties, nullptr, 0.0, plan.rows, rhs, plan.inv_weight, axis_name[a], &info.sum_squares);
    info.max_offset = delta.cwiseAbs().maxCoeff();
    res.offsets.col(a) += delta;
    res.steps.push_back(info);
  }
}

}  // namespace vpffd
