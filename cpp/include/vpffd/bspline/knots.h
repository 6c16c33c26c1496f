#pragma once
/// @file knots.h
/// Knot vectors: construction, validation, span search and Greville abscissae.

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "vpffd/core/check.h"

namespace vpffd {

/// Largest supported B-spline degree. Kernels keep per-vertex basis values on
/// the stack; degree 5 means at most 6 x 6 x 6 = 216 control points per vertex.
inline constexpr int kMaxDegree = 5;

/// Open-uniform (clamped) knot vector on [lo, hi] for `n` control points of
/// degree `d`: d+1 repeated end knots and n-d-1 uniformly spaced interior knots.
/// @returns n + d + 1 knots.
inline std::vector<double> clamped_uniform_knots(int n, int d, double lo = 0.0, double hi = 1.0) {
  VPFFD_CHECK(d >= 1 && d <= kMaxDegree, "clamped_uniform_knots: degree ", d, " not in [1, ", kMaxDegree, "]");
  VPFFD_CHECK(n >= d + 1, "clamped_uniform_knots: ", n, " control points are too few for degree ", d,
              " (need at least ", d + 1, ")");
  std::vector<double> t(static_cast<size_t>(n + d + 1));
  const int spans = n - d;
  for (int i = 0; i < n + d + 1; ++i) {
    const int k = std::clamp(i - d, 0, spans);
    t[i] = (k == spans) ? hi : lo + (hi - lo) * static_cast<double>(k) / spans;
  }
  return t;
}

/// Uniform unclamped knots of a periodic axis with `n` distinct control points of
/// degree `d`: t_i = lo + (i - d) h, h = (hi - lo) / n, i = 0..n+2d, so that the
/// domain [t_d, t_{n+d}] is [lo, hi] and holds n spans.
/// @returns n + 2d + 1 knots (for the n + d control points of the extended axis).
inline std::vector<double> periodic_uniform_knots(int n, int d, double lo = 0.0, double hi = 1.0) {
  VPFFD_CHECK(d >= 1 && d <= kMaxDegree, "periodic_uniform_knots: degree ", d, " not in [1, ", kMaxDegree, "]");
  VPFFD_CHECK(n >= d + 1, "periodic_uniform_knots: ", n, " distinct control points are too few for degree ", d,
              " (need at least degree + 1 = ", d + 1, ")");
  std::vector<double> t(static_cast<size_t>(n + 2 * d + 1));
  for (int i = 0; i < n + 2 * d + 1; ++i) t[i] = lo + (hi - lo) * static_cast<double>(i - d) / n;
  return t;
}

/// Checks that `t` is a usable knot vector for `n` control points of degree `d`:
/// n + d + 1 finite, non-decreasing knots, a non-empty domain [t_d, t_n], and
/// no interior knot repeated more than d times (which would tear the deformation).
/// @throws InvalidInputError naming `axis` and the problem.
inline void validate_knots(const std::vector<double>& t, int n, int d, char axis) {
  VPFFD_CHECK(d >= 1 && d <= kMaxDegree, "lattice: degree ", d, " along ", axis, " not in [1, ", kMaxDegree, "]");
  VPFFD_CHECK(n >= d + 1, "lattice: ", n, " control points along ", axis, " are too few for degree ", d,
              " (need at least ", d + 1, ")");
  VPFFD_CHECK(t.size() == static_cast<size_t>(n + d + 1), "lattice: knot vector along ", axis, " has ", t.size(),
              " knots, expected n + degree + 1 = ", n + d + 1);
  for (size_t i = 0; i < t.size(); ++i) {
    VPFFD_CHECK(std::isfinite(t[i]), "lattice: knot ", i, " along ", axis, " is not finite");
    if (i > 0) VPFFD_CHECK(t[i] >= t[i - 1], "lattice: knots along ", axis, " decrease at index ", i);
  }
  VPFFD_CHECK(t[d] < t[n], "lattice: empty parameter domain along ", axis, " (t[", d, "] == t[", n, "])");
  // The first basis function lives on [t_0, t_{d+1}) and the last on [t_{n-1}, t_{n+d}): each must
  // reach into the domain [t_d, t_n], or its control plane has no influence at all (more than d+1
  // equal end knots, or an end knot of the domain repeated inside it).
  VPFFD_CHECK(t[d + 1] > t[d], "lattice: the first control plane along ", axis,
              " has no influence (the knot ", t[d], " that starts the domain is repeated more than degree + 1 = ",
              d + 1, " times, counting the knots before it)");
  VPFFD_CHECK(t[n - 1] < t[n], "lattice: the last control plane along ", axis,
              " has no influence (the knot ", t[n], " that ends the domain is repeated more than degree + 1 = ",
              d + 1, " times, counting the knots after it)");
  for (int i = d + 1; i < n;) {
    int j = i;
    while (j + 1 < n && t[j + 1] == t[i]) ++j;
    VPFFD_CHECK(j - i + 1 <= d, "lattice: interior knot ", t[i], " along ", axis, " repeated ", j - i + 1,
                " times; at most degree = ", d, " keeps the deformation continuous");
    i = j + 1;
  }
}

/// Index s of the knot span [t_s, t_{s+1}) that holds u, with d <= s < n and the
/// span non-empty. Parameters outside [t_d, t_n] get the first or last span,
/// which evaluates the end polynomial pieces (extrapolation).
inline int find_span(const std::vector<double>& t, int n, int d, double u) {
  if (u >= t[n]) {
    int s = n - 1;
    while (t[s] == t[s + 1]) --s;  // skip empty spans at the end
    return s;
  }
  if (u < t[d]) {
    int s = d;
    while (t[s] == t[s + 1]) ++s;
    return s;
  }
  // Last s in [d, n-1] with t[s] <= u: upper_bound gives the first knot > u.
  auto it = std::upper_bound(t.begin() + d, t.begin() + n + 1, u);
  return static_cast<int>(it - t.begin()) - 1;
}

/// find_span for many parameters on one knot vector: a guess from the mean span
/// length, then steps to the neighbouring knots until t_s <= u < t_{s+1}. The same
/// span as find_span for every u (the last s with t_s <= u), found in one or two
/// predictable comparisons on uniform knots instead of a binary search whose
/// branches a CPU cannot predict (embedding a mesh is a per-vertex loop of them).
struct SpanLocator {
  const double* t;
  int n, d;
  double lo, hi, steps_per_unit;
  std::vector<double> inv_length;  ///< per span s, 1 / (t_{s+1} - t_s) (0 for an empty span)

  SpanLocator(const std::vector<double>& knots, int n_, int d_)
      : t(knots.data()), n(n_), d(d_), lo(knots[d_]), hi(knots[n_]), steps_per_unit((n_ - d_) / (hi - lo)),
        inv_length(knots.size(), 0.0) {
    for (size_t s = 0; s + 1 < knots.size(); ++s)
      if (knots[s + 1] > knots[s]) inv_length[s] = 1.0 / (knots[s + 1] - knots[s]);
    // Uniform: every knot of the domain is the grid point lo + (s - d) h up to the
    // rounding of computing either (clamped_uniform_knots, periodic_uniform_knots: a few
    // eps max(|lo|, |hi|)). A knot further off is a different spline, and the search
    // below is what evaluates it.
    const double slack = 8 * std::numeric_limits<double>::epsilon() * std::max(std::abs(lo), std::abs(hi));
    uniform_ = true;
    for (int s = d; s <= n; ++s)
      uniform_ = uniform_ && std::abs(t[s] - (lo + (s - d) / steps_per_unit)) <= slack;
  }

  /// The local parameter of u in span s: (u - t_s) / (t_{s+1} - t_s), as a multiply.
  double local(double u, int s) const { return (u - t[s]) * inv_length[s]; }

  /// The span of u and its local parameter together (u finite). On uniform knots
  /// both come from g = (u - t_d) steps_per_unit alone: s = d + floor(g) kept in
  /// [d, n - 1], tau = g - (s - d), no knot read, so a loop of them vectorises;
  /// within rounding of a knot that may be the neighbouring span with tau ~ 1 instead
  /// of ~ 0 (the same point of a continuous spline). Otherwise operator() and local().
  int locate(double u, double& tau) const {
    if (uniform_) {
      const double g = (u - lo) * steps_per_unit;
      const double f = std::clamp(std::floor(g), 0.0, double(n - 1 - d));
      tau = g - f;
      return d + static_cast<int>(f);
    }
    const int s = (*this)(u);
    tau = local(u, s);
    return s;
  }

  /// Whether locate() takes the uniform path (for loops that inline it).
  bool uniform() const { return uniform_; }

  int operator()(double u) const {
    // Outside [t_d, t_n) (ends, extrapolation, NaN): find_span's end rules.
    if (!(u >= lo && u < hi)) return end_span(u);
    int s = d + static_cast<int>((u - lo) * steps_per_unit);
    s = s < d ? d : (s > n - 1 ? n - 1 : s);
    while (t[s] > u) --s;       // stops at d: t_d = lo <= u
    while (t[s + 1] <= u) ++s;  // stops below n: t_n = hi > u
    return s;
  }

 private:
  bool uniform_ = false;  ///< knots t_d..t_n on the uniform grid, to rounding

  int end_span(double u) const {
    int s;
    if (u >= hi) {
      s = n - 1;
      while (t[s] == t[s + 1]) --s;
    } else {
      s = d;
      while (t[s] == t[s + 1]) ++s;
    }
    return s;
  }
};

/// Greville abscissae g_i = (t_{i+1} + ... + t_{i+d}) / d, i = 0..n-1. Control
/// points placed at the Greville abscissae make the B-spline the identity map.
inline std::vector<double> greville(const std::vector<double>& t, int n, int d) {
  std::vector<double> g(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    double s = 0;
    for (int k = 1; k <= d; ++k) s += t[i + k];
    g[i] = s / d;
  }
  return g;
}

}  // namespace vpffd
