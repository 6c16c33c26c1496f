#pragma once
/// @file lattice.h
/// The structure of a trivariate B-spline lattice: degrees, knots and the world
/// box that is mapped affinely onto the parameter domain. Control points are kept
/// apart, as plain (nu*nv*nw) x 3 arrays, because they change every frame while
/// the structure does not.
///
/// Control point (i, j, k) is row (i * nv + j) * nw + k, which is the C-order
/// flattening of a numpy array of shape (nu, nv, nw, 3).

#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "vpffd/bspline/basis.h"
#include "vpffd/bspline/knots.h"
#include "vpffd/core/types.h"

namespace vpffd {

/// How a periodic axis ties its last `degree` control slices to its first ones
/// (lattice/periodic.h). None: the axis is not periodic.
enum class Seam : std::uint8_t {
  None,
  Shift,   ///< P_ext[n+m] = P[m] + extent * e_a: the rest lattice is the identity and tiles space
  Closed,  ///< P_ext[n+m] = P[m]: the control net closes on itself (a ring)
  Twist,   ///< P_ext[n+m, j, k] = P[m, nv-1-j, nw-1-k] (the other two axes mirrored): a Moebius band
};

struct Lattice {
  std::array<int, 3> degree{3, 3, 3};
  std::array<std::vector<double>, 3> knots;  ///< per axis, n_a + degree_a + 1 knots
  Vector3d box_min = Vector3d::Zero();       ///< world point mapped to (t_d, t_d, t_d)
  Vector3d box_max = Vector3d::Ones();       ///< world point mapped to (t_n, t_n, t_n)
  /// Per axis: Seam::None, or how a periodic axis closes. A periodic axis of n distinct
  /// control points is stored as an ordinary axis of n + degree points on uniform
  /// unclamped knots whose domain [t_d, t_{n+d}] spans the box (lattice/periodic.h).
  std::array<Seam, 3> seam{Seam::None, Seam::None, Seam::None};

  bool periodic(int a) const { return seam[a] != Seam::None; }
  bool any_periodic() const { return periodic(0) || periodic(1) || periodic(2); }
  /// Control points along axis a that the user sets: dim(a), less the tied slices.
  int distinct_dim(int a) const { return periodic(a) ? dim(a) - degree[a] : dim(a); }
  Index n_distinct_points() const { return Index(distinct_dim(0)) * distinct_dim(1) * distinct_dim(2); }

  int dim(int a) const { return static_cast<int>(knots[a].size()) - degree[a] - 1; }
  std::array<int, 3> dims() const { return {dim(0), dim(1), dim(2)}; }
  Index n_control_points() const { return Index(dim(0)) * dim(1) * dim(2); }
  /// Row of control point (i, j, k) in the control point array.
  Index index(int i, int j, int k) const { return (Index(i) * dim(1) + j) * dim(2) + k; }
  double domain_lo(int a) const { return knots[a][degree[a]]; }
  double domain_hi(int a) const { return knots[a][dim(a)]; }
};

/// Periodic axes: uniform knots, at least degree + 1 distinct control points, and a
/// twisted seam only with the two other axes open (the mirror of their indices
/// would otherwise not be a map of the lattice onto itself).
inline void validate_periodic(const Lattice& L) {
  static const char axes[3] = {'x', 'y', 'z'};
  for (int a = 0; a < 3; ++a) {
    if (!L.periodic(a)) continue;
    const int d = L.degree[a], n = L.distinct_dim(a);
    VPFFD_CHECK(n >= d + 1, "lattice: periodic axis ", axes[a], " has ", n, " distinct control points; degree ", d,
                " needs at least degree + 1 = ", d + 1, " (fewer would tie a control point to itself)");
    const std::vector<double>& t = L.knots[a];
    const double h = (t.back() - t.front()) / double(t.size() - 1);
    for (size_t i = 1; i < t.size(); ++i)
      VPFFD_CHECK(std::abs(t[i] - t[i - 1] - h) <= 1e-12 * std::abs(t.back() - t.front()), "lattice: periodic axis ",
                  axes[a], " needs uniform knots (knot ", i, " breaks the spacing)");
  }
  for (int a = 0; a < 3; ++a)
    if (L.seam[a] == Seam::Twist)
      for (int b = 0; b < 3; ++b)
        VPFFD_CHECK(b == a || !L.periodic(b), "lattice: the twisted (Moebius) seam along ", axes[a],
                    " mirrors the other two axes, so ", axes[b], " cannot be periodic too");
}

/// @throws InvalidInputError for a degree outside [1, 5], too few control points
/// for the degree, bad knots, or a box with a non-finite or non-positive extent.
inline void validate_lattice(const Lattice& L) {
  static const char axes[3] = {'x', 'y', 'z'};
  for (int a = 0; a < 3; ++a) {
    VPFFD_CHECK(L.degree[a] >= 1 && L.degree[a] <= kMaxDegree, "lattice: degree ", L.degree[a], " along ", axes[a],
                " not in [1, ", kMaxDegree, "]");
    validate_knots(L.knots[a], L.dim(a), L.degree[a], axes[a]);
    VPFFD_CHECK(std::isfinite(L.box_min[a]) && std::isfinite(L.box_max[a]), "lattice: box along ", axes[a],
                " is not finite");
    VPFFD_CHECK(L.box_max[a] > L.box_min[a], "lattice: zero or negative extent along ", axes[a], " (",
                L.box_min[a], " .. ", L.box_max[a], ")");
    // The parameter map divides by the extent: both it and its inverse must be finite.
    const double ext = L.box_max[a] - L.box_min[a];
    const double scale = (L.domain_hi(a) - L.domain_lo(a)) / ext;
    VPFFD_CHECK(std::isfinite(ext) && std::isfinite(scale) && scale > 0 && std::isnormal(ext), "lattice: extent ",
                ext, " along ", axes[a], " is out of the range double precision can map");
  }
  validate_periodic(L);
  VPFFD_CHECK(L.n_control_points() < (Index(1) << 31), "lattice: too many control points (",
              L.n_control_points(), ")");
}

/// A lattice over the box [box_min, box_max] with `dims` control points per axis,
/// the given degrees and uniform knots on [0, 1]: open-uniform (clamped) along an
/// axis whose `seam` is None, periodic (periodic.h) along the others, where `dims`
/// counts the distinct control points (as Python's Lattice(shape=..., periodic=...)).
inline Lattice make_lattice(const Vector3d& box_min, const Vector3d& box_max, std::array<int, 3> dims,
                            std::array<int, 3> degree, std::array<Seam, 3> seam = {Seam::None, Seam::None, Seam::None}) {
  Lattice L;
  L.degree = degree;
  L.box_min = box_min;
  L.box_max = box_max;
  L.seam = seam;
  for (int a = 0; a < 3; ++a) {
    VPFFD_CHECK(degree[a] >= 1 && degree[a] <= kMaxDegree, "lattice: degree ", degree[a], " not in [1, ",
                kMaxDegree, "]");
    VPFFD_CHECK(dims[a] >= degree[a] + 1, "lattice: shape ", dims[a], " along axis ", a,
                " is too small for degree ", degree[a], " (need at least ", degree[a] + 1, ")");
    L.knots[a] = seam[a] == Seam::None ? clamped_uniform_knots(dims[a], degree[a])
                                       : periodic_uniform_knots(dims[a], degree[a]);
  }
  validate_lattice(L);
  return L;
}

/// The affine map of the box onto the parameter domain, u = lo + (x - box_min) k per
/// axis with k = (domain length) / (box extent): built once for a loop over many
/// points (a multiply where a division per coordinate would bound the loop).
struct ParameterMap {
  Vector3d lo, box_min, k;
  explicit ParameterMap(const Lattice& L) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = L.domain_lo(a);
      box_min[a] = L.box_min[a];
      k[a] = (L.domain_hi(a) - L.domain_lo(a)) / (L.box_max[a] - L.box_min[a]);
    }
  }
  Vector3d operator()(const Vector3d& x) const { return lo + ((x - box_min).array() * k.array()).matrix(); }
};

/// Parameter (u, v, w) of a world point (ParameterMap, for one point).
inline Vector3d parameter_of(const Lattice& L, const Vector3d& x) { return ParameterMap(L)(x); }

/// The rest (identity) control points: each at the world image of its Greville
/// abscissae, so that the undeformed FFD maps every point exactly onto itself
/// (B-splines reproduce linear functions). Returns (nu*nv*nw) x 3.
inline RowMatrixX3d rest_control_points(const Lattice& L) {
  std::array<std::vector<double>, 3> g;
  for (int a = 0; a < 3; ++a) {
    g[a] = greville(L.knots[a], L.dim(a), L.degree[a]);
    const double lo = L.domain_lo(a), hi = L.domain_hi(a);
    for (double& x : g[a]) x = L.box_min[a] + (x - lo) / (hi - lo) * (L.box_max[a] - L.box_min[a]);
  }
  RowMatrixX3d P(L.n_control_points(), 3);
  for (int i = 0; i < L.dim(0); ++i)
    for (int j = 0; j < L.dim(1); ++j)
      for (int k = 0; k < L.dim(2); ++k) P.row(L.index(i, j, k)) << g[0][i], g[1][j], g[2][k];
  return P;
}

/// Jacobian of the parameter map: du_a/dx_a (the map is axis-aligned).
inline Vector3d parameter_scale(const Lattice& L) {
  Vector3d s;
  for (int a = 0; a < 3; ++a) s[a] = (L.domain_hi(a) - L.domain_lo(a)) / (L.box_max[a] - L.box_min[a]);
  return s;
}

}  // namespace vpffd
