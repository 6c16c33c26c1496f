#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "helpers.h"

using namespace vpffd;

namespace {

std::vector<double> random_knots(int n, int d, std::mt19937& rng) {
  // Clamped ends, random interior knots (some repeated up to d times).
  std::uniform_real_distribution<double> U(0.0, 1.0);
  std::vector<double> inner(n - d - 1);
  for (double& x : inner) x = U(rng);
  if (d >= 2 && inner.size() >= 2) inner[1] = inner[0];  // a double knot where continuity allows it
  std::sort(inner.begin(), inner.end());
  std::vector<double> t(d + 1, 0.0);
  t.insert(t.end(), inner.begin(), inner.end());
  t.insert(t.end(), d + 1, 1.0);
  return t;
}

}  // namespace

TEST(BSpline, PartitionOfUnityAllDegrees) {
  std::mt19937 rng(1);
  for (int d = 1; d <= kMaxDegree; ++d) {
    const int n = d + 5;
    for (const auto& t : {clamped_uniform_knots(n, d), random_knots(n, d, rng)}) {
      validate_knots(t, n, d, 'u');
      const SpanPolynomials sp = span_polynomials(t, n, d);
      for (int q = 0; q <= 200; ++q) {
        const double u = q / 200.0;
        const int s = find_span(t, n, d, u);
        double N[kMaxDegree + 1], M[kMaxDegree + 1];
        basis_values(t, d, s, u, N);
        eval_span(sp.span_coef(s), d + 1, (u - t[s]) * sp.inv_width[s - d], M);
        double sum = 0;
        for (int r = 0; r <= d; ++r) {
          EXPECT_GE(N[r], -1e-15);
          EXPECT_NEAR(N[r], M[r], 1e-13) << "degree " << d << " u " << u;
          sum += N[r];
        }
        EXPECT_NEAR(sum, 1.0, 1e-14);
      }
    }
  }
}

TEST(BSpline, DerivativesMatchFiniteDifferences) {
  for (int d = 1; d <= kMaxDegree; ++d) {
    const int n = d + 4;
    const auto t = clamped_uniform_knots(n, d);
    const SpanPolynomials sp = span_polynomials(t, n, d);
    for (double u : {0.013, 0.21, 0.5004, 0.77, 0.991}) {
      const int s = find_span(t, n, d, u);
      double N[6], dN[6], Np[6], Nm[6], P[6], dP[6];
      const double h = 1e-6;
      basis_values_derivs(t, d, s, u, N, dN);
      basis_values(t, d, s, u + h, Np);
      basis_values(t, d, s, u - h, Nm);
      eval_span_derivs(sp.span_coef(s), d + 1, (u - t[s]) * sp.inv_width[s - d], P, dP);
      for (int r = 0; r <= d; ++r) {
        EXPECT_NEAR(dN[r], (Np[r] - Nm[r]) / (2 * h), 1e-6) << "degree " << d;
        EXPECT_NEAR(dN[r], dP[r] * sp.inv_width[s - d], 1e-11) << "degree " << d;
      }
    }
  }
}

TEST(BSpline, GrevilleReproducesIdentity) {
  std::mt19937 rng(7);
  for (int d = 1; d <= kMaxDegree; ++d) {
    const int n = d + 4;
    const auto t = random_knots(n, d, rng);
    const auto g = greville(t, n, d);
    for (double u : {0.0, 0.1, 0.33, 0.5, 0.9, 1.0}) {
      const int s = find_span(t, n, d, u);
      double N[6];
      basis_values(t, d, s, u, N);
      double x = 0;
      for (int r = 0; r <= d; ++r) x += N[r] * g[s - d + r];
      EXPECT_NEAR(x, u, 1e-14);
    }
  }
}

TEST(BSpline, BadKnotsAreRejected) {
  EXPECT_THROW(validate_knots({0, 0, 1, 1}, 3, 1, 'x'), InvalidInputError);        // wrong count
  EXPECT_THROW(validate_knots({0, 0, 0.6, 0.4, 1, 1}, 4, 1, 'x'), InvalidInputError);  // decreasing
  EXPECT_THROW(validate_knots({0, 0, 0, 0, 0, 0}, 4, 1, 'x'), InvalidInputError);      // empty domain
  EXPECT_THROW(validate_knots({0, 0, 0.5, 0.5, 1, 1}, 4, 1, 'x'), InvalidInputError);  // multiplicity > d
  EXPECT_THROW(clamped_uniform_knots(3, 3), InvalidInputError);
  EXPECT_THROW(clamped_uniform_knots(8, 6), InvalidInputError);
  try {
    validate_knots({0, 0, NAN, 1, 1}, 3, 1, 'y');
    FAIL();
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("along y"), std::string::npos) << e.what();
  }
}

TEST(BSpline, SpanLocatorFindsFindSpansSpan) {
  // The locator guesses from the mean span length and steps: on random knots (repeated
  // interior knots, spans of very different lengths) it must still give find_span's
  // span for every parameter, at and next to every knot, outside the domain and at its ends.
  std::mt19937 rng(11);
  for (int d = 1; d <= 4; ++d)
    for (int trial = 0; trial < 20; ++trial) {
      const int n = d + 1 + static_cast<int>(rng() % 9);
      const std::vector<double> t = trial == 0 ? clamped_uniform_knots(n, d) : random_knots(n, d, rng);
      const SpanLocator locate(t, n, d);
      std::vector<double> us = {-1.0, -1e-300, 2.0, std::nextafter(1.0, 2.0)};
      for (double k : t) us.insert(us.end(), {k, std::nextafter(k, -1.0), std::nextafter(k, 2.0)});
      std::uniform_real_distribution<double> U(-0.1, 1.1);
      for (int i = 0; i < 200; ++i) us.push_back(U(rng));
      for (double u : us) {
        const int s = locate(u);
        ASSERT_EQ(s, find_span(t, n, d, u)) << "d " << d << " trial " << trial << " u " << u;
        // (u - t_s) < h is exact-or-rounded down to at most h, times fl(1/h) <= (1 + eps)/h:
        // the product is below (1 + eps)^2 < 1 + 1e-15 (eps = 2^-53).
        if (u >= t[d] && u < t[n]) EXPECT_EQ(locate.local(u, s) >= 0.0 && locate.local(u, s) < 1.0 + 1e-15, true);
      }
    }
}

TEST(BSpline, SpanLocatorLocateIsTheSearchUpToRounding) {
  // locate() on uniform knots: s = d + floor(g), tau = g - floor(g), g = (u - t_d) / h,
  // against find_span's span and (u - t_s) / (t_{s+1} - t_s). Rounding: g errs by a
  // few eps |g|, each knot by a few eps max(|lo|, |hi|), i.e. that over h in span
  // units, and tau* by 2 eps; 8 eps (|g| + max(|lo|, |hi|) / h + 1) covers them. Within
  // that of a knot the neighbouring span may be taken, with tau ~ 1 for tau* ~ 0 (or
  // the reverse). On non-uniform knots locate() is the search itself, bit for bit.
  const double eps = std::numeric_limits<double>::epsilon();
  std::mt19937 rng(5);
  int checked = 0;
  for (int d = 1; d <= 5; ++d)
    for (int trial = 0; trial < 24; ++trial) {
      const int n = d + 1 + static_cast<int>(rng() % 40);
      const double lo = trial % 3 == 0 ? 0.0 : -5.0 + 10.0 * (rng() % 1000) / 1000.0;
      const double hi = lo + (trial % 3 == 0 ? 1.0 : 0.01 + 20.0 * (rng() % 1000) / 1000.0);
      const bool uniform = trial % 4 != 3, periodic = uniform && trial % 2 == 1;
      // A periodic axis of m distinct points has m + d control points (extended axis).
      const int m = std::max(d + 1, n - d), nn = periodic ? m + d : n;
      const std::vector<double> t = !uniform   ? random_knots(n, d, rng)
                                    : periodic ? periodic_uniform_knots(m, d, lo, hi)
                                               : clamped_uniform_knots(n, d, lo, hi);
      const SpanLocator locate(t, nn, d);
      const double a = t[d], b = t[nn], h = (b - a) / (nn - d);
      std::vector<double> us = {a - 0.3 * (b - a), a, b, std::nextafter(b, b + 1), b + 0.7 * (b - a)};
      for (int i = d; i <= nn; ++i) us.insert(us.end(), {t[i], std::nextafter(t[i], a - 1), std::nextafter(t[i], b + 1)});
      std::uniform_real_distribution<double> U(a - 0.1 * (b - a), b + 0.1 * (b - a));
      for (int i = 0; i < 300; ++i) us.push_back(U(rng));
      for (double u : us) {
        double tau = 0;
        const int s = locate.locate(u, tau);
        const int s0 = find_span(t, nn, d, u);
        const double tau0 = locate.local(u, s0);
        ++checked;
        if (!uniform) {
          ASSERT_EQ(s, s0);
          ASSERT_EQ(tau, tau0);
          continue;
        }
        const double g = (u - a) / h;
        // The knots the library makes take the arithmetic: exactly g's floor and rest.
        const double f = std::clamp(std::floor((u - a) * locate.steps_per_unit), 0.0, double(nn - 1 - d));
        ASSERT_EQ(s, d + static_cast<int>(f));
        ASSERT_EQ(tau, (u - a) * locate.steps_per_unit - f);
        const double bound = 8 * eps * (std::abs(g) + std::max(std::abs(a), std::abs(b)) / h + 1);
        ASSERT_LE(std::abs(s - s0), 1) << "d " << d << " u " << u;
        ASSERT_NEAR(tau + (s - s0), tau0, bound) << "d " << d << " n " << nn << " u " << u << " span " << s << " vs "
                                                 << s0;
      }
    }
  EXPECT_GT(checked, 10000);
  // A knot a hair off the grid (1e-11 of a span: far beyond rounding) is another
  // spline: the search evaluates it, bit for bit.
  for (int d = 1; d <= 4; ++d) {
    std::vector<double> t = clamped_uniform_knots(12, d, -1.0, 3.0);
    t[d + 2] += 1e-11 * (4.0 / (12 - d));
    const SpanLocator locate(t, 12, d);
    for (double u : {t[d + 2], std::nextafter(t[d + 2], -2.0), 0.3, -0.999, 2.5}) {
      double tau = 0;
      const int s = locate.locate(u, tau);
      ASSERT_EQ(s, find_span(t, 12, d, u)) << u;
      ASSERT_EQ(tau, locate.local(u, s)) << u;
    }
  }
}

// embed_into's loops (written to vectorise) against SpanLocator::locate of each point's
// parameter, computed as ParameterMap does: the same arithmetic (equal up to FMA
// contraction, below), on uniform and non-uniform knots, periodic axes, the box's faces
// and, extrapolated, points far outside.
TEST(BSpline, EmbeddingIsEachPointLocated) {
  std::mt19937 rng(11);
  for (int variant = 0; variant < 4; ++variant) {
    Lattice L = variant == 3 ? make_lattice(Vector3d(-1, -2, 0.5), Vector3d(3, 1, 2.5), {7, 5, 6}, {3, 2, 1},
                                            {Seam::Shift, Seam::None, Seam::None})
                             : make_lattice(Vector3d(-1, -2, 0.5), Vector3d(3, 1, 2.5), {7, 5, 6}, {3, 2, variant + 1});
    if (variant == 1) L.knots[1][L.degree[1] + 1] += 0.07;  // a non-uniform axis
    const OutsidePolicy policy = variant == 2 ? OutsidePolicy::Extrapolate : OutsidePolicy::Error;
    const double reach = policy == OutsidePolicy::Extrapolate ? 3.0 : 0.0;  // box extents beyond
    RowMatrixX3d X(3000, 3);
    for (int a = 0; a < 3; ++a) {
      const double lo = L.box_min[a], ext = L.box_max[a] - L.box_min[a];
      std::uniform_real_distribution<double> U(lo - reach * ext, lo + (1 + reach) * ext);
      for (Index i = 0; i < X.rows(); ++i) X(i, a) = U(rng);
      X(a, a) = L.box_min[a];  // on the box's faces
      X(3 + a, a) = L.box_max[a];
      X(6 + a, a) = std::nextafter(L.box_max[a], -1e9);
    }
    const Embedding E = embed(L, X, policy, 2);
    // embed_cells: the cells of that embedding, without it.
    std::vector<std::int32_t> cells;
    embed_cells(L, X, policy, cells, 2);
    const BasisTables T = basis_tables(L);
    ASSERT_EQ(Index(cells.size()), X.rows());
    for (Index i = 0; i < X.rows(); ++i) ASSERT_EQ(cells[i], detail::cell_index(T, E, i)) << "point " << i;
    const ParameterMap to_parameter(L);
    for (int a = 0; a < 3; ++a) {
      const SpanLocator locate(L.knots[a], L.dim(a), L.degree[a]);
      for (Index i = 0; i < X.rows(); ++i) {
        const Vector3d x = L.any_periodic() ? wrap_point(L, X.row(i).transpose()) : Vector3d(X.row(i).transpose());
        double u = to_parameter(x)[a];
        if (policy == OutsidePolicy::Error) u = std::min(std::max(u, L.domain_lo(a)), L.domain_hi(a));
        double tau = 0;
        const int s = locate.locate(u, tau);
        // The same operations, but a compiler may fuse a multiply and an add (FMA) in
        // one path and not the other: g = (u - lo) / h then differs by a few units of
        // rounding of |g| and of the parameter's terms, which near a knot may put the
        // point in the neighbouring span with tau ~ 1 instead of ~ 0 (the same point).
        const double steps = (L.dim(a) - L.degree[a]) / (L.domain_hi(a) - L.domain_lo(a));
        const double g = (u - L.domain_lo(a)) * steps;
        const double bound =
            16 * std::numeric_limits<double>::epsilon() * (std::abs(g) + std::abs(u) * steps + 1);
        ASSERT_LE(std::abs(E.span[a][i] - s), 1) << "variant " << variant << " axis " << a << " point " << i;
        ASSERT_NEAR(E.tau[a][i] + (E.span[a][i] - s), tau, bound)
            << "variant " << variant << " axis " << a << " point " << i;
      }
    }
  }
}

TEST(BSpline, EmbeddingInAGivenOrderIsTheEmbeddingPermuted) {
  const TriMesh m = icosphere(2);
  const Lattice L = test::lattice_around(m.V, {5, 6, 7}, 3, 0.1);
  std::vector<std::int32_t> order(m.V.rows());
  for (Index i = 0; i < m.V.rows(); ++i) order[i] = static_cast<std::int32_t>((i * 37) % m.V.rows());
  const Embedding E = embed(L, m.V, OutsidePolicy::Error);
  Embedding Eo;
  embed_into(L, m.V, OutsidePolicy::Error, Eo, 2, "vertex", order.data());
  for (int a = 0; a < 3; ++a)
    for (Index i = 0; i < m.V.rows(); ++i) {
      ASSERT_EQ(Eo.span[a][i], E.span[a][order[i]]);
      ASSERT_EQ(Eo.tau[a][i], E.tau[a][order[i]]);
    }
  // Errors name the outside vertex of lowest index whatever the order; Eo is reused.
  RowMatrixX3d X = m.V;
  X(40, 0) = X(7, 1) = 1e3;
  std::string plain, ordered;
  try {
    embed(L, X, OutsidePolicy::Error);
  } catch (const InvalidInputError& e) {
    plain = e.what();
  }
  try {
    embed_into(L, X, OutsidePolicy::Error, Eo, 2, "vertex", order.data());
  } catch (const InvalidInputError& e) {
    ordered = e.what();
  }
  EXPECT_NE(plain.find("2 vertices lie outside"), std::string::npos) << plain;
  EXPECT_NE(plain.find("the first is vertex 7 at"), std::string::npos) << plain;
  EXPECT_EQ(ordered, plain);
  std::vector<std::int32_t> cells;
  try {
    embed_cells(L, X, OutsidePolicy::Error, cells, 2);
    ADD_FAILURE() << "embed_cells took vertices outside the box";
  } catch (const InvalidInputError& e) {
    EXPECT_EQ(std::string(e.what()), plain);
  }
  X(7, 1) = std::nan("");
  try {
    embed_into(L, X, OutsidePolicy::Error, Eo, 1, "vertex", order.data());
    ADD_FAILURE() << "a NaN vertex was embedded";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("vertex 7 is not finite"), std::string::npos) << e.what();
  }
}
