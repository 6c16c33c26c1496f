// RBF regions (paper 002, Section 6): the precomputed affine-handle basis against
// the general RBF solve, identity and rigid motions, the blocked kernel against the
// per-point evaluation, and refused input.

#include <cmath>
#include <functional>
#include <memory>
#include <string>

#include "helpers.h"
#include "vpffd/multires/decomposition.h"
#include "vpffd/multires/rbf_map.h"
#include "vpffd/multires/rbf_regions.h"

namespace vpffd::test {
// Named (not anonymous), with the tests inside: the tests compile as unity batches,
// and test_multires.cpp has helpers of the same names.
namespace rbf_regions_test {

double diag(const RowMatrixX3d& V) { return (V.colwise().maxCoeff() - V.colwise().minCoeff()).norm(); }

// Exactness budget as in test_multires.cpp: short sums of O(1) products, ~1e-14 of
// the diagonal; the RBF coefficients add the solve's rounding (refined once).
constexpr double kExact = 1e-12;

struct Setting {
  std::shared_ptr<Multires> mr;
  std::vector<std::uint8_t> deformable;
  std::vector<std::vector<Index>> handles;
};

// Deformable: z > -0.2; handle 1: z > 0.7; handle 2: x > 0.6 and z in (0, 0.5).
Setting setting(int subdivisions) {
  const TriMesh m = bumpy(subdivisions);
  Setting s;
  s.mr = std::make_shared<Multires>(decompose(m.V, m.F, 10.0));
  s.deformable.resize(m.V.rows());
  s.handles.resize(2);
  for (Index i = 0; i < m.V.rows(); ++i) {
    const double x = m.V(i, 0), z = m.V(i, 2);
    s.deformable[i] = z > -0.2;
    if (z > 0.7) s.handles[0].push_back(i);
    else if (x > 0.6 && z > 0 && z < 0.5) s.handles[1].push_back(i);
  }
  return s;
}

Matrix4d affine(const Matrix3d& A, const Vector3d& t) {
  Matrix4d T = Matrix4d::Identity();
  T.topLeftCorner<3, 3>() = A;
  T.topRightCorner<3, 1>() = t;
  return T;
}

Matrix3d rotation(double a) { return Eigen::AngleAxisd(a, Vector3d(1, 2, 3).normalized()).toRotationMatrix(); }

struct Frame {
  RowMatrixX3d X, N, B;
};

Frame frame(const RbfRegions& r, const std::vector<Matrix4d>& T) {
  const Index n = r.multires().n_vertices();
  Frame f{RowMatrixX3d(n, 3), RowMatrixX3d(n, 3), RowMatrixX3d(n, 3)};
  r.deform(T, f.X.data(), f.N.data(), f.B.data());
  return f;
}

void expect_message(const std::function<void()>& f, const std::string& part) {
  try {
    f();
    ADD_FAILURE() << "accepted; expected an error containing '" << part << "'";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
  }
}


TEST(RbfRegions, IdentityKeepsTheMeshAndFixedVerticesBitForBit) {
  const Setting s = setting(3);
  const RbfRegions r(s.mr, s.deformable, s.handles);
  const Multires& m = *s.mr;
  EXPECT_EQ(r.n_regions(), 2);
  EXPECT_GT(r.n_free(), 0);
  const Frame f = frame(r, {Matrix4d::Identity(), Matrix4d::Identity()});
  EXPECT_LT((f.X - m.fine).cwiseAbs().maxCoeff(), kExact * diag(m.fine));
  EXPECT_LT((f.N - m.rest_normals).cwiseAbs().maxCoeff(), kExact);
  EXPECT_TRUE(f.B == m.base);  // D_k = 0: the base of every vertex is where it was
  for (Index i = 0; i < m.n_vertices(); ++i)
    if (r.labels()[i] < 0) {
      ASSERT_TRUE(f.X.row(i) == m.fine.row(i));
      ASSERT_TRUE(f.N.row(i) == m.rest_normals.row(i));
    }
}

TEST(RbfRegions, OneRigidMotionOfEveryConstraintIsThatMotion) {
  // No fixed part: every constraint moves by the same rigid map, which the RBF's
  // linear part reproduces, so the whole mesh moves rigidly.
  Setting s = setting(3);
  std::fill(s.deformable.begin(), s.deformable.end(), 1);
  const RbfRegions r(s.mr, s.deformable, s.handles);
  const Matrix4d T = affine(rotation(0.8), Vector3d(0.3, -0.2, 0.5));
  const Frame f = frame(r, {T, T});
  const Multires& m = *s.mr;
  const Matrix3d R = T.topLeftCorner<3, 3>();
  const RowMatrixX3d want = (m.fine * R.transpose()).rowwise() + T.topRightCorner<3, 1>().transpose();
  EXPECT_LT((f.X - want).cwiseAbs().maxCoeff(), kExact * diag(m.fine));
  EXPECT_LT((f.N - m.rest_normals * R.transpose()).cwiseAbs().maxCoeff(), kExact);
}

TEST(RbfRegions, EqualsTheGeneralSolveOfItsConstraints) {
  const Setting s = setting(3);
  const RbfRegions r(s.mr, s.deformable, s.handles);
  Matrix3d A = rotation(0.5);
  A.col(0) *= 1.3;  // non-rigid
  const std::vector<Matrix4d> T = {affine(A, Vector3d(0.1, 0.2, 0.4)),
                                   affine(rotation(-0.3), Vector3d(0.3, 0.0, -0.1))};
  const Frame f = frame(r, T);
  const RbfMap general(r.constraint_points());
  const RbfWeights W = general.solve(r.targets(T));
  const MultiresFrame g = rbf_deform(*s.mr, general, W);
  const RowMatrixX3d gb = general.map(W, s.mr->base);
  // Both paths sum H + 4 terms phi_j(x) w_j per point; the weights of a dense
  // constraint set are large and cancel, so each rounds by ~eps * sum_j |phi_j w_j|,
  // the terms' magnitude S (measured here), not the result's: 1e-12 relative to S.
  double S = 0;
  for (Index i = 0; i < s.mr->n_vertices(); ++i) {
    if (r.labels()[i] != 0) continue;
    const Vector3d x = (s.mr->foot_point(i) - general.centre()) / general.scale();
    double t = 0;
    for (Index j = 0; j < general.n_handles(); ++j)
      t += std::pow((x - general.centres().row(j).transpose()).norm(), 3) * W.w.row(j).cwiseAbs().maxCoeff();
    S = std::max(S, t);
  }
  const double scale = diag(s.mr->fine), tol = kExact * std::max(scale, S);
  double dx = 0, dn = 0, db = 0;
  for (Index i = 0; i < s.mr->n_vertices(); ++i) {
    const int l = r.labels()[i];
    if (l == 0) {
      dx = std::max(dx, (f.X.row(i) - g.vertices.row(i)).cwiseAbs().maxCoeff());
      dn = std::max(dn, (f.N.row(i) - g.normals.row(i)).cwiseAbs().maxCoeff());
    }
    if (l >= 0) db = std::max(db, (f.B.row(i) - gb.row(i)).cwiseAbs().maxCoeff());  // incl. handle bases
  }
  EXPECT_LT(dx, tol);
  EXPECT_LT(dn, tol / scale);
  EXPECT_LT(db, tol);
  // Handle vertices move with their map exactly.
  for (Index i : s.handles[1]) {
    const Vector3d p = T[1].topLeftCorner<3, 3>() * s.mr->fine.row(i).transpose() + T[1].topRightCorner<3, 1>();
    ASSERT_LT((f.X.row(i).transpose() - p).norm(), kExact * scale);
  }
}

TEST(RbfRegions, BlockedKernelMatchesThePerPointEvaluation) {
  const TriMesh m = bumpy(3);
  RowMatrixX3d H(37, 3), T(37, 3);
  for (Index j = 0; j < H.rows(); ++j) {
    H.row(j) = m.V.row(j * 17);
    T.row(j) = H.row(j) + 0.1 * Vector3d(std::sin(j), std::cos(3.0 * j), 0.5).transpose();
  }
  const RbfMap rbf(H);
  const RbfWeights W = rbf.solve(T);
  RowMatrixX3d v;
  RowMatrixXd J;
  rbf.map_jacobians(W, m.V, v, J);  // 642 points: 3 chunks, the last with a padded lane group
  const RowMatrixX3d v2 = rbf.map(W, m.V);
  EXPECT_TRUE(v == v2);
  for (Index i = 0; i < m.V.rows(); ++i) {
    Vector3d e;
    Matrix3d Je;
    rbf.eval(W, m.V.row(i).transpose(), e, Je);
    ASSERT_LT((v.row(i).transpose() - e).norm(), kExact * diag(m.V)) << i;
    for (int k = 0; k < 9; ++k) ASSERT_NEAR(J(i, k), Je(k / 3, k % 3), kExact * (1 + Je.norm())) << i;
  }
}

TEST(RbfRegions, SpacingThinsEachGroupAndKeepsTheFrameExact) {
  const Setting s = setting(3);
  const double spacing = 0.15;
  const RbfRegions all(s.mr, s.deformable, s.handles);
  const RbfRegions thin(s.mr, s.deformable, s.handles, 2, spacing);
  EXPECT_LT(thin.constraint_points().rows(), all.constraint_points().rows());
  const auto& reg = thin.constraint_regions();
  const RowMatrixX3d& P = thin.constraint_points();
  for (Index a = 0; a < P.rows(); ++a)
    for (Index b = 0; b < a; ++b)
      if (reg[a] == reg[b]) ASSERT_GE((P.row(a) - P.row(b)).norm(), spacing) << a << " " << b;
  const Frame f = frame(thin, {Matrix4d::Identity(), Matrix4d::Identity()});
  EXPECT_LT((f.X - s.mr->fine).cwiseAbs().maxCoeff(), kExact * diag(s.mr->fine));
  EXPECT_THROW(RbfRegions(s.mr, s.deformable, s.handles, 2, -1.0), InvalidInputError);
}

TEST(RbfRegions, RefusesBadSettingsAndMaps) {
  const Setting s = setting(2);
  const Index nv = s.mr->n_vertices();
  std::vector<std::uint8_t> shorter(s.deformable.begin(), s.deformable.end() - 1);
  expect_message([&] { RbfRegions(s.mr, shorter, s.handles); }, "entries for a mesh of");
  expect_message([&] { RbfRegions(s.mr, std::vector<std::uint8_t>(nv, 0), s.handles); }, "deformable region is empty");
  expect_message([&] { RbfRegions(s.mr, s.deformable, {}); }, "no handle region");
  auto overlap = s.handles;
  overlap[1].push_back(overlap[0][0]);
  expect_message([&] { RbfRegions(s.mr, s.deformable, overlap); }, "must not overlap");
  auto empty = s.handles;
  empty[1].clear();
  expect_message([&] { RbfRegions(s.mr, s.deformable, empty); }, "handle region 2 is empty");
  Index outside = 0;
  while (s.deformable[outside]) ++outside;
  auto out = s.handles;
  out[0].push_back(outside);
  expect_message([&] { RbfRegions(s.mr, s.deformable, out); }, "outside the deformable region");
  auto range = s.handles;
  range[0].push_back(nv);
  expect_message([&] { RbfRegions(s.mr, s.deformable, range); }, "outside 0..");
  std::vector<std::vector<Index>> all(1);
  for (Index i = 0; i < nv; ++i)
    if (s.deformable[i]) all[0].push_back(i);
  expect_message([&] { RbfRegions(s.mr, s.deformable, all); }, "no vertex is left to deform");

  const RbfRegions r(s.mr, s.deformable, s.handles);
  const Matrix4d I = Matrix4d::Identity();
  expect_message([&] { frame(r, {I}); }, "1 transforms for 2 handle regions");
  Matrix4d flat = I;
  flat(2, 2) = 0;
  expect_message([&] { frame(r, {I, flat}); }, "handle region 2 is singular");
  Matrix4d proj = I;
  proj(3, 0) = 0.1;
  expect_message([&] { frame(r, {proj, I}); }, "not affine");
  Matrix4d nan = I;
  nan(0, 3) = std::nan("");
  expect_message([&] { frame(r, {nan, I}); }, "NaN");
}

}  // namespace rbf_regions_test
}  // namespace vpffd::test
