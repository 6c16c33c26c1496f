// Several parts keeping their own volumes (K volume rows in one axis solve), and
// moving the rest mesh (Deformer::set_rest_vertices).

#include <random>

#include "helpers.h"

using namespace vpffd;
using namespace vpffd::test;

namespace {

/// `count` spheres of radius 1 side by side along x (centres 3 apart), one mesh.
TriMesh spheres(int count, int subdivisions = 2) {
  const TriMesh s = icosphere(subdivisions);
  TriMesh m;
  m.V.resize(count * s.V.rows(), 3);
  m.F.resize(count * s.F.rows(), 3);
  for (int i = 0; i < count; ++i) {
    m.V.middleRows(i * s.V.rows(), s.V.rows()) = s.V.rowwise() + Eigen::RowVector3d(3.0 * i, 0, 0);
    m.F.middleRows(i * s.F.rows(), s.F.rows()) = s.F.array() + int(i * s.V.rows());
  }
  return m;
}

std::vector<std::int64_t> sphere_labels(const TriMesh& m, int count) {
  std::vector<std::int64_t> l(m.V.rows());
  for (Index v = 0; v < m.V.rows(); ++v) l[v] = 10 * (v / (m.V.rows() / count));  // labels 0, 10, 20...
  return l;
}

}  // namespace

TEST(PartsSolve, KVolumeRowsAndConstraintsAreMetWithMinimalWeightedOffsets) {
  // Random sparse-ish rows: the solve must meet every row to rounding, and the
  // offsets must be W^-1 R^T lambda (the weighted least-norm solution), i.e. equal
  // to the direct formula with an independent (LDLT) solve of the small system.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  const Index N = 60;
  const int K = 3;
  RowMatrixXd alphas = RowMatrixXd::Zero(K, N);
  for (int k = 0; k < K; ++k)
    for (Index c = 20 * k; c < 20 * k + 30 && c < N; ++c) alphas(k, c) = u(rng);  // overlapping supports
  std::vector<SparseVec> rows(1);
  rows[0].index = {5, 25, 45};
  rows[0].value = {0.3, 0.5, 0.2};
  const std::vector<double> rows_rhs = {0.01};
  VectorXd iw(N);
  for (Index c = 0; c < N; ++c) iw[c] = 0.5 + 0.02 * c;
  iw[7] = 0;  // fixed
  const double vrhs[K] = {0.1, -0.2, 0.05};
  double ss = 0;
  const VectorXd delta = solve_axis_offsets_parts(alphas.data(), K, vrhs, rows, rows_rhs, iw, 'x', &ss);
  RowMatrixXd R(K + 1, N);
  R.topRows(K) = alphas;
  R.row(K).setZero();
  for (size_t q = 0; q < rows[0].index.size(); ++q) R(K, rows[0].index[q]) = rows[0].value[q];
  Eigen::VectorXd b(K + 1);
  b << vrhs[0], vrhs[1], vrhs[2], rows_rhs[0];
  // Rows and right-hand sides are O(1); the refined solve leaves residuals of a few
  // ulps of the largest term, far below 1e-13.
  EXPECT_LT((R * delta - b).cwiseAbs().maxCoeff(), 1e-13);
  EXPECT_EQ(delta[7], 0.0);
  const Eigen::MatrixXd G = R * iw.asDiagonal() * R.transpose();
  const VectorXd expect = iw.asDiagonal() * (R.transpose() * G.ldlt().solve(b));
  // Both are the same well-conditioned (cond(G) < 1e3 here) 4x4 solve computed two
  // ways: they agree to cond(G) * a few ulps.
  EXPECT_LT((delta - expect).cwiseAbs().maxCoeff(), 1e-12 * expect.cwiseAbs().maxCoeff());
  const Eigen::RowVectorXd t = alphas.colwise().sum();
  EXPECT_NEAR(ss, (t.array().square() * iw.transpose().array()).sum(), 1e-12 * ss);
}

TEST(PartsSolve, NamesTheDependentOrUnmovableParts) {
  const Index N = 10;
  RowMatrixXd alphas = RowMatrixXd::Zero(3, N);
  alphas.row(0).head(4).setConstant(1.0);
  alphas.row(1).segment(3, 4).setConstant(2.0);
  alphas.row(2).segment(3, 4).setConstant(-1.0);  // row 2 = -row 1 / 2: dependent
  const double rhs[3] = {1, 1, 1};
  const VectorXd iw = VectorXd::Ones(N);
  try {
    solve_axis_offsets_parts(alphas.data(), 3, rhs, {}, {}, iw, 'y');
    FAIL() << "dependent rows must throw";
  } catch (const SolverError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("part 1"), std::string::npos) << msg;
    EXPECT_NE(msg.find("part 2"), std::string::npos) << msg;
    EXPECT_EQ(msg.find("part 0"), std::string::npos) << msg;
  }
  // Part 1's control points all fixed: that part cannot move.
  alphas.row(2).setZero();
  alphas(2, 9) = 1.0;
  VectorXd fixed = iw;
  fixed.segment(3, 4).setZero();
  try {
    solve_axis_offsets_parts(alphas.data(), 3, rhs, {}, {}, fixed, 'z');
    FAIL() << "a part with no free control point must throw";
  } catch (const SolverError& e) {
    EXPECT_NE(std::string(e.what()).find("part 1"), std::string::npos) << e.what();
  }
  // More conditions than free points.
  VectorXd two = VectorXd::Zero(N);
  two[0] = two[9] = 1;
  EXPECT_THROW(solve_axis_offsets_parts(alphas.data(), 3, rhs, {}, {}, two, 'x'), SolverError);
}

TEST(Parts, EveryPartKeepsItsVolume) {
  for (int count : {2, 3}) {
    const TriMesh m = spheres(count);
    const Lattice L = lattice_around(m.V, {8, 5, 5}, 3);
    const MeshParts parts = parts_from_labels(m.F, sphere_labels(m, count), m.V.rows());
    ASSERT_EQ(parts.count, count);
    Deformer D(m.V, m.F, L, OutsidePolicy::Error, 0, &parts);
    const VectorXd rest = D.rest_part_volumes();
    const Vector3d c = 0.5 * (L.box_min + L.box_max);
    const RowMatrixX3d P = twist(rest_control_points(L), M_PI, 0, c);
    CorrectionOptions o;
    const DeformResult r = D.deform(P, o);
    ASSERT_EQ(r.part_volumes.size(), count);
    // The volumes before the correction come from the first coefficient pass (the
    // vertex weights), not a face pass: the same volumes of the plain FFD to rounding.
    CorrectionOptions plain;
    plain.preserve_volume = false;
    const DeformResult f = D.deform(P, plain);
    ASSERT_EQ(f.part_volumes_before.size(), count);
    for (int k = 0; k < count; ++k) {
      // Each part's volume is its share of a face sum of ~F_k terms of size ~|V_k|:
      // the result is exact to a few hundred ulps of the volume, far below 1e-11.
      EXPECT_LE(rel(r.part_volumes[k], rest[k]), 1e-11) << k;
      EXPECT_GT(rel(r.part_volumes_before[k], rest[k]), 1e-4) << k;
      EXPECT_LE(rel(r.part_volumes_before[k], f.part_volumes_before[k]), 1e-11) << k;
      EXPECT_EQ(f.part_volumes[k], f.part_volumes_before[k]) << k;
    }
    EXPECT_EQ(r.volume_before, r.part_volumes_before.sum());
    // The volumes after it come from the last gather (that step's weights): the face
    // pass over the corrected vertices gives them to rounding (the bound above: two
    // sums of ~F_k terms of size ~|V_k|, a few hundred ulps apart at most).
    const VectorXd measured = part_volumes(r.vertices, D.part_faces(), D.part_face_start(), D.origin());
    for (int k = 0; k < count; ++k) EXPECT_LE(rel(r.part_volumes[k], measured[k]), 1e-11) << k;
    EXPECT_LE(rel(r.volume, rest.sum()), 1e-11);
    // Per-part targets.
    CorrectionOptions t;
    for (int k = 0; k < count; ++k) t.part_targets.push_back(rest[k] * (1.0 + 0.1 * k));
    const DeformResult q = D.deform(squashed(L, 0.5), t);
    for (int k = 0; k < count; ++k) EXPECT_LE(rel(q.part_volumes[k], t.part_targets[k]), 1e-11) << k;
    // One scalar target for several parts is ambiguous.
    CorrectionOptions s;
    s.target_volume = rest.sum();
    EXPECT_THROW(D.deform(P, s), InvalidInputError);
  }
}

// The frame's per-part coefficients (vertex fans, scatter run by run in the power
// form) against the straightforward sums: alpha_k = sum over part k's vertices of
// w_v B_v, with w_v from the ring pairs and B the explicit basis matrix. The same
// products summed in other orders (see RingCoefficientsEqualFacePass for 1e-13).
TEST(Parts, PartCoefficientsEqualStraightforwardSums) {
  const TriMesh m = spheres(3, 3);
  const Lattice L = lattice_around(m.V, {8, 5, 5}, 3);
  const MeshParts parts = parts_from_labels(m.F, sphere_labels(m, 3), m.V.rows());
  Deformer D(m.V, m.F, L, OutsidePolicy::Error, 0, &parts);
  const Vector3d c = 0.5 * (L.box_min + L.box_max);
  const RowMatrixX3d Xc = D.ffd(twist(squashed(L, 0.6), 1.0, 0, c));
  const Index n = Xc.rows(), N = L.n_control_points();
  const std::vector<std::int32_t>& order = D.processing_order();
  RowMatrixX3d X(n, 3);  // processing order
  for (Index i = 0; i < n; ++i) X.row(i) = Xc.row(order[i]);
  const BasisTables& T = D.tables();
  const Embedding& E = D.processing_embedding();
  const VertexRings rings = vertex_rings(D.processing_faces(), n);
  const PaddedFans fans = pad_fans(vertex_fans(rings));
  const CellRuns runs = cell_runs(E);
  const CsrMatrix B = D.basis_matrix();  // rows in the caller's vertex order
  for (int ax = 0; ax < 3; ++ax) {
    std::vector<double> w(n);
    coefficients_rings(T, E, rings, X.data(), ax, D.origin(), 1, false, w.data());
    for (int threads : {1, 2}) {
      const PartCoefficients pc =
          part_coefficients_rings(T, E, fans, X.data(), ax, D.origin(), D.part_start(), threads, &runs);
      ASSERT_EQ(pc.alpha.rows(), 3);
      for (int k = 0; k < 3; ++k) {
        VectorXd want = VectorXd::Zero(N);
        double vol = 0;
        for (Index i = D.part_start()[k]; i < D.part_start()[k + 1]; ++i) {
          for (auto p = B.indptr[order[i]]; p < B.indptr[order[i] + 1]; ++p) want[B.indices[p]] += w[i] * B.values[p];
          vol += w[i] * (X(i, ax) - D.origin()[ax]);
        }
        SCOPED_TRACE(::testing::Message() << "axis " << ax << ", part " << k << ", threads " << threads);
        EXPECT_LE((pc.alpha.row(k).transpose() - want).cwiseAbs().maxCoeff(), 1e-13 * want.cwiseAbs().maxCoeff());
        EXPECT_LE(std::abs(pc.volume[k] - vol), 1e-13 * std::abs(vol));
      }
    }
  }
}

TEST(Parts, ComponentsAndBadLabels) {
  const TriMesh m = spheres(3, 1);
  const MeshParts comp = parts_from_components(m.F, m.V.rows());
  EXPECT_EQ(comp.count, 3);
  const MeshParts lab = parts_from_labels(m.F, sphere_labels(m, 3), m.V.rows());
  EXPECT_EQ(comp.vertex_part, lab.vertex_part);
  std::vector<std::int64_t> l = sphere_labels(m, 3);
  l[m.F(0, 1)] = 99;  // a face joins two labels
  EXPECT_THROW(parts_from_labels(m.F, l, m.V.rows()), InvalidInputError);
  l.pop_back();
  EXPECT_THROW(parts_from_labels(m.F, l, m.V.rows()), InvalidInputError);
  // An open part: drop one face of sphere 1.
  TriMesh open = m;
  open.F.conservativeResize(m.F.rows() - 1, 3);
  const MeshParts p = parts_from_labels(open.F, sphere_labels(m, 3), m.V.rows());
  try {
    require_closed_parts(open.F, p);
    FAIL() << "an open part must be refused";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("3 boundary edges"), std::string::npos) << e.what();
  }
}

// Rest positions given as a strided view (the first three columns of a wider array,
// which an Eigen::Ref binds without a copy): the volumes read the rows where they are.
TEST(MovingRest, StridedPositionsGiveTheSameVolumes) {
  const TriMesh m = spheres(2);
  const Lattice L = lattice_around(m.V, {7, 5, 5}, 3, 0.3);
  const MeshParts parts = parts_from_labels(m.F, sphere_labels(m, 2), m.V.rows());
  Eigen::Matrix<double, Eigen::Dynamic, 4, Eigen::RowMajor> wide(m.V.rows(), 4);
  wide.leftCols(3) = m.V;
  wide.col(3).setConstant(1e3);  // read as a coordinate, it would change every volume
  const Eigen::Map<const RowMatrixX3d, 0, Eigen::OuterStride<>> view(wide.data(), m.V.rows(), 3,
                                                                      Eigen::OuterStride<>(4));
  EXPECT_EQ(signed_volume(view, m.F), signed_volume(m.V, m.F));
  for (const MeshParts* pp : {static_cast<const MeshParts*>(nullptr), &parts}) {
    Deformer D(view, m.F, L, OutsidePolicy::Error, 0, pp);
    const Deformer plain(m.V, m.F, L, OutsidePolicy::Error, 0, pp);
    EXPECT_EQ(D.rest_volume(), plain.rest_volume());
    EXPECT_EQ(D.rest_part_volumes(), plain.rest_part_volumes());
    D.set_rest_vertices(view);
    EXPECT_EQ(D.rest_part_volumes(), plain.rest_part_volumes());
  }
}

TEST(MovingRest, EqualsAFreshDeformerBitForBit) {
  const TriMesh m = spheres(2);
  const Lattice L = lattice_around(m.V, {7, 5, 5}, 3, 0.3);
  const MeshParts parts = parts_from_labels(m.F, sphere_labels(m, 2), m.V.rows());
  for (const MeshParts* pp : {static_cast<const MeshParts*>(nullptr), &parts}) {
    Deformer D(m.V, m.F, L, OutsidePolicy::Error, 0, pp);
    const RowMatrixX3d P = twist(rest_control_points(L), 0.5 * M_PI, 0, 0.5 * (L.box_min + L.box_max));
    CorrectionOptions o;
    const DeformResult first = D.deform(P, o);
    RowMatrixX3d X = m.V;
    for (int move = 1; move <= 3; ++move) {
      X.col(0).array() += 0.1;
      X.col(1).array() -= 0.05 * move;
      D.set_rest_vertices(X);
      Deformer fresh(X, m.F, L, OutsidePolicy::Error, 0, pp);
      // The same operations on the same data in the same order: the same bits.
      EXPECT_EQ(D.rest_volume(), fresh.rest_volume());
      EXPECT_EQ(D.processing_order(), fresh.processing_order());
      // The renumbered faces and their vertex-face lists are those of a fresh Deformer.
      EXPECT_EQ(D.processing_adjacency().indptr, fresh.processing_adjacency().indptr);
      EXPECT_EQ(D.processing_adjacency().faces, fresh.processing_adjacency().faces);
      EXPECT_EQ(D.processing_faces(), fresh.processing_faces());
      const DeformResult a = D.deform(P, o), b = fresh.deform(P, o);
      EXPECT_EQ(a.vertices, b.vertices);
      EXPECT_EQ(a.offsets, b.offsets);
      EXPECT_EQ(a.volume, b.volume);
      EXPECT_EQ(a.part_volumes, b.part_volumes);
      EXPECT_EQ(D.face_matrix().values, fresh.face_matrix().values);
    }
    D.set_rest_vertices(m.V);  // back home: the first frame again
    const DeformResult back = D.deform(P, o);
    EXPECT_EQ(back.vertices, first.vertices);
    EXPECT_EQ(back.volume, first.volume);
  }
}

TEST(MovingRest, BadInputLeavesTheDeformerUnchanged) {
  const TriMesh m = icosphere(2);
  const Lattice L = lattice_around(m.V, {5, 5, 5}, 3);
  Deformer D(m.V, m.F, L);
  const double V0 = D.rest_volume();
  RowMatrixX3d X = m.V;
  X.col(0).array() += 5.0;  // every vertex leaves the box
  try {
    D.set_rest_vertices(X);
    FAIL() << "vertices outside the box must be refused";
  } catch (const InvalidInputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(std::to_string(m.V.rows()) + " vertices lie outside"), std::string::npos) << msg;
    EXPECT_NE(msg.find("the first is vertex 0"), std::string::npos) << msg;
  }
  EXPECT_EQ(D.rest_volume(), V0);
  EXPECT_EQ(D.rest_vertices(), m.V);
  // Non-finite coordinates are refused by the embedding's own pass and then named as
  // such (in the extrapolating Deformer too, where no box test would catch them).
  Deformer E(m.V, m.F, L, OutsidePolicy::Extrapolate);
  for (const double bad : {double(NAN), double(INFINITY), -double(INFINITY)})
    for (Deformer* d : {&D, &E}) {
      RowMatrixX3d Y = m.V;
      Y(4, 1) = bad;
      try {
        d->set_rest_vertices(Y);
        ADD_FAILURE() << "a non-finite coordinate must be refused";
      } catch (const InvalidInputError& e) {
        const std::string msg = e.what();
        EXPECT_NE(msg.find("set_rest_vertices: vertex 4 has a non-finite coordinate"), std::string::npos) << msg;
      }
      EXPECT_EQ(d->rest_vertices(), m.V);
    }
  RowMatrixX3d far = m.V;
  far(7, 2) = 1e300;  // finite, but past the 1000 box extents the embedding takes
  try {
    E.set_rest_vertices(far);
    ADD_FAILURE() << "a vertex 1e300 away must be refused";
  } catch (const InvalidInputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("7 is not finite, or too far from the lattice"), std::string::npos) << msg;
  }
  EXPECT_THROW(D.set_rest_vertices(m.V.topRows(5)), InvalidInputError);
  // With extrapolation a vertex outside the box is fine.
  X = m.V;
  X.col(0).array() += 0.3;
  E.set_rest_vertices(X);
  // A translation keeps the volume; each sum rounds by about F u max|term| (320 faces,
  // terms below 1): under 1e-13 relative, so 1e-12 holds with margin.
  EXPECT_LE(rel(E.rest_volume(), V0), 1e-12);
}
