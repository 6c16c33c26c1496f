// Mesh defect counts and orientation repair (mesh/check.h, mesh/validate.h) and the
// ready-made lattice edits (edits/lattice_edits.h), against hand-counted cases and
// closed forms.

#include <gtest/gtest.h>

#include <cmath>

#include "vpffd/core/exceptions.h"
#include "vpffd/edits/lattice_edits.h"
#include "vpffd/mesh/check.h"
#include "vpffd/mesh/shapes.h"
#include "vpffd/mesh/validate.h"

namespace {

using vpffd::Index;
using vpffd::RowMatrixX3d;
using vpffd::RowMatrixX3i;
using vpffd::Vector3d;

// The regular octahedron with vertices at +-1 on each axis: 6 vertices, 8 faces, 12 edges,
// volume 4/3, all faces wound outward.
vpffd::TriMesh octahedron() {
  vpffd::TriMesh m;
  m.V.resize(6, 3);
  m.V << 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1;
  m.F.resize(8, 3);
  m.F << 0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5;
  return m;
}

// Eight tetrahedra with integer coordinates: each determinant is exact, the sum of 8
// terms and the division by 6 round at most ~8 times by u = 2^-53 of 4/3.
constexpr double kVolTol = 8 * 0x1p-53 * 4.0 / 3.0 * 2;

RowMatrixX3i drop_face(const RowMatrixX3i& F, Index f) {
  RowMatrixX3i G(F.rows() - 1, 3);
  for (Index r = 0, o = 0; r < F.rows(); ++r)
    if (r != f) G.row(o++) = F.row(r);
  return G;
}

}  // namespace

TEST(MeshCheck, CleanOctahedron) {
  const auto m = octahedron();
  const auto r = vpffd::check_mesh(m.V, m.F);
  EXPECT_EQ(r.edges, 12);
  EXPECT_EQ(r.boundary_edges, 0);
  EXPECT_EQ(r.nonmanifold_edges, 0);
  EXPECT_EQ(r.misoriented_edges, 0);
  EXPECT_EQ(r.components, 1);
  EXPECT_EQ(r.euler_characteristic, 2);
  EXPECT_TRUE(r.watertight() && r.closed() && r.is_volume());
  EXPECT_NEAR(r.signed_volume, 4.0 / 3.0, kVolTol);
  EXPECT_TRUE(vpffd::edge_report(m.F).closed());
}

TEST(MeshCheck, HoleIsABoundaryLoop) {
  const auto m = octahedron();
  const RowMatrixX3i F = drop_face(m.F, 0);
  const auto r = vpffd::check_mesh(m.V, F);
  EXPECT_EQ(r.boundary_edges, 3);
  EXPECT_EQ(r.boundary_loops, 1);
  EXPECT_FALSE(r.watertight() || r.closed());
  EXPECT_TRUE(std::isnan(r.signed_volume));
  EXPECT_FALSE(vpffd::edge_report(F).closed());
  EXPECT_THROW(vpffd::require_closed(vpffd::edge_report(F), "test"), vpffd::InvalidInputError);
}

TEST(MeshCheck, OneMeaningOfClosed) {
  // One face flipped: still watertight, no longer a closed surface; every check agrees.
  auto m = octahedron();
  std::swap(m.F(0, 1), m.F(0, 2));
  const auto r = vpffd::check_mesh(m.V, m.F);
  EXPECT_EQ(r.misoriented_edges, 3);
  EXPECT_TRUE(r.watertight());
  EXPECT_FALSE(r.closed());
  EXPECT_FALSE(vpffd::edge_report(m.F).closed());
  EXPECT_TRUE(std::isnan(r.signed_volume));
}

TEST(MeshCheck, OrientRepairsAFlipAndAnInsideOut) {
  auto m = octahedron();
  std::swap(m.F(3, 0), m.F(3, 1));
  const auto o = vpffd::orient_faces(m.V, m.F);
  EXPECT_EQ(o.flipped_faces, 1);
  EXPECT_NEAR(vpffd::check_mesh(m.V, o.F).signed_volume, 4.0 / 3.0, kVolTol);
  // All faces reversed: one closed component turned outward, every face flipped.
  RowMatrixX3i inv = octahedron().F.rowwise().reverse();
  const auto p = vpffd::orient_faces(m.V, inv);
  EXPECT_EQ(p.inward_components, 1);
  EXPECT_EQ(p.flipped_faces, 8);
  EXPECT_NEAR(vpffd::check_mesh(m.V, p.F).signed_volume, 4.0 / 3.0, kVolTol);
}

TEST(MeshCheck, NonManifoldEdgeAndDuplicates) {
  auto m = octahedron();
  RowMatrixX3d V(7, 3);
  V << m.V, 0.5, 0.5, 2.0;
  RowMatrixX3i F(10, 3);
  F << m.F, 0, 2, 6, 0, 2, 4;  // a fin on edge (0, 2) and a copy of face 0
  const auto r = vpffd::check_mesh(V, F);
  EXPECT_GE(r.nonmanifold_edges, 1);
  EXPECT_EQ(r.duplicate_faces, 1);
  EXPECT_FALSE(r.watertight());
}

TEST(MeshCheck, IcosphereCounts) {
  const auto s = vpffd::icosphere(3);
  const auto r = vpffd::check_mesh(s.V, s.F);
  EXPECT_EQ(r.vertices, 642);
  EXPECT_EQ(r.edges, 3 * 1280 / 2);
  EXPECT_TRUE(r.is_volume());
}

TEST(Edits, TwistTurnsTheTopByTheAngleAndKeepsTheBottom) {
  RowMatrixX3d P(4, 3);
  P << 1, 0, 0, 1, 0, 1, 0, 1, 0.5, -1, 0, 1;
  const RowMatrixX3d Q = vpffd::twist(P, M_PI / 2, 2, Vector3d::Zero());
  // Bottom (z = 0) untouched; top (z = 1) turned by 90 degrees; middle by 45.
  EXPECT_EQ(Q.row(0), P.row(0));
  EXPECT_NEAR(Q(1, 0), 0.0, 1e-15);
  EXPECT_NEAR(Q(1, 1), 1.0, 1e-15);
  EXPECT_NEAR(Q(2, 0), -std::sqrt(0.5), 1e-15);
  EXPECT_NEAR(Q(2, 1), std::sqrt(0.5), 1e-15);
  EXPECT_EQ(Q.col(2), P.col(2));
  // Distances from the axis are kept.
  for (Index r = 0; r < 4; ++r) EXPECT_NEAR(Q.row(r).head<2>().norm(), P.row(r).head<2>().norm(), 1e-15);
}

TEST(Edits, BendKeepsLengthsAlongTheCentreLine) {
  // Points on the centre line z = 0 along x in [0, 2]: bent by 90 degrees they lie on a
  // quarter circle of radius 2 / (pi / 2), arc length from the start = their x.
  RowMatrixX3d P(5, 3);
  for (int i = 0; i < 5; ++i) P.row(i) << 0.5 * i, 0, 0;
  const RowMatrixX3d Q = vpffd::bend(P, M_PI / 2, 0, 2, Vector3d::Zero());
  const double R = 2.0 / (M_PI / 2);
  for (int i = 0; i < 5; ++i) {
    const Vector3d c(0, 0, R);
    EXPECT_NEAR((Q.row(i).transpose() - c).norm(), R, 1e-14);
    EXPECT_NEAR(std::atan2(Q(i, 0), R - Q(i, 2)) * R, P(i, 0), 1e-14);
  }
  EXPECT_EQ(vpffd::bend(P, 0.0, 0, 2, Vector3d::Zero()), P);
}

TEST(Edits, TaperAndScale) {
  RowMatrixX3d P(2, 3);
  P << 1, 1, 0, 1, 1, 2;
  const RowMatrixX3d T = vpffd::taper(P, 0.5, 2, Vector3d::Zero());
  EXPECT_EQ(T.row(0), P.row(0));
  EXPECT_EQ(T(1, 0), 0.5);
  EXPECT_EQ(T(1, 1), 0.5);
  EXPECT_EQ(T(1, 2), 2.0);
  const RowMatrixX3d S = vpffd::scale(P, Vector3d(2, 3, 0.5), Vector3d(1, 1, 1));
  EXPECT_EQ(S(1, 0), 1.0);
  EXPECT_EQ(S(1, 2), 1.5);
  EXPECT_EQ(S(0, 2), 0.5);
}

TEST(Edits, BadInputIsRefused) {
  RowMatrixX3d P(2, 3);
  P << 0, 0, 0, 1, 1, 1;
  const Vector3d c = Vector3d::Zero();
  EXPECT_THROW(vpffd::twist(P, 1.0, 3, c), vpffd::InvalidInputError);
  EXPECT_THROW(vpffd::twist(P, NAN, 2, c), vpffd::InvalidInputError);
  EXPECT_THROW(vpffd::bend(P, 1.0, 0, 0, c), vpffd::InvalidInputError);
  RowMatrixX3d flat(2, 3);
  flat << 0, 0, 0, 1, 1, 0;
  EXPECT_THROW(vpffd::taper(flat, 0.5, 2, c), vpffd::InvalidInputError);  // no extent along z
  RowMatrixX3d bad = P;
  bad(1, 1) = INFINITY;
  EXPECT_THROW(vpffd::scale(bad, Vector3d::Ones(), c), vpffd::InvalidInputError);
  EXPECT_THROW(vpffd::scale(RowMatrixX3d(0, 3), Vector3d(NAN, 1, 1), c), vpffd::InvalidInputError);
}
