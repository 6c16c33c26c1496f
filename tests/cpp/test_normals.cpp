// Deformed normals: cofactor formula against closed forms, tangent approximation
// against the exact one, bad input.

#include <gtest/gtest.h>

#include <cmath>

#include "vpffd/ffd/normals.h"
#include "vpffd/frame/deformer.h"
#include "vpffd/mesh/check.h"
#include "vpffd/mesh/shapes.h"

namespace {

double angle_deg(const vpffd::Vector3d& a, const vpffd::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / M_PI;
}

}  // namespace

TEST(Normals, CofactorOfLinearMap) {
  vpffd::Matrix3d A;
  A << 1.5, 0.3, 0.0, 0.0, 0.7, 0.2, 0.1, 0.0, 1.2;
  vpffd::RowMatrixXd J(2, 9);
  for (int r = 0; r < 2; ++r)
    for (int i = 0; i < 9; ++i) J(r, i) = A(i / 3, i % 3);
  vpffd::RowMatrixX3d N0(2, 3);
  N0 << 0, 0, 1, 0.6, 0.8, 0;
  const vpffd::RowMatrixX3d N = vpffd::deformed_normals_exact(J, N0);
  const vpffd::Matrix3d cof = A.determinant() * A.inverse().transpose();
  for (int r = 0; r < 2; ++r) {
    const vpffd::Vector3d want = (cof * N0.row(r).transpose()).normalized();
    EXPECT_LT(angle_deg(N.row(r).transpose(), want), 1e-12);
    EXPECT_NEAR(N.row(r).norm(), 1.0, 1e-15);
  }
}

TEST(Normals, MappedTangentsGiveTheCofactor) {
  // (J t1) x (J t2) = cof(J) (t1 x t2) for any tangents.
  vpffd::Matrix3d A;
  A << 0.2, -1.0, 0.4, 1.1, 0.3, 0.0, -0.5, 0.2, 0.9;
  const vpffd::Vector3d t1(0.3, -0.2, 0.7), t2(-0.1, 0.9, 0.2);
  const vpffd::Matrix3d cof = A.determinant() * A.inverse().transpose();
  EXPECT_LT(((A * t1).cross(A * t2) - cof * t1.cross(t2)).norm(), 1e-14);
}

TEST(Normals, SphereVertexNormalsPointOutward) {
  const vpffd::TriMesh s = vpffd::icosphere(3, 2.0);
  const vpffd::RowMatrixX3d N = vpffd::vertex_normals(s.V, s.F);
  for (vpffd::Index v = 0; v < s.V.rows(); ++v) EXPECT_LT(angle_deg(N.row(v), s.V.row(v)), 1.0);
}

TEST(Normals, TangentApproximationConvergesToExact) {
  const vpffd::TriMesh s = vpffd::icosphere(2, 1.0);
  const vpffd::Lattice L =
      vpffd::make_lattice(vpffd::Vector3d::Constant(-1.2), vpffd::Vector3d::Constant(1.2), {4, 4, 4}, {3, 3, 3});
  vpffd::RowMatrixX3d P = vpffd::rest_control_points(L);
  for (vpffd::Index i = 0; i < P.rows(); ++i) {  // a twist about z
    const double a = 0.5 * P(i, 2), x = P(i, 0), y = P(i, 1);
    P(i, 0) = std::cos(a) * x - std::sin(a) * y;
    P(i, 1) = std::sin(a) * x + std::cos(a) * y;
  }
  vpffd::Deformer d(s.V, s.F, L);
  const vpffd::RowMatrixX3d N0 = vpffd::vertex_normals(s.V, s.F);
  const vpffd::RowMatrixX3d exact = vpffd::deformed_normals_exact(d.jacobians(P), N0);
  double prev = 1e9;
  for (double eps : {1e-1, 1e-2, 1e-3}) {
    const vpffd::RowMatrixX3d approx = vpffd::deformed_normals_tangent(L, P, s.V, N0, eps);
    double worst = 0;
    for (vpffd::Index v = 0; v < s.V.rows(); ++v)
      worst = std::max(worst, angle_deg(exact.row(v), approx.row(v)));
    EXPECT_LT(worst, prev);
    prev = worst;
  }
  EXPECT_LT(prev, 0.05);
}

TEST(Normals, BadInput) {
  vpffd::RowMatrixXd J(2, 8);
  J.setZero();
  vpffd::RowMatrixX3d N0 = vpffd::RowMatrixX3d::Zero(2, 3);
  EXPECT_THROW(vpffd::deformed_normals_exact(J, N0), vpffd::InvalidInputError);
  vpffd::RowMatrixXd J9 = vpffd::RowMatrixXd::Zero(3, 9);
  EXPECT_THROW(vpffd::deformed_normals_exact(J9, N0), vpffd::InvalidInputError);
  vpffd::RowMatrixXd Jn = vpffd::RowMatrixXd::Zero(2, 9);
  Jn(0, 0) = NAN;
  EXPECT_THROW(vpffd::deformed_normals_exact(Jn, N0), vpffd::InvalidInputError);
  // A singular Jacobian gives a zero normal, not NaN.
  const vpffd::RowMatrixX3d Z = vpffd::deformed_normals_exact(vpffd::RowMatrixXd::Zero(2, 9), N0);
  EXPECT_TRUE(Z.allFinite());
}

TEST(MeshCheck, OctahedronAndPlantedHole) {
  vpffd::RowMatrixX3d V(6, 3);
  V << 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1;
  vpffd::RowMatrixX3i F(8, 3);
  F << 0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5;
  const vpffd::MeshCheckReport r = vpffd::check_mesh(V, F);
  EXPECT_TRUE(r.is_volume());
  EXPECT_EQ(r.edges, 12);
  EXPECT_NEAR(r.signed_volume, 4.0 / 3.0, 1e-14);
  const vpffd::RowMatrixX3i open = F.bottomRows(7);
  const vpffd::MeshCheckReport o = vpffd::check_mesh(V, open);
  EXPECT_EQ(o.boundary_edges, 3);
  EXPECT_EQ(o.boundary_loops, 1);
  EXPECT_FALSE(o.closed());
  vpffd::RowMatrixX3i inward = F.rowwise().reverse();
  EXPECT_TRUE(vpffd::check_mesh(V, inward).inward());
  const vpffd::OrientResult fix = vpffd::orient_faces(V, inward);
  EXPECT_EQ(fix.flipped_faces, 8);
  EXPECT_TRUE(vpffd::check_mesh(V, fix.F).is_volume());
}
