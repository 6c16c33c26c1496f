#pragma once
/// @file periodic.h
/// Periodic axes: the map between the control points a user sets (the *distinct*
/// ones) and those the kernels evaluate (the *extended* lattice).
///
/// A periodic axis a with n distinct control points and degree d is stored as an
/// ordinary axis of n + d control points on uniform unclamped knots whose domain
/// [t_d, t_{n+d}] spans the box (knots.h periodic_uniform_knots). The last d
/// slices are tied to the first d by the axis's Seam (lattice.h):
///   Shift   P_ext[n+m] = P[m] + extent_a e_a
///   Closed  P_ext[n+m] = P[m]
///   Twist   P_ext[n+m, j, k] = P[m, nv-1-j, nw-1-k]   (j, k: the other two axes)
/// With uniform knots B_{i+n}(u + n h) = B_i(u), so the spline continues across the
/// end of the box into its start with all its d-1 derivatives: there is no seam.
///
/// Displacements (volume and constraint corrections) are tied by pure copies, so a
/// correction is a vector over the distinct points: the coefficients of the extended
/// lattice are folded onto them (summed through the map), the solve runs on them
/// (correction/tied_solve.h), and its result is expanded back.

#include <cmath>
#include <cstdint>
#include <vector>

#include "vpffd/core/types.h"
#include "vpffd/lattice/lattice.h"

namespace vpffd {

/// The tie map of a lattice: extended row -> distinct row, and the constant the
/// Shift seam adds.
struct Ties {
  bool identity = true;              ///< no periodic axis: extended == distinct
  Index n_distinct = 0;
  std::vector<std::int32_t> source;  ///< per extended row, the distinct row it copies
  std::vector<std::int32_t> home;    ///< per distinct row, its extended row with the same (i, j, k)
  RowMatrixX3d shift;                ///< per extended row, added to the copy (Shift seams); empty if none
};

inline Ties make_ties(const Lattice& L) {
  Ties t;
  t.n_distinct = L.n_distinct_points();
  if (!L.any_periodic()) return t;
  t.identity = false;
  const std::array<int, 3> ne = L.dims();
  std::array<int, 3> nd;
  for (int a = 0; a < 3; ++a) nd[a] = L.distinct_dim(a);
  const bool shifted = L.seam[0] == Seam::Shift || L.seam[1] == Seam::Shift || L.seam[2] == Seam::Shift;
  t.source.resize(static_cast<size_t>(L.n_control_points()));
  t.home.resize(static_cast<size_t>(t.n_distinct));
  if (shifted) t.shift = RowMatrixX3d::Zero(L.n_control_points(), 3);
  for (int i = 0; i < ne[0]; ++i)
    for (int j = 0; j < ne[1]; ++j)
      for (int k = 0; k < ne[2]; ++k) {
        std::array<int, 3> q{i, j, k};
        Vector3d c = Vector3d::Zero();
        for (int a = 0; a < 3; ++a) {
          if (q[a] < nd[a]) continue;  // only periodic axes have tied slices
          q[a] -= nd[a];
          if (L.seam[a] == Seam::Shift) c[a] += L.box_max[a] - L.box_min[a];
          if (L.seam[a] == Seam::Twist)
            for (int b = 0; b < 3; ++b)
              if (b != a) q[b] = nd[b] - 1 - q[b];  // validate_periodic: b is not periodic
        }
        const Index r = L.index(i, j, k);
        const Index s = (Index(q[0]) * nd[1] + q[1]) * nd[2] + q[2];
        t.source[r] = static_cast<std::int32_t>(s);
        if (shifted) t.shift.row(r) = c.transpose();
        if (i < nd[0] && j < nd[1] && k < nd[2]) t.home[s] = static_cast<std::int32_t>(r);
      }
  return t;
}

/// The extended control points (N_ext x 3) of distinct ones P (N x 3).
inline RowMatrixX3d expand_points(const Ties& t, const Eigen::Ref<const RowMatrixX3d>& P) {
  if (t.identity) return P;
  RowMatrixX3d E(static_cast<Index>(t.source.size()), 3);
  for (Index r = 0; r < E.rows(); ++r) E.row(r) = P.row(t.source[r]);
  if (t.shift.rows() > 0) E += t.shift;
  return E;
}

/// Coordinate `a` of the extended control points, from coordinate `a` of distinct ones.
inline VectorXd expand_column(const Ties& t, const Eigen::Ref<const VectorXd>& v, int a) {
  if (t.identity) return v;
  VectorXd e(static_cast<Index>(t.source.size()));
  for (Index r = 0; r < e.size(); ++r) e[r] = v[t.source[r]];
  if (t.shift.rows() > 0) e += t.shift.col(a);
  return e;
}

/// Displacements of the extended points: pure copies (no seam constant).
inline VectorXd expand_offsets(const Ties& t, const Eigen::Ref<const VectorXd>& delta) {
  if (t.identity) return delta;
  VectorXd e(static_cast<Index>(t.source.size()));
  for (Index r = 0; r < e.size(); ++r) e[r] = delta[t.source[r]];
  return e;
}

/// The distinct points' rows of extended control points (the inverse of expand_points).
inline RowMatrixX3d restrict_points(const Ties& t, const Eigen::Ref<const RowMatrixX3d>& E) {
  if (t.identity) return E;
  RowMatrixX3d P(t.n_distinct, 3);
  for (Index s = 0; s < t.n_distinct; ++s) P.row(s) = E.row(t.home[s]);
  return P;
}

/// Coefficients over the extended points folded onto the distinct ones: the
/// transpose of expand_offsets, so fold(alpha) . delta == alpha . expand_offsets(delta).
inline VectorXd fold(const Ties& t, const Eigen::Ref<const VectorXd>& v) {
  if (t.identity) return v;
  VectorXd f = VectorXd::Zero(t.n_distinct);
  for (Index r = 0; r < v.size(); ++r) f[t.source[r]] += v[r];
  return f;
}

/// A world point moved into the box along the periodic axes of L, where the
/// spline is evaluated. What the point's image is then depends on the seam:
///  * Shift: the map is periodic up to the translation it repeats with,
///    D(x + k L e_a) = D(x) + k L e_a (the rest lattice is the identity everywhere,
///    and an edit tiles space); `translation` receives k L e_a, to add to the image.
///  * Closed: D(x + k L e_a) = D(x): the point and its wrapped twin map to one place.
///  * Twist: D(x + L e_a) = D(x with the two other coordinates mirrored in the box):
///    the band comes back upside down; `mirrored` tells whether that happened (an
///    odd number of turns), and the wrapped point returned is already mirrored.
inline Vector3d wrap_point(const Lattice& L, Vector3d x, bool* mirrored = nullptr,
                           Vector3d* translation = nullptr) {
  bool flip = false;
  if (translation) translation->setZero();
  for (int a = 0; a < 3; ++a) {
    if (!L.periodic(a) || !std::isfinite(x[a])) continue;
    const double lo = L.box_min[a], ext = L.box_max[a] - L.box_min[a];
    double turns = std::floor((x[a] - lo) / ext);
    // One rounding on every build. Left to the compiler, an FMA build fuses this
    // multiply-subtract and a baseline build rounds the product first: the wrapped
    // point's last bit, and far along the axis (~1e19 box extents, where the
    // remainder is all rounding) whether the embedding refuses it as too far, would
    // depend on the build. std::fma is what FMA builds computed before.
    double y = std::fma(-turns, ext, x[a]);
    // Rounding can leave y a hair outside [lo, lo + ext).
    if (y >= L.box_max[a]) {
      y -= ext;
      turns += 1;
    }
    if (y < lo) y = lo;
    // The translation is the one the point was moved by, so x maps exactly onto x on
    // the rest lattice (not onto y + turns * ext, which rounds differently).
    if (translation && L.seam[a] == Seam::Shift) (*translation)[a] = x[a] - y;
    x[a] = y;
    if (L.seam[a] == Seam::Twist && std::fmod(std::abs(turns), 2.0) == 1.0) flip = !flip;
  }
  if (flip)
    for (int a = 0; a < 3; ++a)
      if (L.seam[a] == Seam::Twist)
        for (int b = 0; b < 3; ++b)
          if (b != a) x[b] = L.box_min[b] + L.box_max[b] - x[b];
  if (mirrored) *mirrored = flip;
  return x;
}

/// Per point of X (#X x 3), the translation a Shift seam adds to its image
/// (wrap_point); an empty matrix when no point has one.
inline RowMatrixX3d seam_translations(const Lattice& L, const Eigen::Ref<const RowMatrixX3d>& X) {
  if (L.seam[0] != Seam::Shift && L.seam[1] != Seam::Shift && L.seam[2] != Seam::Shift) return {};
  RowMatrixX3d T = RowMatrixX3d::Zero(X.rows(), 3);
  bool any = false;
  for (Index r = 0; r < X.rows(); ++r) {
    Vector3d t;
    wrap_point(L, X.row(r).transpose(), nullptr, &t);
    T.row(r) = t.transpose();
    any |= !t.isZero(0.0);
  }
  if (!any) return {};
  return T;
}

/// The axis with a twist seam, or -1 (a lattice has at most one).
inline int twist_axis(const Lattice& L) {
  for (int a = 0; a < 3; ++a)
    if (L.seam[a] == Seam::Twist) return a;
  return -1;
}

/// The Jacobian j (9, row-major) of the FFD at point x's wrapped twin turned into
/// that of the map of x as given: a point mirrored by wrap_point has J * M with M
/// the mirror of the two axes other than `twist` (those columns negated).
/// @param twist  twist_axis(L); nothing to do when it is -1
inline void unmirror_jacobian(const Lattice& L, int twist, const Vector3d& x, double* j) {
  if (twist < 0) return;
  bool flip = false;
  wrap_point(L, x, &flip);
  if (!flip) return;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      if (c != twist) j[3 * r + c] = -j[3 * r + c];
}

}  // namespace vpffd
