#pragma once
/// @file basis.h
/// Univariate B-spline basis functions: Cox-de Boor values and first derivatives
/// (the reference), and per-span power-form polynomials (the fast path).

#include <Eigen/Core>
#include <array>
#include <vector>

#include "vpffd/bspline/knots.h"
#include "vpffd/core/types.h"

namespace vpffd {

/// Values N_{s-d..s}(u) of the d+1 basis functions that are non-zero on span s,
/// by the Cox-de Boor triangle. `N` receives d+1 values. Works for u outside the
/// span too (polynomial continuation of that span's pieces).
inline void basis_values(const std::vector<double>& t, int d, int s, double u, double* N) {
  double left[kMaxDegree + 1], right[kMaxDegree + 1];
  N[0] = 1.0;
  for (int j = 1; j <= d; ++j) {
    left[j] = u - t[s + 1 - j];
    right[j] = t[s + j] - u;
    double saved = 0.0;
    for (int r = 0; r < j; ++r) {
      const double tmp = N[r] / (right[r + 1] + left[j - r]);
      N[r] = saved + right[r + 1] * tmp;
      saved = left[j - r] * tmp;
    }
    N[j] = saved;
  }
}

/// Values and first derivatives dN/du of the d+1 non-zero basis functions on span s.
inline void basis_values_derivs(const std::vector<double>& t, int d, int s, double u, double* N, double* dN) {
  // Derivative of a degree-d B-spline from the degree d-1 values:
  // N'_{i,d} = d (N_{i,d-1}/(t_{i+d}-t_i) - N_{i+1,d-1}/(t_{i+d+1}-t_{i+1})).
  double lower[kMaxDegree + 1];
  basis_values(t, d - 1, s, u, lower);  // the d values N_{s-d+1..s, d-1}
  basis_values(t, d, s, u, N);
  for (int r = 0; r <= d; ++r) {
    const int i = s - d + r;
    double a = 0.0, b = 0.0;
    if (r >= 1) {  // N_{i,d-1} is lower[r-1]
      const double den = t[i + d] - t[i];
      if (den > 0) a = lower[r - 1] / den;
    }
    if (r <= d - 1) {  // N_{i+1,d-1} is lower[r]
      const double den = t[i + d + 1] - t[i + 1];
      if (den > 0) b = lower[r] / den;
    }
    dN[r] = d * (a - b);
  }
}

/// The d+1 basis functions of every knot span in power form, N_{s-d+r}(u) =
/// sum_q coef[s][q][r] tau^q with tau = (u - t_s) / (t_{s+1} - t_s).
///
/// Evaluating them is d multiply-adds per function and no division, which is
/// what makes the per-frame passes over the vertices cheap: a vertex keeps only
/// its span and its local parameter tau (the paper's direct polynomial form of
/// the uniform cubic basis, generalised to any knots).
struct SpanPolynomials {
  int degree = 0;
  int first_span = 0;            ///< = degree; spans are first_span .. first_span + n_spans - 1
  int n_spans = 0;               ///< n - degree, empty spans included (never used)
  std::vector<double> inv_width; ///< 1 / (t_{s+1} - t_s) per span, 0 for an empty span
  std::vector<double> coef;      ///< n_spans x (d+1) x (d+1): [span][power q][function r]

  const double* span_coef(int span) const {
    return coef.data() + static_cast<size_t>(span - first_span) * (degree + 1) * (degree + 1);
  }
};

/// Builds the power forms by running the Cox-de Boor recursion on polynomials
/// in tau (exact up to rounding; tau in [0, 1] keeps the coefficients small).
inline SpanPolynomials span_polynomials(const std::vector<double>& t, int n, int d) {
  SpanPolynomials sp;
  sp.degree = d;
  sp.first_span = d;
  sp.n_spans = n - d;
  const int K = d + 1;
  sp.inv_width.resize(sp.n_spans);
  sp.coef.assign(static_cast<size_t>(sp.n_spans) * K * K, 0.0);
  for (int s = d; s < n; ++s) {
    const int si = s - d;
    const double h = t[s + 1] - t[s];
    sp.inv_width[si] = h > 0 ? 1.0 / h : 0.0;
    if (h <= 0) continue;
    // P[r] holds the polynomial (in tau) of N_{s-p+r, p} for the current degree p.
    std::array<std::array<double, kMaxDegree + 1>, kMaxDegree + 1> P{};
    P[0][0] = 1.0;
    for (int p = 1; p <= d; ++p) {
      std::array<std::array<double, kMaxDegree + 1>, kMaxDegree + 1> Q{};
      for (int r = 0; r <= p; ++r) {
        const int i = s - p + r;  // function N_{i,p}
        // term 1: (u - t_i)/(t_{i+p} - t_i) * N_{i,p-1}   (N_{i,p-1} is P[r-1])
        if (r >= 1) {
          const double den = t[i + p] - t[i];
          if (den > 0) {
            const double c0 = (t[s] - t[i]) / den, c1 = h / den;  // u - t_i = (t_s - t_i) + h tau
            for (int q = 0; q < p; ++q) {
              Q[r][q] += c0 * P[r - 1][q];
              Q[r][q + 1] += c1 * P[r - 1][q];
            }
          }
        }
        // term 2: (t_{i+p+1} - u)/(t_{i+p+1} - t_{i+1}) * N_{i+1,p-1}   (P[r])
        if (r <= p - 1) {
          const double den = t[i + p + 1] - t[i + 1];
          if (den > 0) {
            const double c0 = (t[i + p + 1] - t[s]) / den, c1 = -h / den;
            for (int q = 0; q < p; ++q) {
              Q[r][q] += c0 * P[r][q];
              Q[r][q + 1] += c1 * P[r][q];
            }
          }
        }
      }
      P = Q;
    }
    double* c = sp.coef.data() + static_cast<size_t>(si) * K * K;
    // Power-major layout: Horner then runs over all K functions at once (one vector op per power).
    for (int r = 0; r < K; ++r)
      for (int q = 0; q < K; ++q) c[q * K + r] = P[r][q];
  }
  return sp;
}

/// Evaluates the K = d+1 functions of one span at local parameter tau (Horner,
/// all functions side by side).
template <int K>
VPFFD_ALWAYS_INLINE void eval_span(const double* c, double tau, double* N) {
  using Vec = Eigen::Array<double, K, 1>;
  Vec n = Eigen::Map<const Vec>(c + (K - 1) * K);
  for (int q = K - 2; q >= 0; --q) n = n * tau + Eigen::Map<const Vec>(c + q * K);
  Eigen::Map<Vec> out(N);
  out = n;
}

/// Runtime-order version of eval_span.
inline void eval_span(const double* c, int K, double tau, double* N) {
  for (int r = 0; r < K; ++r) N[r] = c[(K - 1) * K + r];
  for (int q = K - 2; q >= 0; --q)
    for (int r = 0; r < K; ++r) N[r] = N[r] * tau + c[q * K + r];
}

/// Values and derivatives d/dtau (multiply by inv_width for d/du).
inline void eval_span_derivs(const double* c, int K, double tau, double* N, double* dN) {
  for (int r = 0; r < K; ++r) {
    N[r] = c[(K - 1) * K + r];
    dN[r] = 0.0;
  }
  for (int q = K - 2; q >= 0; --q)
    for (int r = 0; r < K; ++r) {
      dN[r] = dN[r] * tau + N[r];
      N[r] = N[r] * tau + c[q * K + r];
    }
}

}  // namespace vpffd
