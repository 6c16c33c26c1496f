// The CPU Deformer: frames against straightforward references (every option, both
// coefficient methods, thread counts, moving rest meshes). Length: one file per
// class under test, like the other suites.
#include <cmath>
#include <limits>
#include <random>
#include <string>

#include "helpers.h"

using namespace vpffd;
using namespace vpffd::test;

TEST(Volume, UnitCubeAndIcosphere) {
  const TriMesh cube = box_mesh(4, 1.0);
  EXPECT_NEAR(signed_volume(cube.V, cube.F), 1.0, 1e-14);
  EXPECT_EQ(edge_report(cube.F).boundary_edges, 0);
  // Far from the origin the volume is the same; the centred sum keeps precision.
  RowMatrixX3d moved = cube.V.rowwise() + Eigen::RowVector3d(1e4, -2e4, 3e4);
  EXPECT_NEAR(signed_volume(moved, cube.F, Vector3d(1e4, -2e4, 3e4)), 1.0, 1e-12);
  // Icosphere: the inscribed polyhedron tends to 4/3 pi; compare with the exact
  // sum of its tetrahedra, and check the rate.
  const TriMesh s5 = icosphere(5);
  const double v5 = signed_volume(s5.V, s5.F);
  EXPECT_LT(v5, 4.0 / 3.0 * M_PI);
  EXPECT_NEAR(v5, 4.0 / 3.0 * M_PI, 3e-3);
  const TriMesh s4 = icosphere(4);
  EXPECT_NEAR(signed_volume(s4.V, s4.F), 4.17973892, 1e-7);  // sphere_ico4.ply (float32 file)
}

TEST(Deformer, IdentityLatticeMapsVerticesOntoThemselves) {
  const TriMesh m = icosphere(3);
  for (int d = 1; d <= kMaxDegree; ++d) {
    const Lattice L = lattice_around(m.V, {d + 2, d + 3, d + 4}, d);
    Deformer D(m.V, m.F, L);
    const RowMatrixX3d X = D.ffd(rest_control_points(L));
    EXPECT_LT((X - m.V).cwiseAbs().maxCoeff(), 1e-12) << "degree " << d;
    // Jacobian of the identity is the identity.
    const RowMatrixXd J = D.jacobians(rest_control_points(L));
    for (Index v = 0; v < J.rows(); v += 17)
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(J(v, 3 * r + c), r == c ? 1.0 : 0.0, 1e-11);
  }
}

TEST(Deformer, BasisMatrixReproducesFfd) {
  const TriMesh m = icosphere(2);
  const Lattice L = lattice_around(m.V, {5, 6, 7}, 3);
  Deformer D(m.V, m.F, L);
  const RowMatrixX3d P = twist(squashed(L, 0.5), 1.0, 2, Vector3d::Zero());
  const CsrMatrix B = D.basis_matrix();
  const RowMatrixX3d X = D.ffd(P);
  for (Index v = 0; v < B.rows; ++v) {
    Vector3d x = Vector3d::Zero();
    for (auto p = B.indptr[v]; p < B.indptr[v + 1]; ++p) x += B.values[p] * P.row(B.indices[p]).transpose();
    EXPECT_LT((x - X.row(v).transpose()).norm(), 1e-13);
  }
}

TEST(Deformer, JacobianMatchesFiniteDifferences) {
  const TriMesh m = icosphere(2);
  const Lattice L = lattice_around(m.V, {5, 5, 5}, 3);
  const RowMatrixX3d P = bend(squashed(L, 0.7), 0.8, 2, 0, Vector3d::Zero());
  Deformer D(m.V, m.F, L);
  const RowMatrixXd J = D.jacobians(P);
  const double h = 1e-6;
  for (Index v : {0, 11, 40, 101}) {
    for (int c = 0; c < 3; ++c) {
      RowMatrixX3d xp = m.V.row(v), xm = m.V.row(v);
      xp(0, c) += h;
      xm(0, c) -= h;
      const RowMatrixX3d fp = ffd_points(L, P, xp), fm = ffd_points(L, P, xm);
      for (int r = 0; r < 3; ++r) EXPECT_NEAR(J(v, 3 * r + c), (fp(0, r) - fm(0, r)) / (2 * h), 1e-6);
    }
  }
}

TEST(Deformer, CoefficientMethodsAgree) {
  const TriMesh m = icosphere(3);
  const Lattice L = lattice_around(m.V, {6, 5, 7}, 3);
  Deformer D(m.V, m.F, L);
  const RowMatrixX3d X = D.ffd(twist(squashed(L, 0.4), 2.0, 2, Vector3d::Zero()));
  for (int a = 0; a < 3; ++a) {
    const AxisCoefficients t = D.volume_coefficients(X, a, CoefficientMethod::Traversal);
    const AxisCoefficients c = D.volume_coefficients(X, a, CoefficientMethod::Csr);
    EXPECT_LT((t.alpha - c.alpha).norm(), 1e-12 * t.alpha.norm());
    EXPECT_NEAR(t.volume, c.volume, 1e-12 * std::abs(t.volume));
    EXPECT_NEAR(t.volume, signed_volume(X, m.F), 1e-12 * std::abs(t.volume));
    // Linearity in each axis: moving by delta changes the volume by alpha . delta exactly.
    VectorXd delta = VectorXd::LinSpaced(t.alpha.size(), -0.05, 0.07);
    RowMatrixX3d Y = X;
    const CsrMatrix B = D.basis_matrix();
    for (Index v = 0; v < B.rows; ++v)
      for (auto p = B.indptr[v]; p < B.indptr[v + 1]; ++p) Y(v, a) += B.values[p] * delta[B.indices[p]];
    EXPECT_NEAR(signed_volume(Y, m.F), t.volume + t.alpha.dot(delta), 1e-12);
  }
}

TEST(Deformer, VolumeRestoredForEveryAxisSubset) {
  const TriMesh m = icosphere(3);
  const Lattice L = lattice_around(m.V, {6, 6, 6}, 3);
  Deformer D(m.V, m.F, L);
  const double V0 = D.rest_volume();
  const RowMatrixX3d squash = squashed(L, 0.2);
  const RowMatrixX3d twisted = twist(rest_control_points(L), 2 * M_PI, 2, 0.5 * (L.box_min + L.box_max));
  for (const RowMatrixX3d* P : {&squash, &twisted})
    for (const char* axes : {"x", "y", "z", "xy", "yx", "xz", "yz", "xyz", "zyx"})
      for (auto method : {CoefficientMethod::Traversal, CoefficientMethod::Csr}) {
        CorrectionOptions o;
        o.axes = parse_axes(axes);
        o.method = method;
        const DeformResult r = D.deform(*P, o);
        EXPECT_LE(rel(r.volume, V0), 1e-12) << axes;
        EXPECT_GT(rel(r.volume_before, V0), 1e-3) << axes;
        // Only the chosen axes move.
        for (int a = 0; a < 3; ++a)
          if (std::string(axes).find(char('x' + a)) == std::string::npos) EXPECT_EQ(r.offsets.col(a).norm(), 0.0);
      }
}

TEST(Deformer, OffsetsAreOptimal) {
  // Each step's offsets are a multiple of the weighted coefficients of that step.
  const TriMesh m = icosphere(3);
  const Lattice L = lattice_around(m.V, {5, 6, 5}, 2);
  Deformer D(m.V, m.F, L);
  const RowMatrixX3d P = squashed(L, 0.5);
  VectorXd w = VectorXd::LinSpaced(L.n_control_points(), 0.5, 3.0);
  CorrectionOptions o;
  o.weights = w;
  const DeformResult r = D.deform(P, o);
  RowMatrixX3d X = D.ffd(P);
  const CsrMatrix B = D.basis_matrix();
  for (int a = 0; a < 3; ++a) {
    const VectorXd alpha = D.volume_coefficients(X, a).alpha;
    const VectorXd expect = alpha.cwiseQuotient(w);
    const VectorXd got = r.offsets.col(a);
    const double k = got.dot(expect) / expect.squaredNorm();
    EXPECT_LT((got - k * expect).norm(), 1e-12 * got.norm());
    for (Index v = 0; v < B.rows; ++v)
      for (auto p = B.indptr[v]; p < B.indptr[v + 1]; ++p) X(v, a) += B.values[p] * got[B.indices[p]];
  }
  EXPECT_LT((X - r.vertices).cwiseAbs().maxCoeff(), 1e-13);
}

TEST(Deformer, ConstraintsAndFixedPoints) {
  const TriMesh m = icosphere(3);
  const Lattice L = lattice_around(m.V, {7, 7, 7}, 3);
  Deformer D(m.V, m.F, L);
  const double V0 = D.rest_volume();
  CorrectionOptions o;
  o.constraints.push_back({0, Vector3d::Zero(), m.V.row(0).transpose() * 1.3});
  o.constraints.push_back({-1, Vector3d(0.1, 0.2, -0.3), Vector3d(0.15, 0.2, -0.45)});
  o.constraints.push_back({100, Vector3d::Zero(), m.V.row(100).transpose() + Vector3d(0, 0.1, 0)});
  o.fixed.assign(L.n_control_points(), 0);
  for (int j = 0; j < 7; ++j)
    for (int k = 0; k < 7; ++k) o.fixed[L.index(0, j, k)] = 1;
  const DeformResult r = D.deform(squashed(L, 0.6), o);
  EXPECT_LE(rel(r.volume, V0), 1e-12);
  EXPECT_LE(r.constraint_error, 1e-12);
  EXPECT_LT((r.vertices.row(0) - 1.3 * m.V.row(0)).norm(), 1e-12);
  for (int j = 0; j < 7; ++j)
    for (int k = 0; k < 7; ++k) EXPECT_EQ(r.offsets.row(L.index(0, j, k)).norm(), 0.0);
  // Constraints without volume preservation (direct manipulation only).
  o.preserve_volume = false;
  const DeformResult q = D.deform(rest_control_points(L), o);
  EXPECT_LE(q.constraint_error, 1e-12);
}

TEST(Deformer, UnsolvableCasesRaiseSolverError) {
  const TriMesh m = icosphere(2);
  const Lattice L = lattice_around(m.V, {4, 4, 4}, 3);
  Deformer D(m.V, m.F, L);
  CorrectionOptions o;
  o.fixed.assign(L.n_control_points(), 1);
  EXPECT_THROW(D.deform(squashed(L, 0.5), o), SolverError);  // nothing may move
  CorrectionOptions c;
  c.constraints.push_back({3, Vector3d::Zero(), Vector3d(0, 0, 0)});
  c.constraints.push_back({3, Vector3d::Zero(), Vector3d(0, 0, 0.1)});
  EXPECT_THROW(D.deform(squashed(L, 0.5), c), SolverError);  // same point twice
  CorrectionOptions many;
  for (int i = 0; i < 70; ++i) many.constraints.push_back({i, Vector3d::Zero(), m.V.row(i).transpose()});
  EXPECT_THROW(D.deform(squashed(L, 0.5), many), SolverError);  // 71 conditions > 64 points
}

TEST(Deformer, BadInput) {
  const TriMesh m = icosphere(2);
  const Lattice L = lattice_around(m.V, {4, 4, 4}, 3);
  // Vertices outside the lattice.
  const Lattice small = make_lattice(Vector3d(-0.5, -0.5, -0.5), Vector3d(0.5, 0.5, 0.5), {4, 4, 4}, {3, 3, 3});
  EXPECT_THROW(Deformer(m.V, m.F, small), InvalidInputError);
  EXPECT_NO_THROW(Deformer(m.V, m.F, small, OutsidePolicy::Extrapolate));
  // Extrapolation keeps the identity.
  Deformer E(m.V, m.F, small, OutsidePolicy::Extrapolate);
  EXPECT_LT((E.ffd(rest_control_points(small)) - m.V).cwiseAbs().maxCoeff(), 1e-12);
  // Faces out of range, NaN vertices, empty mesh.
  RowMatrixX3i F = m.F;
  F(3, 1) = static_cast<int>(m.V.rows());
  EXPECT_THROW(Deformer(m.V, F, L), InvalidInputError);
  RowMatrixX3d V = m.V;
  V(5, 2) = NAN;
  EXPECT_THROW(Deformer(V, m.F, L), InvalidInputError);
  EXPECT_THROW(Deformer(RowMatrixX3d(0, 3), RowMatrixX3i(0, 3), L), InvalidInputError);
  // Open mesh: volume refused, with the boundary edge count.
  Deformer O(m.V, m.F.topRows(m.F.rows() - 1), L);
  try {
    O.deform(rest_control_points(L), {});
    FAIL();
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("3 boundary edges"), std::string::npos) << e.what();
  }
  // Bad options.
  Deformer D(m.V, m.F, L);
  CorrectionOptions w;
  w.weights = VectorXd::Ones(L.n_control_points());
  w.weights[2] = 0.0;
  EXPECT_THROW(D.deform(rest_control_points(L), w), InvalidInputError);
  EXPECT_THROW(D.deform(RowMatrixX3d::Zero(5, 3), {}), InvalidInputError);
  EXPECT_THROW(parse_axes("xw"), InvalidInputError);
  EXPECT_THROW(parse_axes("xx"), InvalidInputError);
  // Degenerate lattice.
  EXPECT_THROW(make_lattice(Vector3d(0, 0, 0), Vector3d(1, 0, 1), {4, 4, 4}, {3, 3, 3}), InvalidInputError);
  EXPECT_THROW(make_lattice(Vector3d(0, 0, 0), Vector3d(1, 1, 1), {3, 4, 4}, {3, 3, 3}), InvalidInputError);
}

TEST(Deformer, ThreadCountDoesNotChangeResults) {
  if (!has_openmp()) GTEST_SKIP() << "built without OpenMP";
  // Above kParallelMin vertices and faces, so the loops really run in parallel.
  const TriMesh m = icosphere(6);
  ASSERT_GE(m.V.rows(), kParallelMin);
  const Lattice L = lattice_around(m.V, {8, 8, 8}, 3);
  const RowMatrixX3d P = twist(squashed(L, 0.5), 1.5, 2, Vector3d::Zero());
  // An open mesh (the cone form) too: the top cap removed.
  std::vector<Index> keep;
  for (Index f = 0; f < m.F.rows(); ++f)
    if (m.V(m.F(f, 0), 2) < 0.8 || m.V(m.F(f, 1), 2) < 0.8 || m.V(m.F(f, 2), 2) < 0.8) keep.push_back(f);
  RowMatrixX3i Fopen(static_cast<Index>(keep.size()), 3);
  for (size_t i = 0; i < keep.size(); ++i) Fopen.row(static_cast<Index>(i)) = m.F.row(keep[i]);
  for (bool open : {false, true}) {
    Deformer D(m.V, open ? Fopen : m.F, L);
    for (CoefficientMethod method : {CoefficientMethod::Traversal, CoefficientMethod::Csr}) {
      if (open && method == CoefficientMethod::Csr) continue;  // the paper's matrix is for closed meshes
      CorrectionOptions o;
      o.method = method;
      o.allow_open = open;
      o.threads = 1;
      const DeformResult a = D.deform(P, o);
      for (int threads : {2, 3}) {
        o.threads = threads;
        const DeformResult b = D.deform(P, o);
        SCOPED_TRACE(::testing::Message() << "open " << open << ", method " << int(method) << ", threads "
                                          << threads);
        EXPECT_EQ((a.vertices - b.vertices).cwiseAbs().maxCoeff(), 0.0);
        EXPECT_EQ((a.offsets - b.offsets).cwiseAbs().maxCoeff(), 0.0);
        EXPECT_EQ(a.volume, b.volume);
        ASSERT_EQ(a.steps.size(), b.steps.size());
        for (size_t s = 0; s < a.steps.size(); ++s) EXPECT_EQ(a.steps[s].sum_squares, b.steps[s].sum_squares);
      }
    }
  }
  // Repeated axes are refused (rounds repeats the axes; the backends size their steps by it).
  CorrectionOptions rep;
  rep.axes = {0, 1, 0};
  EXPECT_THROW(Deformer(m.V, m.F, L).deform(P, rep), InvalidInputError);
}

// The pieces of a frame that every backend shares (FramePlan, constraint_steps,
// constraint_error) give what Deformer::deform gives.
TEST(Deformer, SharedFramePieces) {
  const TriMesh m = icosphere(2);
  const Lattice L = lattice_around(m.V, {4, 5, 4}, 2);
  Deformer D(m.V, m.F, L);
  const Index N = L.n_control_points();
  const RowMatrixX3d P = squashed(L, 0.7);
  CorrectionOptions o;
  o.preserve_volume = false;
  o.rounds = 2;
  o.axes = {2, 0};
  o.fixed.assign(N, 0);
  o.fixed[0] = o.fixed[5] = 1;
  const RowMatrixX3d X = D.ffd(P);
  o.constraints.push_back({3, Vector3d::Zero(), X.row(3).transpose() + Vector3d(0.02, 0, -0.01)});
  o.constraints.push_back({-1, Vector3d(0.1, 0.2, -0.3), Vector3d(0.12, 0.2, -0.35)});
  const FramePlan pl = D.plan(P, o);
  EXPECT_EQ(pl.free_points, N - 2);
  DeformResult mine;
  mine.offsets = RowMatrixX3d::Zero(N, 3);
  constraint_steps(pl, P, o, mine);
  const DeformResult r = D.deform(P, o);
  ASSERT_EQ(mine.steps.size(), 4u);
  ASSERT_EQ(r.steps.size(), 4u);
  EXPECT_EQ((mine.offsets - r.offsets).cwiseAbs().maxCoeff(), 0.0);
  for (size_t s = 0; s < 4; ++s) EXPECT_EQ(mine.steps[s].axis, r.steps[s].axis);
  EXPECT_EQ(constraint_error(pl.rows, P + r.offsets, o.constraints), r.constraint_error);
  EXPECT_LE(r.constraint_error, 1e-12);
  EXPECT_GT(constraint_error(pl.rows, P, o.constraints), 1e-3);  // the plain FFD misses them
  // The vertices follow the offsets: the constrained vertex reaches its target.
  EXPECT_LE((r.vertices.row(3).transpose() - o.constraints[0].target).cwiseAbs().maxCoeff(), 1e-12);
}

// plan() makes the first step's checks, so a frame that cannot be corrected fails
// before any work and with the message deform() always gave.
TEST(Deformer, PlanRefusesWhatTheFirstStepWould) {
  const TriMesh m = icosphere(2);
  const Lattice L = lattice_around(m.V, {4, 4, 4}, 3);
  Deformer D(m.V, m.F, L);
  const RowMatrixX3d P = squashed(L, 0.5);
  CorrectionOptions many;
  many.axes = {1, 0, 2};
  for (int i = 0; i < 64; ++i) many.constraints.push_back({i, Vector3d::Zero(), P.row(0).transpose()});
  try {
    D.plan(P, many);
    FAIL() << "plan accepted 65 conditions for 64 control points";
  } catch (const SolverError& e) {
    EXPECT_STREQ(e.what(), "correction along y: 65 conditions (volume + 64 point constraints) but only 64 free "
                           "control points");
  }
  many.preserve_volume = false;  // 64 rows for 64 points: allowed by the count
  EXPECT_EQ(D.plan(P, many).free_points, 64);

  // method='csr' on an open mesh is refused only where a volume is corrected.
  RowMatrixX3i Fo = m.F.topRows(m.F.rows() - 1);
  Deformer open(m.V, Fo, L);
  CorrectionOptions csr;
  csr.method = CoefficientMethod::Csr;
  csr.allow_open = true;
  EXPECT_THROW(open.plan(P, csr), InvalidInputError);
  csr.preserve_volume = false;
  EXPECT_NO_THROW(open.plan(P, csr));
}

// --- the fused frame against the frame written out plainly --------------------

namespace {

// alpha = B^T w for the basis matrix B (#V x N, caller order).
VectorXd transpose_times(const CsrMatrix& B, const VectorXd& w, Index N) {
  VectorXd alpha = VectorXd::Zero(N);
  for (Index v = 0; v < B.rows; ++v)
    for (auto p = B.indptr[v]; p < B.indptr[v + 1]; ++p) alpha[B.indices[p]] += B.values[p] * w[v];
  return alpha;
}

// A volume-preserving frame as the paper writes it, in the caller's vertex order
// and with nothing fused: per step a face pass (each face's normal component
// added to its corners, or the cone form's corner terms for an open mesh),
// alpha = B^T w with the explicit basis matrix, the volume by signed_volume, the
// closed-form offsets, X += B delta along the axis; the final volume measured
// again by signed_volume.
DeformResult plain_frame(const Deformer& D, const RowMatrixX3d& P, const CorrectionOptions& o) {
  const FramePlan pl = D.plan(P, o);
  const CsrMatrix B = D.basis_matrix();
  const RowMatrixX3i& F = D.faces();
  const Vector3d org = D.origin();
  const Index N = D.n_control_points();
  DeformResult r;
  RowMatrixX3d X = D.ffd(P);
  r.offsets = RowMatrixX3d::Zero(N, 3);
  r.volume_before = signed_volume(X, F, org);
  const int k = static_cast<int>(o.axes.size()) * o.rounds;
  for (int step = 0; step < k; ++step) {
    const int a = o.axes[step % o.axes.size()], a1 = (a + 1) % 3, a2 = (a + 2) % 3;
    VectorXd w = VectorXd::Zero(X.rows());
    for (Index f = 0; f < F.rows(); ++f) {
      if (D.is_closed()) {
        const Vector3d n = (X.row(F(f, 1)) - X.row(F(f, 0))).cross(X.row(F(f, 2)) - X.row(F(f, 0)));
        for (int c = 0; c < 3; ++c) w[F(f, c)] += n[a] / 6.0;
      } else {
        for (int c = 0; c < 3; ++c) {
          const Vector3d pm = X.row(F(f, (c + 1) % 3)).transpose() - org,
                         pn = X.row(F(f, (c + 2) % 3)).transpose() - org;
          w[F(f, c)] += (pm[a1] * pn[a2] - pm[a2] * pn[a1]) / 6.0;
        }
      }
    }
    const VectorXd alpha = transpose_times(B, w, N);
    AxisStep info;
    info.axis = a;
    info.volume_before = signed_volume(X, F, org);
    info.share = (pl.target - info.volume_before) / (k - step);
    const VectorXd Pa = P.col(a) + r.offsets.col(a);
    const VectorXd delta = solve_axis_offsets(&alpha, info.share, pl.rows, constraint_rhs(pl.rows, o.constraints, a, Pa),
                                              pl.inv_weight, char('x' + a), &info.sum_squares);
    r.offsets.col(a) += delta;
    for (Index v = 0; v < B.rows; ++v)
      for (auto p = B.indptr[v]; p < B.indptr[v + 1]; ++p) X(v, a) += B.values[p] * delta[B.indices[p]];
    r.steps.push_back(info);
  }
  r.vertices = X;
  r.volume = signed_volume(X, F, org);
  return r;
}

}  // namespace

// Tolerance 1e-13 (relative to the box diagonal for positions, to the largest
// offset for offsets, to the volume for volumes): both frames compute the same
// sums in different orders, so each quantity differs by a few hundred roundings
// at most on these ~650-vertex meshes (sums of <= 2,000 terms of one sign
// pattern, the small solves well conditioned); 1e-13 is ~450 ulps of slack over
// double's 2.2e-16 and fails at once if a pass used stale coordinates, a wrong
// corner, or the wrong weights (errors of order 1e-3 and more).
TEST(Deformer, FusedFrameEqualsPlainFrame) {
  const TriMesh m = icosphere(3);
  std::vector<Index> keep;  // open variant: the top cap removed
  for (Index f = 0; f < m.F.rows(); ++f)
    if (m.V(m.F(f, 0), 2) < 0.7 || m.V(m.F(f, 1), 2) < 0.7 || m.V(m.F(f, 2), 2) < 0.7) keep.push_back(f);
  RowMatrixX3i Fopen(static_cast<Index>(keep.size()), 3);
  for (size_t i = 0; i < keep.size(); ++i) Fopen.row(static_cast<Index>(i)) = m.F.row(keep[i]);
  const Lattice L = lattice_around(m.V, {6, 5, 7}, 3);
  const Index N = L.n_control_points();
  const RowMatrixX3d P = twist(squashed(L, 0.6), 1.2, 2, Vector3d::Zero());
  const double diag = (L.box_max - L.box_min).norm();
  enum Variant { Plain, Weights, Fixed, Constraints, Rounds };
  for (bool open : {false, true}) {
    Deformer D(m.V, open ? Fopen : m.F, L);
    ASSERT_EQ(D.is_closed(), !open);
    const RowMatrixX3d X = D.ffd(P);
    for (const char* axes : {"x", "y", "z", "xy", "yx", "xz", "zx", "yz", "xyz", "zyx"})
      for (Variant variant : {Plain, Weights, Fixed, Constraints, Rounds})
        for (auto method : {CoefficientMethod::Traversal, CoefficientMethod::Csr})
          for (int threads : {1, 2}) {
            if (open && method == CoefficientMethod::Csr) continue;
            CorrectionOptions o;
            o.axes = parse_axes(axes);
            o.method = method;
            o.threads = threads;
            o.allow_open = open;
            if (variant == Weights) o.weights = VectorXd::LinSpaced(N, 0.3, 4.0);
            if (variant == Fixed) {
              o.fixed.assign(N, 0);
              for (Index c = 0; c < N; c += 3) o.fixed[c] = 1;
            }
            if (variant == Constraints) {
              // Targets move only along the corrected axes.
              Vector3d t = X.row(7).transpose();
              for (int a : o.axes) t[a] += 0.03;
              o.constraints.push_back({7, Vector3d::Zero(), t});
            }
            if (variant == Rounds) o.rounds = 3;
            SCOPED_TRACE(::testing::Message() << "open " << open << ", axes " << axes << ", variant " << variant
                                              << ", method " << int(method) << ", threads " << threads);
            const DeformResult f = D.deform(P, o);
            const DeformResult p = plain_frame(D, P, o);
            EXPECT_LE((f.vertices - p.vertices).cwiseAbs().maxCoeff(), 1e-13 * diag);
            EXPECT_LE((f.offsets - p.offsets).cwiseAbs().maxCoeff(), 1e-13 * p.offsets.cwiseAbs().maxCoeff());
            EXPECT_LE(std::abs(f.volume - p.volume), 1e-13 * std::abs(p.volume));
            EXPECT_LE(std::abs(f.volume_before - p.volume_before), 1e-13 * std::abs(p.volume));
            ASSERT_EQ(f.steps.size(), p.steps.size());
            for (size_t s = 0; s < f.steps.size(); ++s) {
              EXPECT_EQ(f.steps[s].axis, p.steps[s].axis);
              EXPECT_LE(std::abs(f.steps[s].volume_before - p.steps[s].volume_before), 1e-13 * std::abs(p.volume));
              EXPECT_LE(std::abs(f.steps[s].sum_squares - p.steps[s].sum_squares), 1e-13 * p.steps[s].sum_squares);
            }
            // The measured volume is the target (exactness), and independently measured
            // from the returned vertices.
            EXPECT_LE(rel(f.volume, D.rest_volume(open)), 1e-14);
            EXPECT_LE(std::abs(f.volume - signed_volume(f.vertices, D.faces(), D.origin())), 1e-14 * std::abs(f.volume));
          }
  }
}

// The one-pass coefficients (vertex rings) against the two-pass traversal
// (face pass, then vertex pass): same sums in another order (see above for 1e-13).
TEST(Deformer, RingCoefficientsEqualFacePass) {
  const TriMesh m = icosphere(4);
  const Lattice L = lattice_around(m.V, {5, 7, 6}, 2);
  const RowMatrixX3d P = twist(squashed(L, 0.5), 1.0, 2, Vector3d::Zero());
  for (bool open : {false, true}) {
    const RowMatrixX3i F = open ? RowMatrixX3i(m.F.topRows(m.F.rows() - 40)) : m.F;
    Deformer D(m.V, F, L);
    const BasisTables& T = D.tables();
    const RowMatrixX3d Xc = D.ffd(P);
    RowMatrixX3d X(Xc.rows(), 3);  // processing order
    for (Index i = 0; i < X.rows(); ++i) X.row(i) = Xc.row(D.processing_order()[i]);
    const VertexRings rings = vertex_rings(D.processing_faces(), X.rows());
    for (int a = 0; a < 3; ++a) {
      std::vector<double> w(X.rows());
      const AxisCoefficients r =
          coefficients_rings(T, D.processing_embedding(), rings, X.data(), a, D.origin(), 0, open, w.data());
      const AxisCoefficients t = coefficients_traversal(T, D.processing_embedding(), D.processing_adjacency(),
                                                        X.data(), D.processing_faces(), a, D.origin(), 0, open);
      EXPECT_LE((r.alpha - t.alpha).cwiseAbs().maxCoeff(), 1e-13 * t.alpha.cwiseAbs().maxCoeff());
      EXPECT_LE(std::abs(r.volume - t.volume), 1e-13 * std::abs(t.volume));
      // The volume is linear in the axis coordinates with these weights.
      double vol = 0;
      for (Index v = 0; v < X.rows(); ++v) vol += w[v] * (X(v, a) - D.origin()[a]);
      EXPECT_LE(std::abs(vol - signed_volume(X, D.processing_faces(), D.origin())), 1e-13 * std::abs(vol));
    }
  }
}

// Timings are filled only when asked for, and add up to at most the total.
TEST(Deformer, FrameTimings) {
  const TriMesh m = icosphere(3);
  const Lattice L = lattice_around(m.V, {5, 5, 5}, 3);
  Deformer D(m.V, m.F, L);
  CorrectionOptions o;
  EXPECT_FALSE(D.deform(squashed(L, 0.5), o).timings.recorded);
  o.record_timings = true;
  const FrameTimings t = D.deform(squashed(L, 0.5), o).timings;
  EXPECT_TRUE(t.recorded);
  for (double x : {t.plan, t.ffd, t.coefficients, t.solves, t.gathers, t.volume, t.reorder}) EXPECT_GE(x, 0.0);
  EXPECT_GT(t.ffd + t.coefficients + t.gathers, 0.0);
  EXPECT_LE(t.plan + t.ffd + t.coefficients + t.solves + t.gathers + t.volume + t.reorder, t.total * (1 + 1e-9));
}

// The factored Jacobian (uniform orders) against the plain triple loop, which
// stays as the mixed-order path. Both sum the same products sum_ijk P_c g_q,ijk
// in a different order; with g's factors the B-spline values (>= 0, sum 1) and
// derivatives, sum_ijk |P_c| |g_q| <= Pmax D_q with D_q = sum |dN_q| along axis
// q, so each path is within gamma_m Pmax D_q of the exact sum (m = 3K + 2 roundings
// along the longest chain: the products and the sums over i, j, k) and the two
// within twice that. The determinants then differ by at most sum_rq |cofactor_rq|
// times those, below 1e-12 of the Hadamard bound prod_r |J_r| here (Pmax D_q is
// a few times |J| for this lattice around the origin: the margin is ~100).
TEST(Deformer, FactoredJacobianMatchesTripleLoop) {
  const TriMesh m = icosphere(3);
  constexpr double u = 0.5 * std::numeric_limits<double>::epsilon();
  for (int d = 1; d <= kMaxDegree; ++d) {
    const Lattice L = lattice_around(m.V, {d + 3, d + 4, d + 3}, d);
    const RowMatrixX3d P = bend(twist(squashed(L, 0.6), 1.3, 2, Vector3d::Zero()), 0.7, 2, 0, Vector3d::Zero());
    Deformer D(m.V, m.F, L);
    const BasisTables& T = D.tables();
    const Embedding& E = D.processing_embedding();
    ASSERT_EQ(T.order[0], d + 1);
    const Eigen::VectorXd Px = P.col(0), Py = P.col(1), Pz = P.col(2);
    const Vector3d s = parameter_scale(L);
    const Index n = m.V.rows();
    std::vector<double> fast(9 * n), ref(9 * n);
    detail::dispatch_order(T, [&](auto Kc) {  // the uniform-order path of this lattice
      detail::jacobian_points<decltype(Kc)::value>(T, E, Px.data(), Py.data(), Pz.data(), s, fast.data(), 0, n);
    });
    detail::jacobian_points<0>(T, E, Px.data(), Py.data(), Pz.data(), s, ref.data(), 0, n);
    const double Pmax = P.cwiseAbs().maxCoeff();
    const int K = d + 1, chain = 3 * K + 2;
    const double gamma = chain * u / (1 - chain * u);
    double worst_entry = 0, worst_det = 0;
    for (Index v = 0; v < n; ++v) {
      double Dq[3];
      for (int a = 0; a < 3; ++a) {
        const int sp = E.span[a][v];
        double N[detail::kMaxOrder], dN[detail::kMaxOrder];
        eval_span_derivs(T.poly[a].span_coef(sp), K, E.tau[a][v], N, dN);
        Dq[a] = 0;
        for (int r = 0; r < K; ++r) Dq[a] += std::abs(dN[r]);
        Dq[a] *= T.poly[a].inv_width[sp - T.poly[a].first_span] * s[a];
      }
      Eigen::Matrix3d Jf, Jr;
      for (int r = 0; r < 3; ++r)
        for (int q = 0; q < 3; ++q) {
          Jf(r, q) = fast[9 * v + 3 * r + q];
          Jr(r, q) = ref[9 * v + 3 * r + q];
          const double bound = 2 * gamma * Pmax * Dq[q];
          ASSERT_LE(std::abs(Jf(r, q) - Jr(r, q)), bound) << "degree " << d << " vertex " << v;
          worst_entry = std::max(worst_entry, std::abs(Jf(r, q) - Jr(r, q)) / bound);
        }
      const double hadamard = Jr.row(0).norm() * Jr.row(1).norm() * Jr.row(2).norm();
      ASSERT_LE(std::abs(Jf.determinant() - Jr.determinant()), 1e-12 * hadamard) << "degree " << d << " vertex " << v;
      worst_det = std::max(worst_det, std::abs(Jf.determinant() - Jr.determinant()) / hadamard);
    }
    // The check is not vacuous: the Jacobians are far from the identity.
    double off_identity = 0;
    for (Index v = 0; v < n; ++v)
      off_identity = std::max(off_identity,
                              (Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(ref.data() + 9 * v) -
                               Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff());
    EXPECT_GT(off_identity, 0.3) << "degree " << d;
    RecordProperty("worst_entry_over_bound_deg" + std::to_string(d), std::to_string(worst_entry));
    RecordProperty("worst_det_rel_deg" + std::to_string(d), std::to_string(worst_det));
  }
}

TEST(Deformer, UncorrectedFrameIsTheFfdInTheCallersOrder) {
  // A frame that corrects nothing writes the FFD straight into the caller's order and
  // sums its volume over the caller's faces: the same numbers as the FFD through the
  // processing order and the volume over the renumbered faces, bit for bit.
  const TriMesh m = icosphere(3);
  const Lattice L = lattice_around(m.V, {6, 5, 7}, 3, 0.2);
  const RowMatrixX3d P = twist(rest_control_points(L), 0.8, 2, 0.5 * (L.box_min + L.box_max));
  const MeshParts one = parts_from_labels(m.F, std::vector<std::int64_t>(m.V.rows(), 0), m.V.rows());
  for (const MeshParts* pp : {static_cast<const MeshParts*>(nullptr), &one}) {
    const Deformer D(m.V, m.F, L, OutsidePolicy::Error, 2, pp);
    CorrectionOptions o;
    o.preserve_volume = false;
    const DeformResult r = D.deform(P, o);
    const RowMatrixX3d X = D.ffd(P);
    EXPECT_EQ(r.vertices, X);
    // The kernel's rows in processing order, then moved: the same bits.
    const std::vector<std::int32_t>& order = D.processing_order();
    RowMatrixX3d Xs(X.rows(), 3);
    for (Index i = 0; i < X.rows(); ++i) Xs.row(i) = X.row(order[i]);
    EXPECT_EQ(r.volume, signed_volume(Xs, D.processing_faces(), D.origin()));
    EXPECT_EQ(r.volume, r.volume_before);
    // One part: the faces keep the mesh's order, so the caller's faces give the same sum.
    EXPECT_EQ(r.volume, signed_volume(X, m.F, D.origin()));
  }
}

// The volume row alone (the common axis step, solve_volume_row) against what the
// minimiser must be: delta = W^-1 alpha lambda with alpha . delta = rhs, zero at fixed
// points, for coefficients from 1e-150 to 1e150 (the row scaled by a power of two).
TEST(Solve, VolumeRowAloneIsTheWeightedMinimumNorm) {
  std::mt19937 gen(5);
  std::uniform_real_distribution<double> u(-1, 1), w(0.2, 5);
  const Index N = 200;
  for (double size : {1e-150, 1.0, 1e150}) {
    VectorXd alpha(N), inv_weight(N);
    for (Index c = 0; c < N; ++c) {
      alpha[c] = size * u(gen);
      inv_weight[c] = c % 7 == 0 ? 0.0 : w(gen);
    }
    const double rhs = size * 0.37;
    double sum_squares = 0;
    const VectorXd delta = solve_axis_offsets(&alpha, rhs, {}, {}, inv_weight, 'x', &sum_squares);
    double expect_ss = 0, abs_sum = 0;
    for (Index c = 0; c < N; ++c) {
      expect_ss += inv_weight[c] * (alpha[c] / size) * (alpha[c] / size);
      abs_sum += std::abs(alpha[c] * delta[c]);
    }
    // Each product and sum of N terms within N u of its magnitude (N = 200: ~4e-14).
    const double tol = 4.0 * N * std::numeric_limits<double>::epsilon();
    EXPECT_NEAR(sum_squares / (size * size), expect_ss, tol * expect_ss) << size;
    EXPECT_NEAR(alpha.dot(delta), rhs, tol * abs_sum) << size;
    const double lambda = delta[1] / (inv_weight[1] * alpha[1]);
    for (Index c = 0; c < N; ++c) {
      if (inv_weight[c] == 0) {
        EXPECT_EQ(delta[c], 0.0) << c;
      } else {
        EXPECT_NEAR(delta[c], inv_weight[c] * alpha[c] * lambda, tol * std::abs(delta[c])) << c;
      }
    }
  }
  // The refusals: the message of each (the general path's).
  const auto refusal = [](const VectorXd& alpha, const VectorXd& inv_weight) -> std::string {
    try {
      solve_axis_offsets(&alpha, 1.0, {}, {}, inv_weight, 'y', nullptr);
    } catch (const SolverError& e) {
      return e.what();
    }
    return "no SolverError";
  };
  VectorXd alpha = VectorXd::Zero(N), inv_weight = VectorXd::Ones(N);
  const std::string zero = refusal(alpha, inv_weight);
  EXPECT_NE(zero.find("are all zero"), std::string::npos) << zero;
  alpha[3] = std::numeric_limits<double>::quiet_NaN();
  const std::string overflow = refusal(alpha, inv_weight);
  EXPECT_NE(overflow.find("overflow"), std::string::npos) << overflow;
}
