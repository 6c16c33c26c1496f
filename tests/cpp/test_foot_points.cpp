// Exact foot points on the smooth base (multires/foot_points.h), the face adjacency
// the search walks on (mesh/face_adjacency.h) and the shared least-squares fit
// (multires/fitting.h).

#include <cmath>

#include "helpers.h"
#include "vpffd/ffd/normals.h"
#include "vpffd/mesh/face_adjacency.h"
#include "vpffd/multires/decomposition.h"
#include "vpffd/multires/fitting.h"
#include "vpffd/multires/foot_points.h"

namespace vpffd::test_foot_points {



double diag_of(const RowMatrixX3d& V) { return (V.colwise().maxCoeff() - V.colwise().minCoeff()).norm(); }

TEST(FaceAdjacency, NeighboursAcrossEachEdgeAndBoundaries) {
  const TriMesh m = icosphere(2);
  const RowMatrixX3i N = face_neighbours(m.F);
  for (Index f = 0; f < m.F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const std::int32_t g = N(f, c);
      ASSERT_GE(g, 0) << "a closed mesh has no boundary";
      // g holds the edge opposite corner c of f, and names f across it.
      const int a = m.F(f, (c + 1) % 3), b = m.F(f, (c + 2) % 3);
      int shared = 0, back = -1;
      for (int k = 0; k < 3; ++k) {
        shared += m.F(g, k) == a || m.F(g, k) == b;
        if (m.F(g, k) != a && m.F(g, k) != b) back = k;
      }
      EXPECT_EQ(shared, 2);
      EXPECT_EQ(N(g, back), f);
    }
  // Two triangles sharing one edge: that edge links them, the other four are -1.
  RowMatrixX3i F(2, 3);
  F << 0, 1, 2, 2, 1, 3;
  const RowMatrixX3i P = face_neighbours(F);
  EXPECT_EQ(P(0, 0), 1);  // edge (1, 2) is opposite corner 0 of face 0
  EXPECT_EQ(P(1, 2), 0);  // and opposite corner 2 (vertex 3) of face 1
  EXPECT_EQ((P.array() == -1).count(), 4);
}

// Newton's steps stop at rounding: ~1e-16 of the coordinates; the contract is
// kFootPointTolerance (1e-9) of the diagonal, asserted with its margin.
TEST(FootPoints, ExactOnABumpyBaseWithInterpolatedNormals) {
  const TriMesh m = test::bumpy(3);
  const RowMatrixX3d S = fair_mesh(m.V, m.F, 10.0);
  const RowMatrixX3d NS = vertex_normals(S, m.F);
  const std::vector<FootPoint> fp = foot_points(m.V, S, NS, m.F);
  const double tol = kFootPointTolerance * diag_of(m.V);
  for (Index i = 0; i < m.V.rows(); ++i) {
    ASSERT_TRUE(fp[i].exact) << "vertex " << i;
    const FootPoint& f = fp[i];
    EXPECT_GE(std::min({1 - f.u - f.v, f.u, f.v}), -kInsideTolerance);
    // Recomputed here: S(t) and the interpolated normal from the corners.
    const double w[3] = {1 - f.u - f.v, f.u, f.v};
    Vector3d s = Vector3d::Zero(), n = Vector3d::Zero();
    for (int c = 0; c < 3; ++c) {
      s += w[c] * S.row(m.F(f.face, c)).transpose();
      n += w[c] * NS.row(m.F(f.face, c)).transpose();
    }
    n.normalize();
    const Vector3d p = m.V.row(i);
    EXPECT_LE(tangential_residual(p, s, n), tol);
    EXPECT_NEAR(f.d, (p - s).dot(n), tol);
  }
}

TEST(FootPoints, AffineModeIsThePlanarProjection) {
  const TriMesh m = test::bumpy(2);
  const RowMatrixX3d S = fair_mesh(m.V, m.F, 5.0);
  const std::vector<FootPoint> fp = foot_points(m.V, S, vertex_normals(S, m.F), m.F, /*exact=*/false);
  for (Index i = 0; i < m.V.rows(); ++i) {
    EXPECT_FALSE(fp[i].exact);
    const Vector3d s0 = S.row(m.F(fp[i].face, 0)), s1 = S.row(m.F(fp[i].face, 1)), s2 = S.row(m.F(fp[i].face, 2));
    const Vector3d n = (s1 - s0).cross(s2 - s0).normalized();
    const Vector3d p = s0 + fp[i].u * (s1 - s0) + fp[i].v * (s2 - s0) + fp[i].d * n;
    EXPECT_LE((p - m.V.row(i).transpose()).norm(), 1e-12 * diag_of(m.V));
  }
}

TEST(Fitting, RecoversAnExactLinearFitAndShortensDisplacements) {
  // With no fairness the fit reproduces control points that interpolate the data.
  const TriMesh m = icosphere(2);
  const Index n = m.V.rows();
  RowSparse Phi(n, n);
  Phi.setIdentity();
  const Eigen::SparseMatrix<double> K = umbrella_fairness(m.F, n);
  FitReport rep;
  const RowMatrixX3d C = fit_control_points(Phi, m.V, K, 0.0, RowMatrixX3d::Zero(n, 3), 0, &rep);
  // mu = 1e-9 of the mean diagonal pulls toward C0 = 0 by 1e-9 relative; CG to 1e-10.
  EXPECT_LE((C - m.V).cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_GT(rep.rms_before, 0.9);
  EXPECT_LE(rep.rms_after, 1e-8);
  // The thin-plate form has the constants and linear functions of a flat patch in its
  // null space (rows sum to zero): a translated mesh costs the same as the mesh.
  const VectorXd ones = VectorXd::Ones(n);
  EXPECT_LE((K * ones).cwiseAbs().maxCoeff(), 1e-12);

  // The decomposition's fit: the RMS displacement drops, foot points stay exact.
  const TriMesh b = test::bumpy(3);
  const Multires faired = decompose(b.V, b.F, 10.0, 0, true, 0);
  const Multires fitted = decompose(b.V, b.F, 10.0, 0, true, 4, 100.0);
  ASSERT_EQ(fitted.rms_displacement.size(), 5u);
  EXPECT_DOUBLE_EQ(fitted.rms_displacement[0], faired.rms_displacement[0]);
  EXPECT_LT(fitted.rms_displacement.back(), 0.5 * faired.rms_displacement[0]);
  EXPECT_EQ(fitted.unresolved_count(), 0);
}

TEST(Fitting, RefusesMismatchedInput) {
  RowSparse Phi(4, 3);
  const std::vector<Eigen::Triplet<double>> t = {{0, 0, 1.0}, {1, 1, 1.0}, {2, 2, 1.0}, {3, 0, 1.0}};
  Phi.setFromTriplets(t.begin(), t.end());
  const Eigen::SparseMatrix<double> K(3, 3);
  const RowMatrixX3d P = RowMatrixX3d::Zero(4, 3), C0 = RowMatrixX3d::Zero(3, 3);
  EXPECT_THROW(fit_control_points(Phi, RowMatrixX3d::Zero(5, 3), K, 1.0, C0), InvalidInputError);
  EXPECT_THROW(fit_control_points(Phi, P, K, -1.0, C0), InvalidInputError);
  EXPECT_THROW(fit_control_points(Phi, P, K, 1.0, RowMatrixX3d::Zero(2, 3)), InvalidInputError);
  RowMatrixX3d bad = P;
  bad(0, 0) = std::nan("");
  EXPECT_THROW(fit_control_points(Phi, bad, K, 1.0, C0), InvalidInputError);
  const VectorXd w = -VectorXd::Ones(4);
  EXPECT_THROW(fit_control_points(Phi, P, K, 1.0, C0, 0, nullptr, &w), InvalidInputError);
  EXPECT_THROW(decompose(test::bumpy(1).V, test::bumpy(1).F, 5.0, 0, true, -1), InvalidInputError);
  EXPECT_THROW(decompose(test::bumpy(1).V, test::bumpy(1).F, 5.0, 0, true, 2, 0.0), InvalidInputError);
}

}  // namespace vpffd::test_foot_points
