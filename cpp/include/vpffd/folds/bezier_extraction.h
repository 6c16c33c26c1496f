#pragma once
/// @file bezier_extraction.h
/// Bezier extraction: on one knot span a B-spline of degree d is a polynomial,
/// and its Bernstein coefficients on that span are linear in the d+1 B-spline
/// coefficients that act there. The matrix of that map is computed here.
///
/// Bernstein coefficient k of the span [t_s, t_{s+1}] is the blossom of the
/// spline at (t_s repeated d-k times, t_{s+1} repeated k times). The blossom is
/// evaluated by de Boor's triangle with those arguments; every weight
/// (x - t_i) / (t_{i+d+1-r} - t_i) then lies in [0, 1], because t_i <= t_s and
/// t_{i+d+1-r} >= t_{s+1} for the indices involved. So the matrix is
/// non-negative and each entry is computed with a relative error of at most
/// gamma_{5d} (see rounding.h), whatever the knots.

#include <vector>

#include "vpffd/bspline/knots.h"
#include "vpffd/core/check.h"

namespace vpffd {

/// Indices s of the non-empty knot spans [t_s, t_{s+1}) of the domain [t_d, t_n].
inline std::vector<int> nonempty_spans(const std::vector<double>& t, int n, int d) {
  std::vector<int> s;
  for (int i = d; i < n; ++i)
    if (t[i] < t[i + 1]) s.push_back(i);
  return s;
}

/// Bezier extraction matrix of span s: E[k * (d+1) + i] is Bernstein coefficient
/// k (k = 0..d) on [t_s, t_{s+1}] of the B-spline N_{s-d+i} (i = 0..d).
/// @param E receives (d+1)^2 values.
inline void bezier_extraction(const std::vector<double>& t, int d, int s, double* E) {
  VPFFD_CHECK(d >= 1 && d <= kMaxDegree && s >= d && s + d + 1 < static_cast<int>(t.size()) + 1 &&
                  t[s] < t[s + 1],
              "bezier_extraction: span ", s, " is not a non-empty span of degree ", d);
  const int K = d + 1;
  // c[i][col]: the de Boor triangle for all K unit coefficient vectors at once.
  double c[kMaxDegree + 1][kMaxDegree + 1];
  for (int k = 0; k <= d; ++k) {
    for (int i = 0; i < K; ++i)
      for (int col = 0; col < K; ++col) c[i][col] = (i == col) ? 1.0 : 0.0;
    for (int r = 1; r <= d; ++r) {
      const double x = (r <= d - k) ? t[s] : t[s + 1];
      // Downwards, so c[i - 1] still holds stage r - 1 when row i is updated.
      for (int i = d; i >= r; --i) {
        const int g = s - d + i;  // global index of the coefficient
        const double lo = t[g], hi = t[g + d + 1 - r];
        const double den = hi - lo;  // >= t_{s+1} - t_s > 0
        const double a = (x - lo) / den, b = (hi - x) / den;
        for (int col = 0; col < K; ++col) c[i][col] = b * c[i - 1][col] + a * c[i][col];
      }
    }
    for (int col = 0; col < K; ++col) E[k * K + col] = c[d][col];
  }
}

/// Extraction matrices of every non-empty span of one axis, in the order of
/// nonempty_spans: (d+1)^2 values each.
inline std::vector<double> bezier_extraction_all(const std::vector<double>& t, int d, const std::vector<int>& spans) {
  const size_t K2 = static_cast<size_t>(d + 1) * (d + 1);
  std::vector<double> E(spans.size() * K2);
  for (size_t c = 0; c < spans.size(); ++c) bezier_extraction(t, d, spans[c], E.data() + c * K2);
  return E;
}

}  // namespace vpffd
