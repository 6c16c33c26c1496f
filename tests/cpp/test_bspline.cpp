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
