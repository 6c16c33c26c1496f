#pragma once
/// @file fairing.h
/// The base surface S of a multiresolution decomposition (paper 002, Section 6:
/// "a smoothed version" of the mesh, same connectivity): implicit fairing of the
/// fine mesh with the cotangent Laplacian.
///
/// Each step solves (M + h K) X_{k+1} = M X_k, with K the cotangent stiffness
/// matrix and M the lumped (barycentric) mass matrix of the *input* mesh. K is the
/// Dirichlet energy of piecewise linear functions, so it is positive semi-definite
/// for any triangle shapes (obtuse ones included) and M + h K is positive definite.
/// Both M and h scale with the square of the mesh size, so the result does not
/// depend on units.
///
/// The steps are solved by conjugate gradients (sparse/pcg.h), warm-started from the
/// previous step. With h at most one squared mean edge length the matrix is close
/// to its diagonal: on a regular mesh the masses are ~0.9 e^2 and the cotangent
/// weights O(1) e^2, a condition number near 10, and CG reaches the tolerance in a
/// few dozen products. A sparse Cholesky factor of the same matrix fills in like
/// n^1.5 (about 60 entries per row at 40k vertices and growing): on a 2.6M-vertex
/// mesh its factorisation took minutes where CG takes seconds, and CG's products
/// run on every thread. Meshes with very uneven triangles (slivers next to large
/// faces) condition worse: where the first step's convergence rate predicts more
/// than kFairingMaxIterations, or CG has not converged after them, the steps are
/// solved with the factorisation (Eigen SimplicialLDLT) instead, so the base is
/// always the solution to the tolerance below.

#include <cmath>
#include <memory>
#include <vector>

#include <Eigen/Geometry>
#include <Eigen/Sparse>

#include "vpffd/core/check.h"
#include "vpffd/core/exceptions.h"
#include "vpffd/core/types.h"
#include "vpffd/mesh/validate.h"
#include "vpffd/sparse/pcg.h"

namespace vpffd {

/// More steps than this is no longer a base surface but a point: refused.
inline constexpr int kMaxFairingSteps = 10000;

/// Relative residual |M X_k - A X_{k+1}| / |M X_k| of every fairing step (per
/// coordinate column). The error of X_{k+1} relative to the exact step is at most
/// cond(A) times this: ~1e-12 of the mesh size for the condition numbers of
/// ordinary meshes (~10), the level of rounding in the cotangent weights themselves
/// (each is a ratio of two products of coordinate differences: ~1e-15 relative,
/// amplified by cond(A) in any solver, direct ones included).
inline constexpr double kFairingTolerance = 1e-13;

/// CG iterations per step before the direct factorisation takes over.
inline constexpr int kFairingMaxIterations = 500;

/// CG iterations of the first step after which its convergence rate decides between
/// CG and the factorisation: a mesh that would need more than kFairingMaxIterations
/// (a scan with slivers beside large faces: the dragon needs thousands) is factorised
/// without spending them.
inline constexpr int kFairingProbeIterations = 40;

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
/// @param threads  for the solver's products (the result does not depend on it)
/// @param max_cg_iterations  CG iterations per step before the direct factorisation
///            takes over (0: the factorisation from the start)
/// @returns #V x 3 faired vertices (same connectivity as F); each step solved to
///          the relative residual kFairingTolerance
/// @throws InvalidInputError for a bad mesh or smoothing; SolverError when the
///         factorisation fails (it cannot for a valid mesh: M + hK is SPD)
inline RowMatrixX3d fair_mesh(const Eigen::Ref<const RowMatrixX3d>& V, const Eigen::Ref<const RowMatrixX3i>& F,
                              double smoothing, int threads = 0, int max_cg_iterations = kFairingMaxIterations) {
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
  RowSparse A = h * K;
  for (Index v = 0; v < V.rows(); ++v) A.coeffRef(v, v) += mass[v];
  A.makeCompressed();  // an isolated vertex's diagonal was inserted; pcg_solve3 reads the compressed arrays
  RowMatrixX3d X = V, rhs(V.rows(), 3);
  std::unique_ptr<Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>>> ldlt;
  bool use_cg = max_cg_iterations > 0;
  for (int s = 0; s < steps; ++s) {
    parallel_range(V.rows(), threads, [&](Index b, Index e) {
      for (Index v = b; v < e; ++v) rhs.row(v) = mass[v] * X.row(v);
    });
    if (use_cg) {
      RowMatrixX3d next = X;  // the previous step: the warm start
      int budget = max_cg_iterations;
      if (s == 0 && budget > kFairingProbeIterations) {
        const PcgReport probe = pcg_solve3(A, rhs, next, kFairingTolerance, kFairingProbeIterations, threads);
        budget -= probe.iterations;
        if (!probe.converged) {
          // Iterations still needed at the rate seen so far (residual reduction per iteration).
          const double rate = std::pow(probe.relative_residual / probe.initial_relative_residual,
                                       1.0 / probe.iterations);
          const double more = rate < 1 ? std::log(kFairingTolerance / probe.relative_residual) / std::log(rate) : 1e300;
          use_cg = std::isfinite(more) && more <= budget;
        }
      }
      if (use_cg) {
        use_cg = pcg_solve3(A, rhs, next, kFairingTolerance, budget, threads).converged;
        if (use_cg) X.swap(next);
      }
    }
    if (!use_cg) {
      if (!ldlt) {
        ldlt = std::make_unique<Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>>>(Eigen::SparseMatrix<double>(A));
        if (ldlt->info() != Eigen::Success) throw SolverError("fair_mesh: the fairing matrix could not be factorised");
      }
      const Eigen::MatrixXd b = rhs;  // column-major for the solver
      X = ldlt->solve(b);
      if (ldlt->info() != Eigen::Success) throw SolverError("fair_mesh: the fairing solve failed");
    }
    if (!X.allFinite()) throw SolverError("fair_mesh: the fairing solve failed (non-finite result)");
  }
  return X;
}

}  // namespace vpffd
