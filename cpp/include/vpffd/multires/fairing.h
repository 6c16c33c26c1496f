#pragma once
/// @file fairing.h
/// The base surface S of a multiresolution decomposition (paper 002, Section 6:
/// "a smoothed version" of the mesh, same connectivity): implicit fairing of the
/// fine mesh with the cotangent Laplacian.
///
/// Each step solves (M + h K) X_{k+1} = M X_k, with K the cotangent stiffness
/// matrix and M the lumped (barycentric) mass matrix of the *input* mesh: the
/// operator is built and factorised once (Eigen SimplicialLDLT) and every step is
/// one pair of triangular solves. K is the Dirichlet energy of piecewise linear
/// functions, so it is positive semi-definite for any triangle shapes (obtuse ones
/// included) and M + h K is positive definite. Both M and h scale with the square
/// of the mesh size, so the result does not depend on units.

#include <cmath>
#include <vector>

#include <Eigen/Sparse>

#include "vpffd/core/check.h"
#include "vpffd/core/exceptions.h"
#include "vpffd/core/types.h"
#include "vpffd/mesh/validate.h"

namespace vpffd {

/// More steps than this is no longer a base surface but a point: refused.
inline constexpr int kMaxFairingSteps = 10000;

/// Cotangent stiffness matrix K (#V x #V, positive semi-definite, rows sum to 0)
/// and lumped masses (one third of the incident triangle areas per vertex).
/// Zero-area triangles contribute nothing (their cotangents are undefined).
inline void cotangent_operators(const Eigen::Ref<const RowMatrixX3d>& V, const Eigen::Ref<const RowMatrixX3i>& F,
                                Eigen::SparseMatrix<double>& K, VectorXd& mass) {
  const Index n = V.rows();
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(static_cast<size_t>(F.rows()) * 12);
  mass = VectorXd::Zero(n);
  for (Index f = 0; f < F.rows(); ++f) {
    const int idx[3] = {F(f, 0), F(f, 1), F(f, 2)};
    const Vector3d p[3] = {V.row(idx[0]), V.row(idx[1]), V.row(idx[2])};
    const double twice_area = (p[1] - p[0]).cross(p[2] - p[0]).norm();
    const double scale = (p[1] - p[0]).squaredNorm() + (p[2] - p[0]).squaredNorm() + (p[2] - p[1]).squaredNorm();
    if (!(twice_area > 1e-14 * scale)) continue;
    for (int c = 0; c < 3; ++c) {
      // The angle at corner c weighs the opposite edge (a, b).
      const int a = (c + 1) % 3, b = (c + 2) % 3;
      const double w = 0.5 * (p[a] - p[c]).dot(p[b] - p[c]) / twice_area;
      t.emplace_back(idx[a], idx[b], -w);
      t.emplace_back(idx[b], idx[a], -w);
      t.emplace_back(idx[a], idx[a], w);
      t.emplace_back(idx[b], idx[b], w);
      mass[idx[c]] += twice_area / 6.0;
    }
  }
  K.resize(n, n);
  K.setFromTriplets(t.begin(), t.end());
}

/// Mean edge length of F (each edge counted once per face side; only a scale).
inline double mean_edge_length(const Eigen::Ref<const RowMatrixX3d>& V, const Eigen::Ref<const RowMatrixX3i>& F) {
  double s = 0;
  for (Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) s += (V.row(F(f, c)) - V.row(F(f, (c + 1) % 3))).norm();
  return s / double(3 * F.rows());
}

/// Implicit cotangent-Laplacian fairing of (V, F).
/// @param[in] V  #V x 3 vertices
/// @param[in] F  #F x 3 triangles
/// @param[in] smoothing  diffusion time in units of the squared mean edge length
///            (> 0, finite): ceil(smoothing) implicit steps of equal size, so an
///            integer is the number of unit steps (10 = ten steps of h = edge^2).
/// @returns #V x 3 faired vertices (same connectivity as F)
/// @throws InvalidInputError for a bad mesh or smoothing; SolverError when the
///         factorisation fails (it cannot for a valid mesh: M + hK is SPD)
inline RowMatrixX3d fair_mesh(const Eigen::Ref<const RowMatrixX3d>& V, const Eigen::Ref<const RowMatrixX3i>& F,
                              double smoothing) {
  validate_mesh(V, F, "fair_mesh");
  VPFFD_CHECK(std::isfinite(smoothing) && smoothing > 0, "fair_mesh: smoothing must be a positive number, got ",
              smoothing);
  VPFFD_CHECK(smoothing <= kMaxFairingSteps, "fair_mesh: smoothing ", smoothing, " exceeds ", kMaxFairingSteps,
              " (the base surface would shrink to a point)");
  const int steps = static_cast<int>(std::ceil(smoothing));
  Eigen::SparseMatrix<double> K;
  VectorXd mass;
  cotangent_operators(V, F, K, mass);
  // A vertex in no (non-degenerate) face has no mass and no stiffness: it stays put.
  const double mean_mass = mass.sum() / double(V.rows());
  VPFFD_CHECK(mean_mass > 0, "fair_mesh: every triangle has zero area");
  for (Index v = 0; v < V.rows(); ++v)
    if (mass[v] == 0) mass[v] = mean_mass;
  const double e = mean_edge_length(V, F);
  const double h = (smoothing / steps) * e * e;
  Eigen::SparseMatrix<double> A = h * K;
  for (Index v = 0; v < V.rows(); ++v) A.coeffRef(v, v) += mass[v];
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(A);
  if (ldlt.info() != Eigen::Success) throw SolverError("fair_mesh: the fairing matrix could not be factorised");
  Eigen::MatrixXd X = V;  // column-major for the solver
  for (int s = 0; s < steps; ++s) {
    const Eigen::MatrixXd rhs = mass.asDiagonal() * X;
    X = ldlt.solve(rhs);
    if (ldlt.info() != Eigen::Success || !X.allFinite())
      throw SolverError("fair_mesh: the fairing solve failed (non-finite result)");
  }
  return X;
}

}  // namespace vpffd
