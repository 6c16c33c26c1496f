#pragma once
/// @file tied_solve.h
/// The axis step of the correction on a lattice with periodic ties: the solve runs
/// over the distinct control points (lattice/periodic.h), which is where the
/// least-squares objective lives: a tied copy moves with its point, it is not a
/// second unknown.

#include <vector>

#include "vpffd/correction/solve.h"
#include "vpffd/lattice/periodic.h"

namespace vpffd {

/// One axis step of the correction on the distinct points of a lattice with ties
/// (`ties` null: no periodic axis): alpha (extended, may be null) and the constraint
/// rows (extended indices) are folded, the solve runs over the distinct points with
/// their inverse weights, and the distinct offsets are returned.
inline VectorXd solve_tied(const Ties* ties, const VectorXd* alpha, double volume_rhs,
                           const std::vector<SparseVec>& rows, const std::vector<double>& rows_rhs,
                           const VectorXd& inv_weight, char axis, double* sum_squares = nullptr) {
  if (ties == nullptr || ties->identity)
    return solve_axis_offsets(alpha, volume_rhs, rows, rows_rhs, inv_weight, axis, sum_squares);
  std::vector<SparseVec> folded = rows;
  for (SparseVec& r : folded)
    for (std::int32_t& c : r.index) c = ties->source[c];  // solve_axis_offsets sums repeated indices
  if (alpha == nullptr) return solve_axis_offsets(nullptr, volume_rhs, folded, rows_rhs, inv_weight, axis, sum_squares);
  const VectorXd a = fold(*ties, *alpha);
  return solve_axis_offsets(&a, volume_rhs, folded, rows_rhs, inv_weight, axis, sum_squares);
}

/// solve_tied with one volume row per part: `alphas` is K rows of the extended
/// lattice's coefficients (row k contiguous), `volume_rhs` K shares; the rows are
/// folded onto the distinct points before the solve.
inline VectorXd solve_tied_parts(const Ties* ties, const double* alphas, Index n_extended, int K,
                                 const double* volume_rhs, const std::vector<SparseVec>& rows,
                                 const std::vector<double>& rows_rhs, const VectorXd& inv_weight, char axis,
                                 double* sum_squares = nullptr) {
  if (ties == nullptr || ties->identity)
    return solve_axis_offsets_parts(alphas, K, volume_rhs, rows, rows_rhs, inv_weight, axis, sum_squares);
  std::vector<SparseVec> folded = rows;
  for (SparseVec& r : folded)
    for (std::int32_t& c : r.index) c = ties->source[c];
  const Index n = inv_weight.size();
  std::vector<double> a(static_cast<size_t>(K) * n);
  for (int k = 0; k < K; ++k) {
    const VectorXd fk = fold(*ties, Eigen::Map<const VectorXd>(alphas + static_cast<size_t>(k) * n_extended,
                                                                n_extended));
    std::copy(fk.data(), fk.data() + n, a.begin() + static_cast<std::ptrdiff_t>(k) * n);
  }
  return solve_axis_offsets_parts(a.data(), K, volume_rhs, folded, rows_rhs, inv_weight, axis, sum_squares);
}

}  // namespace vpffd
