// The conjugate-gradient solver of the fairing steps (sparse/pcg.h) and the base
// surface it gives (multires/fairing.h) against the direct factorisation.

#include <cmath>
#include <random>

#include <Eigen/SparseCholesky>

#include "helpers.h"
#include "vpffd/multires/fairing.h"
#include "vpffd/sparse/pcg.h"

namespace vpffd::test {
namespace {

/// M + h K of a bumpy icosphere: the fairing operator.
RowSparse fairing_operator(const RowMatrixX3d& V, const RowMatrixX3i& F) {
  Eigen::SparseMatrix<double> K;
  VectorXd mass;
  cotangent_operators(V, F, K, mass);
  const double e = mean_edge_length(V, F);
  RowSparse A = e * e * K;
  for (Index v = 0; v < V.rows(); ++v) A.coeffRef(v, v) += mass[v];
  return A;
}

}  // namespace

TEST(Pcg, SolvesToTheToleranceForAnyThreadCount) {
  // 40,962 rows: above kParallelMin, so 2 and 3 threads really split the loops.
  const TriMesh m = bumpy(6);
  const RowSparse A = fairing_operator(m.V, m.F);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> U(-1, 1);
  RowMatrixX3d B(m.V.rows(), 3);
  for (Index i = 0; i < B.rows(); ++i)
    for (int c = 0; c < 3; ++c) B(i, c) = U(rng);
  B.col(2).setZero();  // a zero column: solution 0, no division by its zero norm
  RowMatrixX3d X1 = RowMatrixX3d::Ones(B.rows(), 3), X2 = X1, X3 = X1;
  const PcgReport r1 = pcg_solve3(A, B, X1, 1e-12, 1000, 1);
  const PcgReport r2 = pcg_solve3(A, B, X2, 1e-12, 1000, 2);
  pcg_solve3(A, B, X3, 1e-12, 1000, 3);
  ASSERT_TRUE(r1.converged);
  EXPECT_EQ(r1.iterations, r2.iterations);
  EXPECT_EQ(X1, X2);  // the same bits: fixed chunks, combined in order
  EXPECT_EQ(X1, X3);
  EXPECT_TRUE(X1.col(2).isZero(0.0));
  // The true residual, recomputed: the recurrence drifts from it by rounding of
  // ~iterations * eps * |A| |X| (|A| |X| / |B| ~ 10 here): ~1e-13 relative, below 1e-11.
  const RowMatrixX3d R = B - A * X1;
  for (int c = 0; c < 2; ++c) EXPECT_LE(R.col(c).norm(), 1e-11 * B.col(c).norm()) << "column " << c;
  // An iteration cap it cannot meet is reported, not hidden.
  RowMatrixX3d X4 = RowMatrixX3d::Zero(B.rows(), 3);
  const PcgReport r4 = pcg_solve3(A, B, X4, 1e-12, 3, 1);
  EXPECT_FALSE(r4.converged);
  EXPECT_EQ(r4.iterations, 3);
  EXPECT_GT(r4.relative_residual, 1e-12);
}

TEST(Pcg, FairingEqualsTheDirectFactorisation) {
  const TriMesh m = bumpy(4);
  const RowMatrixX3d cg = fair_mesh(m.V, m.F, 10, 1);
  const RowMatrixX3d direct = fair_mesh(m.V, m.F, 10, 1, 0);  // the Cholesky path
  // Each CG step leaves a relative residual <= kFairingTolerance = 1e-13, an error of at
  // most cond(A) times that (cond ~ 10 on this regular mesh; 100 allowed) relative
  // to |X| ~ sqrt(#V) for O(1) coordinates; a fairing step does not amplify errors
  // ((M + hK)^-1 M has norm <= 1 in the M-norm), so ten steps add up to at most
  // 10 * 100 * 1e-13 = 1e-10 of |X|, and any single coordinate errs by no more.
  const double scale = direct.norm();
  EXPECT_LE((cg - direct).norm(), 1e-10 * scale);
  EXPECT_GT((direct - m.V).norm(), 1e-3 * scale);  // the fairing did move the mesh
}

// A vertex in no face: its diagonal entry is inserted into the assembled matrix,
// which leaves it uncompressed; the solver once read its gaps as entries (a crash).
// The vertex stays put, the rest is faired as without it.
TEST(Pcg, FairingKeepsAVertexInNoFace) {
  const TriMesh m = bumpy(3);
  RowMatrixX3d V(m.V.rows() + 1, 3);
  V.topRows(m.V.rows()) = m.V;
  V.row(m.V.rows()) = Vector3d(0.1, 0.2, 0.3).transpose();
  const RowMatrixX3d with = fair_mesh(V, m.F, 5, 1);
  const RowMatrixX3d without = fair_mesh(m.V, m.F, 5, 1);
  EXPECT_EQ(with.row(m.V.rows()), V.row(m.V.rows()));
  // The extra vertex changes the mean mass and edge length only through its own
  // (mean) mass; the step size h is the same, so the rest agrees to the solver's tolerance.
  EXPECT_LE((with.topRows(m.V.rows()) - without).norm(), 1e-10 * without.norm());
  // An uncompressed matrix is refused, not misread.
  RowSparse A(3, 3);
  A.coeffRef(0, 0) = 2;
  A.makeCompressed();
  A.coeffRef(1, 1) = 2;
  A.coeffRef(2, 2) = 2;
  RowMatrixX3d X = RowMatrixX3d::Zero(3, 3);
  EXPECT_THROW(pcg_solve3(A, RowMatrixX3d::Ones(3, 3), X, 1e-12, 10, 1), InvalidInputError);
}

}  // namespace vpffd::test
