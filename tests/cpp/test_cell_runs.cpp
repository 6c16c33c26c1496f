// The frame's run-by-run kernels (ffd/cell_runs.h) against the per-point kernels
// (ffd/kernels.h), and the vertex fans (mesh/validate.h) against the ring pairs.
#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <random>

#include "helpers.h"
#include "vpffd/ffd/reorder.h"

using namespace vpffd;
using namespace vpffd::test;

namespace {

constexpr double kU = 0x1p-53;  // unit roundoff of double

struct Points {
  Embedding E;  // cell order
  CellRuns runs;
};

/// n random points in (and, with `outside`, a little beyond) the box of L, in cell
/// order. With `skew` their density falls along x (cells near box_max get few
/// points), so the runs are both shorter and longer than kShortRun.
Points random_points(const Lattice& L, Index n, bool outside, unsigned seed, bool skew = false) {
  std::mt19937 gen(seed);
  const double lo = outside ? -0.1 : 0.0, hi = outside ? 1.1 : 1.0;
  std::uniform_real_distribution<double> u(lo, hi);
  RowMatrixX3d X(n, 3);
  for (Index i = 0; i < n; ++i)
    for (int a = 0; a < 3; ++a) {
      double t = u(gen);
      if (skew && a == 0) t = lo + (hi - lo) * std::pow((t - lo) / (hi - lo), 3);
      X(i, a) = L.box_min[a] + t * (L.box_max[a] - L.box_min[a]);
    }
  const BasisTables T = basis_tables(L);
  const Embedding E = embed(L, X, OutsidePolicy::Extrapolate, 1);
  Points p;
  p.E = permute_embedding(E, cell_order(T, E));
  p.runs = cell_runs(p.E);
  return p;
}

/// Both kernels sum the K^3 products of three basis values (each a Horner sum of K
/// power coefficients, |b| <= K cmax) and one control value: each is within
/// (3K + 6) u K^3 (K cmax)^3 max|D| of the exact sum (a product of 3 factors and a
/// chain of at most 3K additions per term, K^3 terms). Their difference is within twice that.
/// (K cmax)^3: a bound on a product of three basis values.
double product_bound(const BasisTables& T, int K) {
  double cmax = 0;
  for (int a = 0; a < 3; ++a)
    for (double c : T.poly[a].coef) cmax = std::max(cmax, std::abs(c));
  return std::pow(K * cmax, 3);
}
double evaluation_bound(const BasisTables& T, int K, double maxD) {
  return 2 * (3 * K + 6) * kU * std::pow(K, 3) * product_bound(T, K) * maxD;
}

}  // namespace

TEST(CellRuns, RunsCoverThePointsCellByCell) {
  const Lattice L = make_lattice(Vector3d(-1, -1, -1), Vector3d(1, 2, 1), {6, 7, 5}, {3, 2, 3});
  auto check = [](const Embedding& E, const CellRuns& R) {
    ASSERT_EQ(R.start.front(), 0);
    ASSERT_EQ(R.start.back(), E.size());
    for (Index r = 0; r < R.size(); ++r) {
      ASSERT_LT(R.start[r], R.start[r + 1]);
      for (Index v = R.start[r]; v < R.start[r + 1]; ++v)
        for (int a = 0; a < 3; ++a) ASSERT_EQ(E.span[a][v], R.span[a][r]);
      if (r > 0) {  // maximal: two neighbouring runs differ in some span
        bool differ = false;
        for (int a = 0; a < 3; ++a) differ |= R.span[a][r] != R.span[a][r - 1];
        ASSERT_TRUE(differ);
      }
    }
  };
  const Points p = random_points(L, 2000, false, 1);
  check(p.E, p.runs);
  // Found by chunks of points in parallel: the same runs for any thread count, also
  // where runs cross the chunks' boundaries (points in a few cells, 5 chunks).
  const Lattice coarse = make_lattice(Vector3d(-1, -1, -1), Vector3d(1, 2, 1), {4, 4, 4}, {2, 2, 2});
  const Points q = random_points(coarse, 41000, false, 2);
  const Embedding unsorted = embed(coarse, RowMatrixX3d::Random(41000, 3) * 0.99, OutsidePolicy::Error, 1);
  for (const Embedding* E : {&q.E, &unsorted}) {
    const CellRuns one = cell_runs(*E, 1), two = cell_runs(*E, 2);
    check(*E, two);
    EXPECT_EQ(one.start, two.start);
    for (int a = 0; a < 3; ++a) EXPECT_EQ(one.span[a], two.span[a]);
  }
  EXPECT_LT(q.runs.size(), 100);  // long runs, across chunk boundaries
}

// For every uniform order 2..6: the run kernels give the per-point kernels' values
// (to the bound above), and split anywhere give the same bits (each point's value
// does not depend on its lane or run piece). The points have runs of both kinds:
// short ones (per-point arithmetic) and long ones (power form).
TEST(CellRuns, KernelsEqualPerPointKernels) {
  for (int degree = 1; degree <= 5; ++degree) {
    const int K = degree + 1;
    SCOPED_TRACE(::testing::Message() << "degree " << degree);
    const Lattice L = make_lattice(Vector3d(-1, -0.5, 0), Vector3d(1, 1.5, 0.8), {degree + 4, degree + 3, degree + 5},
                                   {degree, degree, degree});
    const BasisTables T = basis_tables(L);
    const Points p = random_points(L, 3001, true, 7 + degree, true);
    const Embedding& E = p.E;
    Index n_short = 0, n_long = 0;
    for (Index r = 0; r < p.runs.size(); ++r) (p.runs.length(r) < kShortRun ? n_short : n_long) += 1;
    ASSERT_GE(n_short, 3);
    ASSERT_GE(n_long, 3);
    const Index n = E.size(), N = L.n_control_points();
    std::mt19937 gen(degree);
    std::uniform_real_distribution<double> u(-1, 1);
    VectorXd Px(N), Py(N), Pz(N), D(N);
    for (Index c = 0; c < N; ++c) {
      Px[c] = u(gen);
      Py[c] = u(gen);
      Pz[c] = u(gen);
      D[c] = u(gen);
    }
    const double tol = evaluation_bound(T, K, 1.0);
    ASSERT_LT(tol, 1e-4);  // meaningful: the values are O(1); a wrong cell or span errs by O(0.1)
    // Pieces cut at odd places (mid-run, mid-lane-group).
    const std::vector<Index> cuts = {0, 1, 6, 333, 1000, 1001, 2500, n};
    detail::dispatch_order(T, [&](auto Kc) {
      constexpr int k = decltype(Kc)::value;
      ASSERT_EQ(k, K);
      if constexpr (k > 0) {
        RowMatrixX3d a(n, 3), b(n, 3), c(n, 3);
        detail::ffd_kernel<k>(T, E, Px.data(), Py.data(), Pz.data(), a.data(), 0, n);
        detail::ffd_runs<k>(T, E, p.runs, Px.data(), Py.data(), Pz.data(), b.data(), 0, n);
        for (size_t q = 0; q + 1 < cuts.size(); ++q)
          detail::ffd_runs<k>(T, E, p.runs, Px.data(), Py.data(), Pz.data(), c.data(), cuts[q], cuts[q + 1]);
        EXPECT_LE((a - b).cwiseAbs().maxCoeff(), tol);
        EXPECT_EQ((b - c).cwiseAbs().maxCoeff(), 0.0);
        // Written straight into the caller's order: the same rows, bit for bit, moved.
        std::vector<std::int32_t> order(n);
        for (Index i = 0; i < n; ++i) order[i] = static_cast<std::int32_t>((i * 7919) % n);  // a permutation (n prime)
        RowMatrixX3d ra(n, 3), rb(n, 3);
        detail::ffd_kernel<k>(T, E, Px.data(), Py.data(), Pz.data(), ra.data(), 0, n, order.data());
        for (size_t q = 0; q + 1 < cuts.size(); ++q)
          detail::ffd_runs<k>(T, E, p.runs, Px.data(), Py.data(), Pz.data(), rb.data(), cuts[q], cuts[q + 1],
                              order.data());
        for (Index i = 0; i < n; ++i) {
          ASSERT_EQ(ra.row(order[i]), a.row(i)) << i;
          ASSERT_EQ(rb.row(order[i]), b.row(i)) << i;
        }
        // A coordinate left out (a volume-preserving frame's first axis): written as 0,
        // the other two the same bits, whichever kernel and however the range is cut.
        for (int skip = 0; skip < 3; ++skip) {
          RowMatrixX3d sa(n, 3), sc(n, 3);
          sa.setConstant(7.0);
          sc.setConstant(7.0);
          detail::ffd_kernel<k>(T, E, Px.data(), Py.data(), Pz.data(), sa.data(), 0, n, nullptr, skip);
          for (size_t q = 0; q + 1 < cuts.size(); ++q)
            detail::ffd_runs<k>(T, E, p.runs, Px.data(), Py.data(), Pz.data(), sc.data(), cuts[q], cuts[q + 1],
                                nullptr, skip);
          for (int col = 0; col < 3; ++col) {
            if (col == skip) {
              EXPECT_EQ(sa.col(col).cwiseAbs().maxCoeff(), 0.0) << skip;
              EXPECT_EQ(sc.col(col).cwiseAbs().maxCoeff(), 0.0) << skip;
            } else {
              EXPECT_EQ((sa.col(col) - a.col(col)).cwiseAbs().maxCoeff(), 0.0) << skip;
              EXPECT_EQ((sc.col(col) - b.col(col)).cwiseAbs().maxCoeff(), 0.0) << skip;
            }
          }
        }

        RowMatrixX3d ga = a, gb = a, gc = a;
        detail::gather_kernel<k>(T, E, D.data(), ga.data(), 1, 0, n);
        detail::gather_runs<k>(T, E, p.runs, D.data(), gb.data(), 1, 0, n);
        for (size_t q = 0; q + 1 < cuts.size(); ++q)
          detail::gather_runs<k>(T, E, p.runs, D.data(), gc.data(), 1, cuts[q], cuts[q + 1]);
        EXPECT_LE((ga - gb).cwiseAbs().maxCoeff(), tol);
        EXPECT_EQ((gb - gc).cwiseAbs().maxCoeff(), 0.0);
        EXPECT_EQ((ga.col(0) - a.col(0)).cwiseAbs().maxCoeff(), 0.0);  // one coordinate only
        EXPECT_EQ((gb.col(2) - a.col(2)).cwiseAbs().maxCoeff(), 0.0);

        // Jacobians: the same sums with one basis factor replaced by its derivative,
        // |dN| <= (K - 1) K cmax times the span's d tau / dx, so the value bound times
        // (K - 1) max d tau / dx, doubled for the gradient's extra Horner steps and the
        // final scaling.
        const Vector3d du_dx = parameter_scale(L);
        double max_scale = 0;
        for (int ax = 0; ax < 3; ++ax)
          for (double iw : T.poly[ax].inv_width) max_scale = std::max(max_scale, iw * du_dx[ax]);
        const double jtol = 2 * tol * (K - 1) * max_scale;
        std::vector<double> ja(9 * n), jb(9 * n), jc(9 * n);
        detail::jacobian_points<k>(T, E, Px.data(), Py.data(), Pz.data(), du_dx, ja.data(), 0, n);
        detail::jacobian_runs<k>(T, E, p.runs, Px.data(), Py.data(), Pz.data(), du_dx, jb.data(), 0, n);
        for (size_t q = 0; q + 1 < cuts.size(); ++q)  // blocks holding their own points only
          detail::jacobian_runs<k>(T, E, p.runs, Px.data(), Py.data(), Pz.data(), du_dx, jc.data() + 9 * cuts[q],
                                   cuts[q], cuts[q + 1], cuts[q]);
        double jdiff = 0, jmax = 0;
        for (Index i = 0; i < 9 * n; ++i) {
          jdiff = std::max(jdiff, std::abs(ja[i] - jb[i]));
          jmax = std::max(jmax, std::abs(ja[i]));
        }
        EXPECT_LE(jdiff, jtol);
        EXPECT_GT(jmax, 1e3 * jtol);  // meaningful: the entries are far above the bound
        EXPECT_EQ(jb, jc);

        // The last gather: the points moved in place (as the gathers move them) and
        // sum w (x - o).
        VectorXd w(n);
        for (Index i = 0; i < n; ++i) w[i] = u(gen);
        RowMatrixX3d fa = a, fb = a;
        const double sa = detail::gather_final_kernel<k>(T, E, D.data(), fa.data(), 2, w.data(), 0.25, 0, n);
        const double sb = detail::gather_final_runs<k>(T, E, p.runs, D.data(), fb.data(), 2, w.data(), 0.25, 0, n);
        RowMatrixX3d gz = a;
        detail::gather_runs<k>(T, E, p.runs, D.data(), gz.data(), 2, 0, n);
        // The same moves as gather_runs: the same arithmetic, but the compiler may fuse
        // a multiply and an add (FMA) in one instantiation and not the other (seen at
        // -O2 after an unrelated header change), which changes roundings of the same
        // polynomial evaluation: within its bound `tol`, not bit for bit.
        EXPECT_LE((fb - gz).cwiseAbs().maxCoeff(), tol);
        EXPECT_LE((fa - fb).cwiseAbs().maxCoeff(), tol);
        // The sums: n terms |w| (|x| + |o| + tol) apart by at most n tol max|w| plus
        // their own roundings, 2 n u sum |w (x - o)|.
        double sabs = 0, want = 0;
        for (Index i = 0; i < n; ++i) {
          sabs += std::abs(w[i] * (fa(i, 2) - 0.25));
          want += w[i] * (fb(i, 2) - 0.25);
        }
        EXPECT_LE(std::abs(sb - want), 2 * n * kU * sabs);
        EXPECT_LE(std::abs(sa - sb), n * tol + 2 * n * kU * sabs);

        // The scatter: acc[c] = sum_v w_v B_c(u_v). Each basis value is within the
        // evaluation bound (max|D| = 1) in both, and the n-term sums (moments or
        // products) add at most n + 3 K roundings of terms below |w_v| (K cmax)^3.
        const double wabs = w.cwiseAbs().sum();
        const double stol = (tol + 2 * (n + 3 * K) * kU * product_bound(T, K)) * wabs;
        VectorXd acc_a = VectorXd::Zero(N), acc_b = VectorXd::Zero(N), acc_c = VectorXd::Zero(N);
        int calls = 0;
        Index last = -1;
        auto weight = [&](Index v) { return w[v]; };
        auto counted = [&](Index v) {
          EXPECT_GT(v, last);  // once per point, in order
          last = v;
          ++calls;
          return w[v];
        };
        detail::scatter_kernel<k>(T, E, weight, acc_a.data(), 0, n);
        detail::scatter_runs<k>(T, E, p.runs, counted, acc_b.data(), 0, n);
        EXPECT_EQ(calls, n);
        EXPECT_LE((acc_a - acc_b).cwiseAbs().maxCoeff(), stol);
        // Cut into pieces the sums are regrouped (each piece its own moments): same bound.
        for (size_t q = 0; q + 1 < cuts.size(); ++q)
          detail::scatter_runs<k>(T, E, p.runs, weight, acc_c.data(), cuts[q], cuts[q + 1]);
        EXPECT_LE((acc_a - acc_c).cwiseAbs().maxCoeff(), stol);

        // With the short runs' basis values kept (cache_short_run_basis) every run
        // kernel gives the same bits: the values are point_basis's, the arithmetic the same.
        CellRuns kept = p.runs;
        cache_short_run_basis(T, E, kept, 2);
        Index n_kept = 0;
        for (Index r = 0; r < kept.size(); ++r) n_kept += kept.length(r) < kShortRun ? kept.length(r) : 0;
        ASSERT_GT(n_kept, 0);
        ASSERT_EQ(kept.basis.size(), size_t(3 * K * n_kept));
        EXPECT_EQ(kept.bytes() - p.runs.bytes(), (kept.basis_start.size() + 3 * K * n_kept) * 8);
        for (size_t q = 0; q + 1 < cuts.size(); ++q) {
          RowMatrixX3d kb(n, 3), kr(n, 3);
          kb.setConstant(7.0);
          kr.setConstant(7.0);
          const Index lo = cuts[q], hi = cuts[q + 1];
          detail::ffd_runs<k>(T, E, p.runs, Px.data(), Py.data(), Pz.data(), kb.data(), lo, hi, order.data());
          detail::ffd_runs<k>(T, E, kept, Px.data(), Py.data(), Pz.data(), kr.data(), lo, hi, order.data());
          ASSERT_EQ(kb, kr);
          detail::gather_runs<k>(T, E, p.runs, D.data(), kb.data(), 0, lo, hi);
          detail::gather_runs<k>(T, E, kept, D.data(), kr.data(), 0, lo, hi);
          ASSERT_EQ(kb, kr);
          ASSERT_EQ(detail::gather_final_runs<k>(T, E, p.runs, D.data(), kb.data(), 1, w.data(), 0.25, lo, hi),
                    detail::gather_final_runs<k>(T, E, kept, D.data(), kr.data(), 1, w.data(), 0.25, lo, hi));
          ASSERT_EQ(kb, kr);
          VectorXd sa = VectorXd::Zero(N), sk = VectorXd::Zero(N);
          // Zero weights are skipped by both (a vertex without faces).
          auto some_zero = [&](Index v) { return v % 5 == 0 ? 0.0 : w[v]; };
          detail::scatter_runs<k>(T, E, p.runs, some_zero, sa.data(), lo, hi);
          detail::scatter_runs<k>(T, E, kept, some_zero, sk.data(), lo, hi);
          ASSERT_EQ(sa, sk);
        }
      }
    });
  }
  // Mixed orders take no runs' kernels: nothing is kept.
  const Lattice mixed = make_lattice(Vector3d(-1, -1, -1), Vector3d(1, 1, 1), {5, 6, 5}, {3, 2, 3});
  const Points m = random_points(mixed, 500, false, 3);
  CellRuns kept = m.runs;
  cache_short_run_basis(basis_tables(mixed), m.E, kept);
  EXPECT_TRUE(kept.basis.empty());
  EXPECT_TRUE(kept.basis_start.empty());
}

// Fans hold each ring pair once as two consecutive entries, and nothing else but
// pairs through the vertex itself (which add exactly zero to its weight).
static void expect_fans_match_rings(const VertexRings& rings, const VertexFans& fans) {
  const Index nv = static_cast<Index>(rings.indptr.size()) - 1;
  ASSERT_EQ(static_cast<Index>(fans.indptr.size()), nv + 1);
  for (Index v = 0; v < nv; ++v) {
    std::map<std::pair<int, int>, int> want, got;
    for (auto p = rings.indptr[v]; p < rings.indptr[v + 1]; ++p) ++want[{rings.pairs[2 * p], rings.pairs[2 * p + 1]}];
    for (auto p = fans.indptr[v]; p + 1 < fans.indptr[v + 1]; ++p) {
      const int m = fans.fan[p], n = fans.fan[p + 1];
      if (m == v || n == v) continue;
      ++got[{m, n}];
    }
    ASSERT_EQ(want, got) << "vertex " << v;
  }
}

TEST(VertexFans, ClosedManifoldVerticesAreOneCycle) {
  const TriMesh m = icosphere(3);
  const VertexRings rings = vertex_rings(m.F, m.V.rows());
  const VertexFans fans = vertex_fans(rings);
  expect_fans_match_rings(rings, fans);
  for (Index v = 0; v < m.V.rows(); ++v) {
    const auto b = fans.indptr[v], e = fans.indptr[v + 1];
    EXPECT_EQ(e - b, rings.indptr[v + 1] - rings.indptr[v] + 1);  // d + 1 entries where the pairs take 2 d
    EXPECT_EQ(fans.fan[b], fans.fan[e - 1]);
  }
}

TEST(PaddedFans, RowsFitTheValences) {
  // An icosphere's fans are 6 (valence 5) or 7 entries long: rows of 7, no tails.
  const TriMesh m = icosphere(3);
  const VertexFans fans = vertex_fans(vertex_rings(m.F, m.V.rows()));
  const PaddedFans p = pad_fans(fans);
  EXPECT_EQ(p.width, 7);
  EXPECT_EQ(p.tail.size(), 0u);
  for (Index v = 0; v < m.V.rows(); ++v) {
    const Index len = fans.indptr[v + 1] - fans.indptr[v];
    for (Index k = 0; k < 7; ++k)
      EXPECT_EQ(p.head[7 * v + k], k < len ? fans.fan[fans.indptr[v] + k] : v);
  }
  // Rows of 3: every fan continues in its tail, in order.
  const PaddedFans q = pad_fans(fans, 3);
  for (Index v = 0; v < m.V.rows(); ++v) {
    std::vector<std::int32_t> got(q.head.begin() + 3 * v, q.head.begin() + 3 * v + 3);
    got.insert(got.end(), q.tail.begin() + q.tail_ptr[v], q.tail.begin() + q.tail_ptr[v + 1]);
    EXPECT_EQ(got, std::vector<std::int32_t>(fans.fan.begin() + fans.indptr[v], fans.fan.begin() + fans.indptr[v + 1]));
  }
  EXPECT_THROW(pad_fans(fans, -1), InvalidInputError);
  // A vertex no face uses has an empty fan: a row of itself, weight 0.
  RowMatrixX3d V(m.V.rows() + 1, 3);
  V << m.V, Eigen::RowVector3d(0.1, 0.2, 0.3);
  const PaddedFans r = pad_fans(vertex_fans(vertex_rings(m.F, V.rows())));
  for (int k = 0; k < r.width; ++k) EXPECT_EQ(r.head[r.width * m.V.rows() + k], m.V.rows());
  EXPECT_EQ(detail::fan_weight<0>(V.data(), r, m.V.rows()), 0.0);
}

TEST(VertexFans, OpenAndNonManifoldVertices) {
  // Two cubes touching at a corner (a closed mesh with a non-manifold vertex), and
  // the same with two faces removed (boundary vertices, one with two gaps).
  TriMesh a = box_mesh(2, 1.0);
  const Index n0 = a.V.rows();
  RowMatrixX3d V(2 * n0 - 1, 3);
  V.topRows(n0) = a.V;
  // The second copy shares vertex 0 of the first: mirrored through it.
  std::vector<int> map(n0);
  map[0] = 0;
  for (Index i = 1, k = n0; i < n0; ++i, ++k) {
    V.row(k) = 2 * a.V.row(0) - a.V.row(i);
    map[i] = static_cast<int>(k);
  }
  RowMatrixX3i F(2 * a.F.rows(), 3);
  F.topRows(a.F.rows()) = a.F;
  for (Index f = 0; f < a.F.rows(); ++f)  // a point reflection reverses orientation: two corners swapped
    F.row(a.F.rows() + f) << map[a.F(f, 0)], map[a.F(f, 2)], map[a.F(f, 1)];
  ASSERT_TRUE(edge_report(F).closed());
  const VertexRings rings = vertex_rings(F, V.rows());
  const VertexFans fans = vertex_fans(rings);
  expect_fans_match_rings(rings, fans);
  // Vertex 0 has two cycles: the separator appears once.
  EXPECT_EQ(std::count(fans.fan.begin() + fans.indptr[0], fans.fan.begin() + fans.indptr[1], 0), 1);

  // Same weights, coefficients and volume as the pairs (another order of the same
  // terms: a few roundings of the largest term apart, see RingCoefficientsEqualFacePass).
  const Lattice L = lattice_around(V, {5, 6, 5}, 3);
  const BasisTables T = basis_tables(L);
  const Embedding E0 = embed(L, V, OutsidePolicy::Error, 1);
  const std::vector<std::int32_t> order = cell_order(T, E0);
  const std::vector<std::int32_t> rank = inverse_order(order);
  const Embedding E = permute_embedding(E0, order);
  RowMatrixX3i Fs(F.rows(), 3);
  for (Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) Fs(f, c) = rank[F(f, c)];
  RowMatrixX3d X(V.rows(), 3);
  const RowMatrixX3d P = twist(squashed(L, 0.7), 0.8, 2, Vector3d::Zero());
  const RowMatrixX3d Xc = ffd_points(L, P, V);
  for (Index i = 0; i < X.rows(); ++i) X.row(i) = Xc.row(order[i]);
  const VertexRings rs = vertex_rings(Fs, X.rows());
  const VertexFans fs = vertex_fans(rs);
  const PaddedFans pf = pad_fans(fs);
  const CellRuns runs = cell_runs(E);
  const Vector3d o = 0.5 * (L.box_min + L.box_max);
  for (int ax = 0; ax < 3; ++ax) {
    std::vector<double> wr(X.rows()), wf(X.rows());
    const AxisCoefficients r = coefficients_rings(T, E, rs, X.data(), ax, o, 1, false, wr.data());
    const AxisCoefficients f = coefficients_fans(T, E, pf, X.data(), ax, o, 1, wf.data(), &runs);
    for (Index v = 0; v < X.rows(); ++v) EXPECT_NEAR(wf[v], wr[v], 1e-13);  // |w| ~ 0.1 here
    EXPECT_LE((r.alpha - f.alpha).cwiseAbs().maxCoeff(), 1e-13 * r.alpha.cwiseAbs().maxCoeff());
    EXPECT_LE(std::abs(r.volume - f.volume), 1e-13 * std::abs(r.volume));
    EXPECT_LE(std::abs(f.volume - signed_volume(X, Fs, o)), 1e-13 * std::abs(f.volume));
    // Any row width gives the same terms in the same order: rows of 1 (every fan in
    // its tail) to 16 (every fan padded; the separators of the two-cycle vertex too);
    // widths 4-8 take the unrolled loops (with_fan_width), the others the plain one.
    for (int width : {1, 2, 3, 4, 5, 6, 7, 8, 9, 16}) {
      std::vector<double> ww(X.rows());
      const AxisCoefficients g = coefficients_fans(T, E, pad_fans(fs, width), X.data(), ax, o, 1, ww.data(), &runs);
      EXPECT_EQ(ww, wf) << "width " << width;
      EXPECT_EQ(g.volume, f.volume) << "width " << width;
      EXPECT_EQ((g.alpha - f.alpha).cwiseAbs().maxCoeff(), 0.0) << "width " << width;
    }
    // Rows stored in any order (row_vertex: the Deformer's weight order, rows padded
    // with their own vertex): the same weights, hence the same bits.
    std::vector<std::int32_t> rows(X.rows()), id(X.rows());
    std::iota(rows.begin(), rows.end(), 0);
    std::iota(id.begin(), id.end(), 0);
    std::shuffle(rows.begin(), rows.end(), std::mt19937(ax + 1));
    for (int width : {3, 6, 16}) {
      const PaddedFans shuffled = pad_fans(permute_fans(fs, rows, id), width, 1, rows.data());
      std::vector<double> ws(X.rows());
      const AxisCoefficients h =
          coefficients_fans(T, E, shuffled, X.data(), ax, o, 1, ws.data(), &runs, rows.data());
      EXPECT_EQ(ws, wf) << "width " << width;
      EXPECT_EQ(h.volume, f.volume) << "width " << width;
      EXPECT_EQ((h.alpha - f.alpha).cwiseAbs().maxCoeff(), 0.0) << "width " << width;
    }
  }

  // Open: two faces at vertex 0 removed, one from each octahedron.
  std::vector<Index> drop;
  for (Index f = 0; f < F.rows() && drop.size() < 2; ++f)
    if ((F(f, 0) == 0 || F(f, 1) == 0 || F(f, 2) == 0) && (drop.empty() || f >= a.F.rows())) drop.push_back(f);
  ASSERT_EQ(drop.size(), 2u);
  RowMatrixX3i Fo(F.rows() - 2, 3);
  for (Index f = 0, k = 0; f < F.rows(); ++f)
    if (f != drop[0] && f != drop[1]) Fo.row(k++) = F.row(f);
  const VertexRings ro = vertex_rings(Fo, V.rows());
  const VertexFans fo = vertex_fans(ro);
  expect_fans_match_rings(ro, fo);
}
