#pragma once
/// @file lattice_edits.h
/// Ready-made edits of control points: twist, bend, taper and scale about an
/// axis. Each takes N x 3 points and returns new ones; angles in radians.
///
/// The extent [lo, hi] along the axis over which an edit ramps from none to
/// full defaults to the points' own extent (pass lo >= hi for that).

#include <algorithm>
#include <cmath>

#include "vpffd/core/check.h"
#include "vpffd/core/types.h"

namespace vpffd {

namespace detail {
inline void edit_range(const Eigen::Ref<const RowMatrixX3d>& P, int axis, double& lo, double& hi, const char* what) {
  VPFFD_CHECK(axis >= 0 && axis < 3, what, ": axis ", axis, " not in 0..2");
  VPFFD_CHECK(P.rows() > 0 && P.allFinite(), what, ": control points are empty or not finite");
  if (!(lo < hi)) {
    lo = P.col(axis).minCoeff();
    hi = P.col(axis).maxCoeff();
  }
  VPFFD_CHECK(hi > lo, what, ": the control points have no extent along axis ", axis);
}
}  // namespace detail

/// Rotation about the line through `center` along `axis`, by angle * (h - lo) / (hi - lo)
/// at height h: the bottom stays, the top turns by `angle`.
inline RowMatrixX3d twist(const Eigen::Ref<const RowMatrixX3d>& P, double angle, int axis, const Vector3d& center,
                          double lo = 0, double hi = 0) {
  detail::edit_range(P, axis, lo, hi, "twist");
  VPFFD_CHECK(std::isfinite(angle), "twist: angle is not finite");
  const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
  RowMatrixX3d Q = P;
  for (Index r = 0; r < P.rows(); ++r) {
    const double t = std::clamp((P(r, axis) - lo) / (hi - lo), 0.0, 1.0) * angle;
    const double c = std::cos(t), s = std::sin(t);
    const double x = P(r, a1) - center[a1], y = P(r, a2) - center[a2];
    Q(r, a1) = center[a1] + c * x - s * y;
    Q(r, a2) = center[a2] + s * x + c * y;
  }
  return Q;
}

/// Bends the points' extent along `axis` into a circular arc of total `angle`,
/// curving towards +`toward` (another axis). Lengths along the axis (at the
/// centre line through `center`) are kept; angle 0 is the identity.
inline RowMatrixX3d bend(const Eigen::Ref<const RowMatrixX3d>& P, double angle, int axis, int toward,
                         const Vector3d& center, double lo = 0, double hi = 0) {
  detail::edit_range(P, axis, lo, hi, "bend");
  VPFFD_CHECK(toward >= 0 && toward < 3 && toward != axis, "bend: toward axis ", toward,
              " must differ from the bend axis ", axis);
  VPFFD_CHECK(std::isfinite(angle), "bend: angle is not finite");
  RowMatrixX3d Q = P;
  if (angle == 0.0) return Q;
  const double R = (hi - lo) / angle;  // radius of the centre line
  for (Index r = 0; r < P.rows(); ++r) {
    const double s = P(r, axis) - lo;  // arc length along the centre line
    const double d = P(r, toward) - center[toward];
    const double th = s / R;
    Q(r, axis) = lo + (R - d) * std::sin(th);
    Q(r, toward) = center[toward] + R - (R - d) * std::cos(th);
  }
  return Q;
}

/// Scales the coordinates across `axis` about the line through `center` by a
/// factor going linearly from 1 at lo to `factor` at hi.
inline RowMatrixX3d taper(const Eigen::Ref<const RowMatrixX3d>& P, double factor, int axis, const Vector3d& center,
                          double lo = 0, double hi = 0) {
  detail::edit_range(P, axis, lo, hi, "taper");
  VPFFD_CHECK(std::isfinite(factor), "taper: factor is not finite");
  RowMatrixX3d Q = P;
  for (Index r = 0; r < P.rows(); ++r) {
    const double f = 1.0 + (factor - 1.0) * std::clamp((P(r, axis) - lo) / (hi - lo), 0.0, 1.0);
    for (int a = 0; a < 3; ++a)
      if (a != axis) Q(r, a) = center[a] + f * (P(r, a) - center[a]);
  }
  return Q;
}

/// Scales about `center` by `factors` per axis.
inline RowMatrixX3d scale(const Eigen::Ref<const RowMatrixX3d>& P, const Vector3d& factors, const Vector3d& center) {
  VPFFD_CHECK(factors.allFinite() && center.allFinite(), "scale: factors and center must be finite");
  VPFFD_CHECK(P.allFinite(), "scale: control points are not finite");
  RowMatrixX3d Q = P;
  for (Index r = 0; r < P.rows(); ++r)
    for (int a = 0; a < 3; ++a) Q(r, a) = center[a] + factors[a] * (P(r, a) - center[a]);
  return Q;
}

}  // namespace vpffd
