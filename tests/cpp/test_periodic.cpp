// Periodic lattices (lattice/periodic.h): the tie map, expansion and fold, the
// periodic basis, and the wrap of points (on the Vulkan backend: test_vulkan.cpp).
#include <random>

#include "helpers.h"

using namespace vpffd;

namespace {

Lattice periodic_lattice(std::array<int, 3> distinct, std::array<int, 3> degree, std::array<Seam, 3> seam) {
  return make_lattice(Vector3d(-1.0, 0.5, 2.0), Vector3d(2.0, 1.5, 2.75), distinct, degree, seam);
}

RowMatrixX3d random_points(Index n, std::mt19937& rng) {
  std::normal_distribution<double> N(0.0, 1.0);
  RowMatrixX3d P(n, 3);
  for (Index r = 0; r < n; ++r)
    for (int c = 0; c < 3; ++c) P(r, c) = N(rng);
  return P;
}

}  // namespace

TEST(Periodic, KnotsAreUniformAndSpanTheBox) {
  for (int d = 1; d <= kMaxDegree; ++d) {
    const int n = d + 3;
    const std::vector<double> t = periodic_uniform_knots(n, d);
    ASSERT_EQ(t.size(), size_t(n + 2 * d + 1));
    EXPECT_EQ(t[d], 0.0);
    EXPECT_EQ(t[n + d], 1.0);
    validate_knots(t, n + d, d, 'x');
  }
  EXPECT_THROW(periodic_uniform_knots(3, 3), InvalidInputError);  // 3 distinct points, cubic: too few
}

// Periodic basis: with uniform knots B_{i+n}(u + n h) = B_i(u), so summing the
// extended basis through the tie map gives a partition of unity whose functions
// are translates of one another around the circle (each is B_0 shifted).
TEST(Periodic, FoldedBasisIsCyclic) {
  for (int d = 1; d <= kMaxDegree; ++d) {
    const int n = d + 4, ne = n + d;
    const std::vector<double> t = periodic_uniform_knots(n, d);
    auto folded = [&](double u) {
      std::vector<double> f(n, 0.0);
      const int s = find_span(t, ne, d, u);
      double N[kMaxDegree + 1];
      basis_values(t, d, s, u, N);
      for (int r = 0; r <= d; ++r) f[(s - d + r) % n] += N[r];
      return f;
    };
    for (int q = 0; q < 97; ++q) {
      const double u = q / 97.0;
      const std::vector<double> f = folded(u);
      double sum = 0;
      for (double v : f) sum += v;
      EXPECT_NEAR(sum, 1.0, 1e-14);
      // Cyclic: basis i at u equals basis (i+1) at u + 1/n (mod 1).
      double up = u + 1.0 / n;
      if (up >= 1.0) up -= 1.0;
      const std::vector<double> g = folded(up);
      for (int i = 0; i < n; ++i) EXPECT_NEAR(f[i], g[(i + 1) % n], 1e-13) << "degree " << d << " u " << u;
    }
  }
}

TEST(Periodic, TieMapAndFoldAreAdjoint) {
  std::mt19937 rng(5);
  for (Seam seam : {Seam::Shift, Seam::Closed, Seam::Twist}) {
    const Lattice L = periodic_lattice({5, 4, 3}, {3, 2, 2}, {seam, Seam::None, Seam::None});
    const Ties t = make_ties(L);
    ASSERT_FALSE(t.identity);
    ASSERT_EQ(t.n_distinct, 5 * 4 * 3);
    ASSERT_EQ(Index(t.source.size()), L.n_control_points());
    // Every distinct point is its own home's source, and restrict undoes expand.
    for (Index s = 0; s < t.n_distinct; ++s) EXPECT_EQ(t.source[t.home[s]], s);
    const RowMatrixX3d P = random_points(t.n_distinct, rng);
    const RowMatrixX3d E = expand_points(t, P);
    EXPECT_EQ((restrict_points(t, E) - P).cwiseAbs().maxCoeff(), 0.0);
    // The ties of the spec: slice n + m copies slice m (moved or mirrored by the seam).
    for (int m = 0; m < 3; ++m)
      for (int j = 0; j < 4; ++j)
        for (int k = 0; k < 3; ++k) {
          const Vector3d e = E.row(L.index(5 + m, j, k)).transpose();
          if (seam == Seam::Twist) {
            EXPECT_EQ((e - P.row((m * 4 + (3 - j)) * 3 + (2 - k)).transpose()).norm(), 0.0);
          } else {
            Vector3d want = P.row((m * 4 + j) * 3 + k).transpose();
            if (seam == Seam::Shift) want.x() += 3.0;
            EXPECT_EQ((e - want).norm(), 0.0);
          }
        }
    // fold is the transpose of expand_offsets: fold(a) . d == a . expand(d).
    const VectorXd a = random_points(L.n_control_points(), rng).col(0);
    const VectorXd d = random_points(t.n_distinct, rng).col(1);
    EXPECT_NEAR(fold(t, a).dot(d), a.dot(expand_offsets(t, d)), 1e-12 * a.norm() * d.norm() * 4);
  }
}

TEST(Periodic, ShiftSeamRestLatticeIsTheIdentityAndTilesSpace) {
  const Lattice L = periodic_lattice({6, 4, 5}, {3, 3, 2}, {Seam::Shift, Seam::None, Seam::Shift});
  const Ties t = make_ties(L);
  // The extended rest lattice is the expansion of its distinct rows.
  const RowMatrixX3d rest = rest_control_points(L);
  const RowMatrixX3d P = restrict_points(t, rest);
  EXPECT_LE((expand_points(t, P) - rest).cwiseAbs().maxCoeff(), 1e-14 * 4);
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> U(-3.0, 5.0);
  RowMatrixX3d X(200, 3);
  std::uniform_real_distribution<double> V(0.5, 1.5), W(-1.0, 4.0);
  for (Index r = 0; r < X.rows(); ++r) X.row(r) << U(rng), V(rng), W(rng);
  const RowMatrixX3d D = ffd_points(L, expand_points(t, P), X);
  // Points anywhere along the periodic axes map onto themselves (rounding of the
  // wrap and of a sum of <= 64 products of size ~5: well below 1e-12 of the box).
  EXPECT_LE((D - X).cwiseAbs().maxCoeff(), 1e-12 * 5);
}

TEST(Periodic, WrapMirrorsAcrossATwistedSeam) {
  const Lattice L = periodic_lattice({6, 4, 3}, {3, 3, 2}, {Seam::Twist, Seam::None, Seam::None});
  bool flip = false;
  const Vector3d x(0.25, 0.6, 2.1);
  Vector3d w = wrap_point(L, x + Vector3d(3.0, 0, 0), &flip);
  EXPECT_TRUE(flip);
  EXPECT_NEAR(w.x(), 0.25, 1e-15 * 4);
  EXPECT_NEAR(w.y(), 0.5 + 1.5 - 0.6, 1e-15 * 4);
  EXPECT_NEAR(w.z(), 2.0 + 2.75 - 2.1, 1e-15 * 8);
  w = wrap_point(L, x - Vector3d(6.0, 0, 0), &flip);
  EXPECT_FALSE(flip);
  EXPECT_NEAR((w - x).norm(), 0.0, 1e-14);
}

TEST(Periodic, ValidationNamesTheProblem) {
  Lattice L = periodic_lattice({5, 4, 3}, {3, 3, 2}, {Seam::Twist, Seam::None, Seam::None});
  L.seam[1] = Seam::Closed;
  L.knots[1] = periodic_uniform_knots(4, 3);
  EXPECT_THROW(validate_lattice(L), InvalidInputError);  // twist with another periodic axis
  Lattice M = periodic_lattice({5, 4, 3}, {3, 3, 2}, {Seam::Closed, Seam::None, Seam::None});
  M.knots[0][4] += 0.01;  // no longer uniform
  EXPECT_THROW(validate_lattice(M), InvalidInputError);
}

// The volume correction on a periodic lattice solves for the distinct points: the
// corrected offsets are tied by copies, and the volume is exact.
TEST(Periodic, DeformerCorrectsOnDistinctPoints) {
  const TriMesh m = box_mesh(6, 1.0);
  const Lattice L = make_lattice(Vector3d::Constant(-0.6), Vector3d::Constant(0.6), {6, 5, 5}, {3, 3, 3},
                                 {Seam::Shift, Seam::None, Seam::None});
  Deformer d(m.V, m.F, L);
  ASSERT_EQ(d.n_control_points(), 6 * 5 * 5);
  RowMatrixX3d P = restrict_points(d.ties(), rest_control_points(L));
  for (Index r = 0; r < P.rows(); ++r) P(r, 2) *= 1.0 + 0.3 * std::sin(3.0 * P(r, 0));
  CorrectionOptions opt;
  const DeformResult res = d.deform(P, opt);
  EXPECT_NEAR(res.volume, d.rest_volume(), 1e-12 * 4);
  ASSERT_EQ(res.control_points.rows(), P.rows());
  // The result equals the FFD of the corrected distinct points (expanded).
  EXPECT_LE((d.ffd(res.control_points) - res.vertices).cwiseAbs().maxCoeff(), 1e-12 * 4);
}

