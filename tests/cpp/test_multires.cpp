// Multiresolution decomposition (paper 002): exactness at rest and under rigid
// motions, the analytic foot-point Jacobian, the RBF map, and refused input.

#include <cmath>
#include <memory>

#include "helpers.h"
#include "vpffd/multires/decomposition.h"
#include "vpffd/multires/ffd_map.h"
#include "vpffd/multires/rbf_map.h"

namespace vpffd::test {
namespace {

/// An icosphere with bumps (radius 1 + 0.05 sin 7x sin 7y sin 7z): details whose
/// displacement from a faired base is clearly non-zero.
TriMesh bumpy(int subdivisions) {
  TriMesh m = icosphere(subdivisions);
  for (Index i = 0; i < m.V.rows(); ++i) {
    const Vector3d u = m.V.row(i).normalized();
    m.V.row(i) = (u * (1.0 + 0.05 * std::sin(7 * u.x()) * std::sin(7 * u.y()) * std::sin(7 * u.z()))).transpose();
  }
  return m;
}

double diag_of(const RowMatrixX3d& V) { return (V.colwise().maxCoeff() - V.colwise().minCoeff()).norm(); }

Matrix3d rotation() {
  return (Eigen::AngleAxisd(0.7, Vector3d(1, 2, 3).normalized()) * Eigen::AngleAxisd(-1.1, Vector3d::UnitX()))
      .toRotationMatrix();
}

// Error budget of the exactness tests: every quantity is a short sum of products of
// O(1) coordinates (the affine foot point with |u|, |v| of a few units, a 64-term
// partition of unity, d N_S), each rounding by a few ulp (~1e-16) relative to the
// coordinates, i.e. about 1e-14 of the diagonal; 1e-12 leaves a factor of 100.
// Normals go through the 3x3 solves of eqs. 6-7 whose condition numbers on these
// meshes are O(10): about 1e-14 again.
constexpr double kExact = 1e-12;

TEST(Multires, IdentityLatticeReproducesMeshAndNormals) {
  const TriMesh m = bumpy(3);
  auto mr = std::make_shared<Multires>(decompose(m.V, m.F, 10.0));
  EXPECT_GT(mr->d.size(), 0u);
  double dmax = 0;
  for (double d : mr->d) dmax = std::max(dmax, std::abs(d));
  EXPECT_GT(dmax, 1e-3);  // the base is really smoother than the mesh
  const Lattice L = lattice_around(m.V, {6, 6, 6}, 3);
  const MultiresFFD ffd(mr, L);
  const MultiresFrame f = ffd.deform(rest_control_points(L));
  EXPECT_LT((f.vertices - m.V).cwiseAbs().maxCoeff(), kExact * diag_of(m.V));
  EXPECT_LT((f.normals - mr->rest_normals).cwiseAbs().maxCoeff(), kExact);
}

TEST(Multires, RigidMotionOfAllControlPoints) {
  const TriMesh m = bumpy(3);
  auto mr = std::make_shared<Multires>(decompose(m.V, m.F, 10.0));
  const Lattice L = lattice_around(m.V, {5, 6, 7}, 3);
  const Matrix3d R = rotation();
  const Vector3d t(0.3, -2.0, 1.5);
  const RowMatrixX3d P = (rest_control_points(L) * R.transpose()).rowwise() + t.transpose();
  const MultiresFrame f = MultiresFFD(mr, L).deform(P);
  const RowMatrixX3d want = (m.V * R.transpose()).rowwise() + t.transpose();
  EXPECT_LT((f.vertices - want).cwiseAbs().maxCoeff(), kExact * diag_of(m.V));
  EXPECT_LT((f.normals - mr->rest_normals * R.transpose()).cwiseAbs().maxCoeff(), kExact);
}

TEST(Multires, FootPointJacobianMatchesDifferences) {
  const TriMesh m = bumpy(2);
  auto mr = std::make_shared<Multires>(decompose(m.V, m.F, 5.0));
  const Lattice L = lattice_around(m.V, {6, 6, 6}, 3);
  const RowMatrixX3d P = twist(rest_control_points(L), 1.2, 2, 0.5 * (L.box_min + L.box_max));
  const MultiresFFD ffd(mr, L);
  RowMatrixX3d X;
  RowMatrixXd J;
  ffd.foot_values_jacobians(P, X, J);
  // Central differences of step h: truncation h^2 |D'''| / 6 (|D'''| ~ 10 for this
  // twist on a unit-size lattice: 2e-9 at h = 1e-5) plus rounding 1e-16 / h = 1e-11.
  const double h = 1e-5;
  for (Index i = 0; i < mr->n_vertices(); i += 17) {
    const Vector3d x = mr->foot_point(i);
    for (int c = 0; c < 3; ++c) {
      RowMatrixX3d Y(2, 3);
      Y.row(0) = (x + h * Vector3d::Unit(c)).transpose();
      Y.row(1) = (x - h * Vector3d::Unit(c)).transpose();
      const RowMatrixX3d D = ffd_points(L, P, Y, OutsidePolicy::Extrapolate);
      const Vector3d fd = (D.row(0) - D.row(1)).transpose() / (2 * h);
      for (int r = 0; r < 3; ++r) EXPECT_NEAR(J(i, 3 * r + c), fd[r], 1e-7) << "vertex " << i;
    }
    const RowMatrixX3d D0 = ffd_points(L, P, x.transpose(), OutsidePolicy::Extrapolate);
    EXPECT_LT((X.row(i) - D0.row(0)).norm(), 1e-14);
  }
}

TEST(Multires, ThreadCountDoesNotChangeResult) {
  const TriMesh m = bumpy(3);
  auto mr = std::make_shared<Multires>(decompose(m.V, m.F, 10.0));
  const Lattice L = lattice_around(m.V, {6, 6, 6}, 3);
  const RowMatrixX3d P = twist(rest_control_points(L), 2.0, 1, 0.5 * (L.box_min + L.box_max));
  const MultiresFFD ffd(mr, L);
  const MultiresFrame a = ffd.deform(P, 1), b = ffd.deform(P, 2);
  EXPECT_EQ((a.vertices - b.vertices).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ((a.normals - b.normals).cwiseAbs().maxCoeff(), 0.0);
}

TEST(Multires, RbfInterpolatesAndIsIdentityForUnmovedHandles) {
  const TriMesh m = bumpy(2);
  const Multires mr = decompose(m.V, m.F, 10.0);
  RowMatrixX3d H(12, 3);
  for (Index j = 0; j < H.rows(); ++j) H.row(j) = m.V.row(j * 13);
  const RbfMap rbf(H);
  // Unmoved handles: the polynomial part reproduces the identity; the kernel weights
  // vanish to the solve's rounding (cond of a 16x16 normalised system, ~1e6, times
  // 1e-16, further reduced by the refinement step).
  const MultiresFrame id = rbf_deform(mr, rbf, rbf.solve(H));
  EXPECT_LT((id.vertices - m.V).cwiseAbs().maxCoeff(), kExact * diag_of(m.V));
  EXPECT_LT((id.normals - mr.rest_normals).cwiseAbs().maxCoeff(), kExact);
  RowMatrixX3d T = H;
  T.row(0) += Vector3d(0.2, 0.1, -0.3).transpose();
  T.row(5) += Vector3d(-0.1, 0.25, 0.0).transpose();
  const RbfWeights W = rbf.solve(T);
  EXPECT_LT((rbf.map(W, H) - T).cwiseAbs().maxCoeff(), kExact * diag_of(m.V));
  // Analytic Jacobian against central differences (truncation h^2 |r'''| with
  // |r'''| ~ 6 |w| / |x - c| stays below 1e-8 at h = 1e-5 away from the centres).
  const Vector3d x(0.13, -0.41, 0.27);
  Vector3d v;
  Matrix3d J;
  rbf.eval(W, x, v, J);
  const double h = 1e-5;
  for (int c = 0; c < 3; ++c) {
    Vector3d a, b;
    Matrix3d dummy;
    rbf.eval(W, x + h * Vector3d::Unit(c), a, dummy);
    rbf.eval(W, x - h * Vector3d::Unit(c), b, dummy);
    EXPECT_LT((J.col(c) - (a - b) / (2 * h)).norm(), 1e-7);
  }
}

TEST(Multires, RbfRefusesSingularHandleSets) {
  RowMatrixX3d three(3, 3);
  three << 0, 0, 0, 1, 0, 0, 0, 1, 0;
  EXPECT_THROW(RbfMap{three}, InvalidInputError);
  RowMatrixX3d planar(5, 3);
  planar << 0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0.5, 0.3, 0;
  try {
    RbfMap r(planar);
    FAIL() << "coplanar handles accepted";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("plane"), std::string::npos) << e.what();
  }
  RowMatrixX3d dup(5, 3);
  dup << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 0, 0;
  try {
    RbfMap r(dup);
    FAIL() << "duplicate handles accepted";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("same point"), std::string::npos) << e.what();
  }
  RowMatrixX3d ok(4, 3);
  ok << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  const RbfMap r(ok);
  EXPECT_THROW(r.solve(RowMatrixX3d::Zero(3, 3)), InvalidInputError);
}

TEST(Multires, RefusesBadSmoothingAndLooseVertices) {
  const TriMesh m = bumpy(1);
  EXPECT_THROW(decompose(m.V, m.F, 0.0), InvalidInputError);
  EXPECT_THROW(decompose(m.V, m.F, -1.0), InvalidInputError);
  EXPECT_THROW(decompose(m.V, m.F, std::nan("")), InvalidInputError);
  RowMatrixX3d V(m.V.rows() + 1, 3);
  V << m.V, RowMatrixX3d::Zero(1, 3);
  try {
    decompose(V, m.F, 5.0);
    FAIL() << "a vertex in no triangle was accepted";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find(std::to_string(m.V.rows())), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace vpffd::test
