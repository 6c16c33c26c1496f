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
#include "vpffd/multires/lift.h"

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

// A flat grid in z = 0 with displacements along z: faces that are the graph of d.
struct Grid {
  RowMatrixX3d P, N;
  RowMatrixX3i F;
};
Grid grid(int n) {
  Grid g;
  g.P.resize((n + 1) * (n + 1), 3);
  g.N = RowMatrixX3d::Zero(g.P.rows(), 3);
  g.N.col(2).setOnes();
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) g.P.row(i * (n + 1) + j) << double(i) / n, double(j) / n, 0.0;
  g.F.resize(2 * n * n, 3);
  for (int i = 0, f = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const int a = i * (n + 1) + j, b = a + n + 1;
      g.F.row(f++) << a, b, b + 1;
      g.F.row(f++) << a, b + 1, a + 1;
    }
  return g;
}

TEST(Lift, HeightFieldSensitivityIsTheSineOfTheTilt) {
  // p = S + d N with S in the plane and d = z: the first term of s_f is |grad d| on
  // the face, the sine of its tilt against the base (lift.h).
  Grid g = grid(4);
  const double slope = 0.75;  // dz/dx
  std::vector<double> d(g.P.rows());
  for (Index i = 0; i < g.P.rows(); ++i) {
    d[i] = slope * g.P(i, 0);
    g.P(i, 2) = d[i];
  }
  const std::vector<double> s = lift_sensitivity(g.P, g.F, g.N, d);
  const double sine = slope / std::sqrt(1 + slope * slope);
  for (double x : s) EXPECT_NEAR(x, sine, 1e-14);
  for (double w : lift_fractions(g.P, g.F, g.N, d)) EXPECT_EQ(w, 0.0);  // height fields are never lifted
}

TEST(Lift, SliverIsBroughtUnderItsBoundAndNoFaceGetsWorse) {
  // One corner of a face lies almost on its opposite edge (a cap sliver) with a
  // displacement that differs from its neighbours': its sensitivity is ~1/height.
  Grid g = grid(6);
  std::vector<double> d(g.P.rows(), 0.0);
  for (Index i = 0; i < g.P.rows(); ++i) d[i] = 0.02 * std::sin(7.0 * i);  // noise, all faces below 1
  const std::vector<double> s_noise = lift_sensitivity(g.P, g.F, g.N, d);
  for (double x : s_noise) ASSERT_LT(x, 1.0);
  // Pull vertex c of face 20 to within 1e-3 of its opposite edge.
  const int f0 = 20, c = g.F(f0, 0), a = g.F(f0, 1), b = g.F(f0, 2);
  const Vector3d mid = 0.5 * (g.P.row(a) + g.P.row(b)).transpose();
  const Vector3d away = (Vector3d(g.P.row(c)) - mid).normalized();
  g.P.row(c) = (mid + 1e-3 * away).transpose();
  d[c] += 0.05;
  g.P(c, 2) = 0.0;
  const std::vector<double> s0 = lift_sensitivity(g.P, g.F, g.N, d);
  ASSERT_GT(s0[f0], 10.0);
  const std::vector<double> w = lift_fractions(g.P, g.F, g.N, d);
  std::vector<double> delta(d.size());
  for (size_t i = 0; i < d.size(); ++i) {
    EXPECT_GE(w[i], 0.0);
    EXPECT_LE(w[i], 1.0);
    delta[i] = (1 - w[i]) * d[i];
  }
  EXPECT_GT(w[c], 0.5);
  const std::vector<double> s1 = lift_sensitivity(g.P, g.F, g.N, delta);
  int lifted = 0;
  for (double x : w) lifted += x > 0;
  EXPECT_LT(lifted, 12) << "only the sliver's neighbourhood is lifted";
  for (Index f = 0; f < g.F.rows(); ++f) {
    const double bound = s0[f] > kLiftHeightField ? kLiftTarget : std::max(s0[f], kLiftTarget);
    EXPECT_LE(s1[f], bound * (1 + 1e-9)) << "face " << f;
  }
}

TEST(Lift, DecompositionKeepsIdentityExactWithLiftedVertices) {
  // Lifted foot points p - delta N rebuild p at rest: decompose's frame data with
  // the identity map (S' = S) give back the fine vertices.
  TriMesh m = test::bumpy(3);
  // Cap slivers as in a scan: one corner of every 7th face (corners not shared with
  // an earlier one) moved to within 3 % of its opposite edge and off the surface by
  // 0.3 edge lengths, up or down in turn.
  const RowMatrixX3d nrm = vertex_normals(m.V, m.F);
  const double edge = (m.V.row(m.F(0, 0)) - m.V.row(m.F(0, 1))).norm();
  std::vector<char> used(m.V.rows(), 0);
  int sign = 1;
  for (Index f = 0; f < m.F.rows(); f += 7) {
    const int a = m.F(f, 0), b = m.F(f, 1), c = m.F(f, 2);
    if (used[a] || used[b] || used[c]) continue;
    used[a] = used[b] = used[c] = 1;
    const Vector3d mid = 0.5 * (m.V.row(b) + m.V.row(c)).transpose();
    const Vector3d pa = m.V.row(a);
    m.V.row(a) = (pa + 0.97 * (mid - pa) + sign * 0.3 * edge * Vector3d(nrm.row(a))).transpose();
    sign = -sign;
  }
  const Multires mr = decompose(m.V, m.F, 10.0);
  const Multires plain = decompose(m.V, m.F, 10.0, 0, true, 4, 100.0, false);
  EXPECT_TRUE(plain.lift.empty());
  ASSERT_EQ(mr.lift.size(), size_t(m.V.rows()));
  EXPECT_GT(mr.lifted_count(), 0) << "the test mesh must have faces to lift";
  const double tol = 1e-12 * diag_of(m.V);
  for (Index i = 0; i < m.V.rows(); ++i) {
    const Vector3d n = mr.tangent_u(i).cross(mr.tangent_v(i)).normalized();
    EXPECT_LT((mr.foot_point(i) + mr.d[i] * n - Vector3d(m.V.row(i))).norm(), tol) << i;
    EXPECT_NEAR(mr.d[i], (1 - mr.lift[i]) * plain.d[i], tol) << i;
  }
}

}  // namespace vpffd::test_foot_points
