// Fold-over certification (vpffd/folds): Bezier extraction, Bernstein algebra,
// and check_folds on maps whose det J is known.

#include <random>

#include "helpers.h"
#include "vpffd/folds/certify.h"

namespace vpffd {
namespace {

Lattice unit_lattice(std::array<int, 3> dims, std::array<int, 3> degree) {
  return make_lattice(Vector3d(-1, -2, 0.5), Vector3d(2, 1, 3), dims, degree);
}

// det J of the FFD at rest-space point x by central differences of ffd_points.
// Step h = 1e-5 of the box: truncation O(h^2 |D'''|) and rounding O(u |D| / h),
// both below 1e-8 relative to |J|^3 for the maps used here.
double fd_det(const Lattice& L, const RowMatrixX3d& P, const Vector3d& x) {
  const Vector3d ext = L.box_max - L.box_min;
  Matrix3d J;
  for (int a = 0; a < 3; ++a) {
    const double h = 1e-5 * ext[a];
    RowMatrixX3d X(2, 3);
    Vector3d xp = x, xm = x;
    xp[a] += h;
    xm[a] -= h;
    X.row(0) = xp.transpose();
    X.row(1) = xm.transpose();
    const RowMatrixX3d D = ffd_points(L, P, X, OutsidePolicy::Extrapolate, 1);
    J.col(a) = (D.row(0) - D.row(1)).transpose() / (2 * h);
  }
  return J.determinant();
}

TEST(BezierExtraction, ReproducesTheBasisOnEverySpan) {
  // Non-uniform knots with a double interior knot: every span's Bernstein form
  // of each B-spline must equal the Cox-de Boor values.
  for (int d = 1; d <= kMaxDegree; ++d) {
    std::vector<double> t(d + 1, 0.0);
    // A double knot where the degree allows it (multiplicity <= d).
    for (double x : {0.1, 0.35, 0.35, 0.6, 0.9})
      if (d > 1 || t.back() != x) t.push_back(x);
    t.insert(t.end(), d + 1, 1.0);
    const int n = static_cast<int>(t.size()) - d - 1;
    validate_knots(t, n, d, 'x');
    const std::vector<int> spans = nonempty_spans(t, n, d);
    ASSERT_EQ(spans.size(), 5u);
    for (int s : spans) {
      std::vector<double> E((d + 1) * (d + 1));
      bezier_extraction(t, d, s, E.data());
      for (double x : E) EXPECT_GE(x, 0.0);  // non-negative by construction
      for (double tau : {0.0, 0.3, 0.77, 1.0}) {
        const double u = t[s] + (t[s + 1] - t[s]) * tau;
        double N[kMaxDegree + 1];
        basis_values(t, d, s, u, N);
        for (int i = 0; i <= d; ++i) {
          double b = 0;
          for (int k = 0; k <= d; ++k) b += E[k * (d + 1) + i] * binomial(d, k) * std::pow(tau, k) * std::pow(1 - tau, d - k);
          // Both sides are sums of d+1 terms in [0, 1] from O(d^2) roundings each.
          EXPECT_NEAR(b, N[i], 1e-14) << "degree " << d << " span " << s << " tau " << tau;
        }
      }
    }
  }
}

TEST(Bernstein, SplitAndProductAgreeWithEvaluation) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(-1, 1);
  Bernstein3 p({2, 3, 1}), q({1, 2, 2});
  for (double& x : p.c) x = U(rng);
  for (double& x : q.c) x = U(rng);
  auto eval = [](const Bernstein3& b, double x, double y, double z) {
    double s = 0;
    for (int i = 0; i < b.n(0); ++i)
      for (int j = 0; j < b.n(1); ++j)
        for (int k = 0; k < b.n(2); ++k)
          s += b(i, j, k) * binomial(b.degree[0], i) * std::pow(x, i) * std::pow(1 - x, b.degree[0] - i) *
               binomial(b.degree[1], j) * std::pow(y, j) * std::pow(1 - y, b.degree[1] - j) *
               binomial(b.degree[2], k) * std::pow(z, k) * std::pow(1 - z, b.degree[2] - k);
    return s;
  };
  Bernstein3 l, r;
  bernstein_split_half(p, 1, l, r);
  Bernstein3 ps = p, qs = q;
  bernstein_scale(ps);
  bernstein_scale(qs);
  Bernstein3 pq({3, 5, 3});
  bernstein_product_add(ps, qs, 1.0, pq);
  // Unscale the product to evaluate it.
  for (int i = 0; i < pq.n(0); ++i)
    for (int j = 0; j < pq.n(1); ++j)
      for (int k = 0; k < pq.n(2); ++k) pq(i, j, k) /= binomial(3, i) * binomial(5, j) * binomial(3, k);
  for (double x : {0.0, 0.2, 0.9})
    for (double y : {0.1, 0.5, 1.0})
      for (double z : {0.0, 0.6}) {
        EXPECT_NEAR(eval(l, x, y, z), eval(p, x, y / 2, z), 1e-13);
        EXPECT_NEAR(eval(r, x, y, z), eval(p, x, 0.5 + y / 2, z), 1e-13);
        EXPECT_NEAR(eval(pq, x, y, z), eval(p, x, y, z) * eval(q, x, y, z), 1e-13);
      }
}

TEST(CheckFolds, IdentityIsCertifiedWithDetOne) {
  for (int d = 1; d <= kMaxDegree; ++d) {
    const Lattice L = unit_lattice({d + 3, d + 2, d + 1}, {d, d, d});
    const FoldReport r = check_folds(L, rest_control_points(L), 3, 1);
    EXPECT_TRUE(r.certified) << "degree " << d;
    EXPECT_FALSE(r.folded);
    EXPECT_EQ(r.n_refined, 0);  // a constant det J needs no subdivision
    EXPECT_EQ(r.cells[0], 3);
    // det J = 1 exactly; rounding of the rest points (Greville abscissae) and of the
    // extraction is a few hundred ulps at most.
    EXPECT_NEAR(r.min_det, 1.0, 1e-12);
    // The lower bound is the smallest coefficient minus the rounding bound of
    // rounding.h: 12 gamma_K (M / D)^3 relative to det J, with K < 1400 (gamma_K <
    // 2e-13) and M / D, the net's size over a Bezier edge, below 3 (d+1) times the
    // box aspect ratio: < 1e-6 for degree 5, whatever the compiler's rounding.
    EXPECT_LE(r.lower_bound, 1.0 + 1e-12);
    EXPECT_GT(r.lower_bound, 1.0 - 1e-6);
  }
}

TEST(CheckFolds, AffineMapHasConstantDet) {
  const Lattice L = unit_lattice({6, 5, 7}, {3, 2, 3});
  Matrix3d A;
  A << 1.2, 0.3, -0.4, 0.1, 0.8, 0.2, -0.3, 0.5, 1.5;
  const RowMatrixX3d P = (rest_control_points(L) * A.transpose()).rowwise() + Vector3d(5, -3, 2).transpose();
  const FoldReport r = check_folds(L, P, 2, 1);
  EXPECT_TRUE(r.certified);
  EXPECT_NEAR(r.min_det, A.determinant(), 1e-12 * std::abs(A.determinant()) * 100);
  EXPECT_LE(r.lower_bound, A.determinant() * (1 + 1e-12));
  EXPECT_GT(r.lower_bound, A.determinant() * (1 - 1e-6));  // the rounding bound, see above
  // A reflection has det J < 0 everywhere: every cell is folded.
  Matrix3d M = A;
  M.col(0) *= -1;
  const FoldReport f = check_folds(L, rest_control_points(L) * M.transpose(), 2, 1);
  EXPECT_TRUE(f.folded);
  EXPECT_FALSE(f.certified);
  EXPECT_EQ(f.n_folded, Index(f.status.size()));
  EXPECT_NEAR(f.witness_det, -A.determinant(), 1e-12 * 100);
}

TEST(CheckFolds, TwistOf90DegreesIsCertified) {
  const Lattice L = unit_lattice({8, 8, 8}, {3, 3, 3});
  const Vector3d c = 0.5 * (L.box_min + L.box_max);
  const RowMatrixX3d P = twist(rest_control_points(L), M_PI / 2, 2, c);
  const FoldReport r = check_folds(L, P, 3, 1);
  EXPECT_TRUE(r.certified);
  EXPECT_GT(r.lower_bound, 0.0);
  EXPECT_LE(r.lower_bound, r.min_det);
}

TEST(CheckFolds, SwappedSlabsFoldWithAVerifiedWitness) {
  for (int d : {1, 2, 3}) {
    const Lattice L = unit_lattice({7, 7, 7}, {d, d, d});
    RowMatrixX3d P = rest_control_points(L);
    // Swap the u = 2 and u = 4 control slabs (a fold of the x direction).
    for (int j = 0; j < 7; ++j)
      for (int k = 0; k < 7; ++k) P.row(L.index(2, j, k)).swap(P.row(L.index(4, j, k)));
    const FoldReport r = check_folds(L, P, 3, 1);
    ASSERT_TRUE(r.folded) << "degree " << d;
    EXPECT_FALSE(r.certified);
    ASSERT_TRUE(r.has_witness);
    EXPECT_LT(r.witness_det, 0.0);
    const double fd = fd_det(L, P, r.witness);
    EXPECT_LT(fd, 0.0) << "degree " << d;
    EXPECT_NEAR(fd, r.witness_det, 1e-5 * std::abs(r.witness_det) + 1e-7);
    EXPECT_GT(r.n_folded, 0);
    // A folded cell keeps the bound of its own net: finite and below the witness.
    EXPECT_TRUE(std::isfinite(r.lower_bound));
    EXPECT_LE(r.lower_bound, r.witness_det);
  }
}

TEST(CheckFolds, RandomEditsAgreeWithSampling) {
  // Whatever the size of the edit: where sampling finds det J < 0 the lattice is
  // not certified; a certified lattice samples positive; every witness verifies.
  std::mt19937 rng(11);
  for (double amp : {0.01, 0.1, 0.3, 0.6, 1.0}) {
    for (int trial = 0; trial < 4; ++trial) {
      const int d = 1 + trial % 3;
      const Lattice L = unit_lattice({d + 3, d + 3, d + 3}, {d, d, d});
      std::normal_distribution<double> N(0, amp * 3.0 / (d + 3));
      RowMatrixX3d P = rest_control_points(L);
      for (Index r = 0; r < P.rows(); ++r)
        for (int c = 0; c < 3; ++c) P(r, c) += N(rng);
      const FoldReport rep = check_folds(L, P, 3, 1);
      EXPECT_FALSE(rep.certified && rep.folded);
      double min_sampled = std::numeric_limits<double>::infinity();
      for (double x : {0.02, 0.3, 0.5, 0.71, 0.98})
        for (double y : {0.02, 0.3, 0.5, 0.71, 0.98})
          for (double z : {0.02, 0.3, 0.5, 0.71, 0.98}) {
            const Vector3d p = L.box_min + Vector3d(x, y, z).cwiseProduct(L.box_max - L.box_min);
            min_sampled = std::min(min_sampled, fd_det(L, P, p));
          }
      if (min_sampled < -1e-6) EXPECT_FALSE(rep.certified) << "amp " << amp;
      if (rep.certified) {
        EXPECT_GT(min_sampled, 0.0);
        EXPECT_LE(rep.lower_bound, min_sampled * (1 + 1e-6));
      }
      if (rep.folded) {
        ASSERT_TRUE(rep.has_witness);
        const double fd = fd_det(L, P, rep.witness);
        EXPECT_LT(fd, 0.0);
      }
      EXPECT_LE(rep.lower_bound, rep.min_det);
    }
  }
}

TEST(CheckFolds, DetWithinRoundingOfZeroNeverCertifies) {
  // All control points on a plane: det J = 0 identically; rounding makes some
  // computed coefficients positive, which must not certify anything.
  const Lattice L = unit_lattice({6, 6, 6}, {3, 3, 3});
  RowMatrixX3d P = rest_control_points(L);
  const Vector3d n = Vector3d(0.3, -0.5, 0.8).normalized();
  for (Index r = 0; r < P.rows(); ++r) {
    const Vector3d p = P.row(r).transpose();
    P.row(r) = (p - n * n.dot(p)).transpose();  // projection onto the plane n.x = 0
  }
  const FoldReport rep = check_folds(L, P, 4, 1);
  EXPECT_FALSE(rep.certified);
  EXPECT_FALSE(rep.folded);
  EXPECT_EQ(rep.n_unknown, Index(rep.status.size()));
  // Numerically zero cells stop at once instead of splitting to the depth.
  EXPECT_EQ(rep.n_subcells, Index(rep.status.size()));
}

TEST(CheckFolds, NonUniformKnotsAndMixedDegrees) {
  Lattice L;
  L.degree = {2, 3, 1};
  L.knots[0] = {0, 0, 0, 0.2, 0.2, 0.7, 1, 1, 1};
  L.knots[1] = {0, 0, 0, 0, 0.4, 0.5, 1, 1, 1, 1};
  L.knots[2] = {0, 0, 0.3, 0.31, 1, 1};
  L.box_min = Vector3d(0, 0, 0);
  L.box_max = Vector3d(1, 2, 1);
  validate_lattice(L);
  const Vector3d c = 0.5 * (L.box_min + L.box_max);
  const RowMatrixX3d P = twist(rest_control_points(L), 0.8, 2, c);
  const FoldReport r = check_folds(L, P, 3, 1);
  EXPECT_EQ(r.cells[0], 3);  // the double knot 0.2 leaves an empty span
  EXPECT_EQ(r.cells[1], 3);
  EXPECT_EQ(r.cells[2], 3);
  EXPECT_TRUE(r.certified);
  // The world-unit det at the cell corners matches finite differences.
  const FoldReport id = check_folds(L, rest_control_points(L), 0, 1);
  EXPECT_TRUE(id.certified);
  EXPECT_NEAR(id.min_det, 1.0, 1e-12);
}

TEST(CheckFolds, ThreadCountDoesNotChangeTheReport) {
  const Lattice L = unit_lattice({9, 9, 9}, {3, 3, 3});
  std::mt19937 rng(3);
  std::normal_distribution<double> N(0, 0.25);
  RowMatrixX3d P = rest_control_points(L);
  for (Index r = 0; r < P.rows(); ++r) P(r, 0) += N(rng);
  const FoldReport a = check_folds(L, P, 3, 1), b = check_folds(L, P, 3, 4);
  EXPECT_EQ(a.status, b.status);
  EXPECT_EQ(a.cell_min_det, b.cell_min_det);
  EXPECT_EQ(a.witness, b.witness);
  EXPECT_EQ(a.n_subcells, b.n_subcells);
}

TEST(CheckFolds, BadInput) {
  const Lattice L = unit_lattice({5, 5, 5}, {3, 3, 3});
  RowMatrixX3d P = rest_control_points(L);
  EXPECT_THROW(check_folds(L, P.topRows(10), 3), InvalidInputError);
  EXPECT_THROW(check_folds(L, P, -1), InvalidInputError);
  EXPECT_THROW(check_folds(L, P, kMaxFoldDepth + 1), InvalidInputError);
  P(7, 1) = std::nan("");
  EXPECT_THROW(check_folds(L, P, 3), InvalidInputError);
}

}  // namespace
}  // namespace vpffd
