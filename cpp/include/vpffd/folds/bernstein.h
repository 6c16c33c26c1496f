#pragma once
/// @file bernstein.h
/// Trivariate polynomials in tensor-product Bernstein form on the unit cube:
/// p(x, y, z) = sum_ijk c_ijk B^{m0}_i(x) B^{m1}_j(y) B^{m2}_k(z), with
/// B^m_i(x) = C(m, i) x^i (1 - x)^(m - i). Coefficients are stored in C order
/// (i slowest). The operations the fold check needs: derivative (hodograph),
/// de Casteljau subdivision at 1/2, and exact-form products.
///
/// Products are formed in the *scaled* basis C(m, i) c_i: there the product of
/// two polynomials is a plain convolution of the scaled coefficients (no
/// weights), and a scaled coefficient has the sign of the unscaled one.

#include <array>
#include <vector>

#include "vpffd/bspline/knots.h"

namespace vpffd {

/// C(n, k) for n <= 3 * kMaxDegree (exact in double).
inline double binomial(int n, int k) {
  if (k < 0 || k > n) return 0.0;
  double r = 1.0;
  for (int i = 1; i <= k; ++i) r = r * (n - k + i) / i;  // exact: every partial result is an integer
  return r;
}

struct Bernstein3 {
  std::array<int, 3> degree{0, 0, 0};
  std::vector<double> c;

  Bernstein3() = default;
  explicit Bernstein3(std::array<int, 3> deg) { reset(deg); }
  void reset(std::array<int, 3> deg) {
    degree = deg;
    c.assign(static_cast<size_t>(deg[0] + 1) * (deg[1] + 1) * (deg[2] + 1), 0.0);
  }
  int n(int a) const { return degree[a] + 1; }
  size_t index(int i, int j, int k) const { return (static_cast<size_t>(i) * n(1) + j) * n(2) + k; }
  double& operator()(int i, int j, int k) { return c[index(i, j, k)]; }
  double operator()(int i, int j, int k) const { return c[index(i, j, k)]; }
};

/// Forward differences along `axis`: out_i = p_{i+1} - p_i, degree one lower there.
/// (The derivative d p / d x_axis is degree * out; the factor is left to the caller.)
/// With `abs_sum` the entries are added instead: the absolute net of a difference.
inline void bernstein_difference(const Bernstein3& p, int axis, bool abs_sum, Bernstein3& out) {
  std::array<int, 3> deg = p.degree;
  deg[axis] -= 1;
  out.reset(deg);
  const int e[3] = {axis == 0, axis == 1, axis == 2};
  for (int i = 0; i < out.n(0); ++i)
    for (int j = 0; j < out.n(1); ++j)
      for (int k = 0; k < out.n(2); ++k) {
        const double hi = p(i + e[0], j + e[1], k + e[2]), lo = p(i, j, k);
        out(i, j, k) = abs_sum ? hi + lo : hi - lo;
      }
}

/// de Casteljau at 1/2 along `axis`: the halves [0, 1/2] (left) and [1/2, 1]
/// (right) of the same polynomial, each reparametrised to [0, 1]. Halving is
/// exact in binary floating point, so each stage rounds once (the addition).
inline void bernstein_split_half(const Bernstein3& p, int axis, Bernstein3& left, Bernstein3& right) {
  left.reset(p.degree);
  right.reset(p.degree);
  const int m = p.degree[axis];
  double tri[3 * kMaxDegree + 1];
  int idx[3];
  const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
  for (int x = 0; x < p.n(a1); ++x)
    for (int y = 0; y < p.n(a2); ++y) {
      idx[a1] = x;
      idx[a2] = y;
      for (int r = 0; r <= m; ++r) {
        idx[axis] = r;
        tri[r] = p(idx[0], idx[1], idx[2]);
      }
      for (int r = 0; r <= m; ++r) {
        // After stage r, tri[0..m-r] holds b^r_0 .. b^r_{m-r}.
        idx[axis] = r;
        left(idx[0], idx[1], idx[2]) = tri[0];
        idx[axis] = m - r;
        right(idx[0], idx[1], idx[2]) = tri[m - r];
        for (int q = 0; q < m - r; ++q) tri[q] = (tri[q] + tri[q + 1]) * 0.5;
      }
    }
}

/// Multiplies every coefficient by C(m0, i) C(m1, j) C(m2, k): the scaled basis.
inline void bernstein_scale(Bernstein3& p) {
  double b[3][3 * kMaxDegree + 1];
  for (int a = 0; a < 3; ++a)
    for (int i = 0; i <= p.degree[a]; ++i) b[a][i] = binomial(p.degree[a], i);
  for (int i = 0; i < p.n(0); ++i)
    for (int j = 0; j < p.n(1); ++j) {
      const double bij = b[0][i] * b[1][j];  // integers below 2^53: exact
      for (int k = 0; k < p.n(2); ++k) p(i, j, k) *= bij * b[2][k];
    }
}

/// out += sign * p * q for scaled coefficients (a convolution); `out` must have
/// degree p.degree + q.degree.
inline void bernstein_product_add(const Bernstein3& p, const Bernstein3& q, double sign, Bernstein3& out) {
  const int q0 = q.n(0), q1 = q.n(1), q2 = q.n(2);
  for (int i = 0; i < p.n(0); ++i)
    for (int j = 0; j < p.n(1); ++j)
      for (int k = 0; k < p.n(2); ++k) {
        const double a = sign * p(i, j, k);
        if (a == 0) continue;
        for (int x = 0; x < q0; ++x)
          for (int y = 0; y < q1; ++y) {
            double* o = &out(i + x, j + y, k);
            const double* b = q.c.data() + q.index(x, y, 0);
            for (int z = 0; z < q2; ++z) o[z] += a * b[z];
          }
      }
}

}  // namespace vpffd

namespace vpffd {

/// Value of an unscaled Bernstein polynomial at (x, y, z) in [0, 1]^3 (de
/// Casteljau along each axis: convex combinations only, so the computed value is
/// within gamma_{2(m0+m1+m2)} max |c| of the exact one).
inline double bernstein_eval(const Bernstein3& p, double x, double y, double z) {
  std::vector<double> a = p.c;
  const int n0 = p.n(0), n1 = p.n(1), n2 = p.n(2);
  // Along z: each (i, j) row collapses into a[(i * n1 + j) * n2].
  for (int r = 1; r < n2; ++r)
    for (int ij = 0; ij < n0 * n1; ++ij)
      for (int k = 0; k < n2 - r; ++k) a[ij * n2 + k] = (1 - z) * a[ij * n2 + k] + z * a[ij * n2 + k + 1];
  for (int r = 1; r < n1; ++r)
    for (int i = 0; i < n0; ++i)
      for (int j = 0; j < n1 - r; ++j)
        a[(i * n1 + j) * n2] = (1 - y) * a[(i * n1 + j) * n2] + y * a[(i * n1 + j + 1) * n2];
  for (int r = 1; r < n0; ++r)
    for (int i = 0; i < n0 - r; ++i) a[i * n1 * n2] = (1 - x) * a[i * n1 * n2] + x * a[(i + 1) * n1 * n2];
  return a[0];
}

}  // namespace vpffd
