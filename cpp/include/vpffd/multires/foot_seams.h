#pragma once
/// @file foot_seams.h
/// What a periodic lattice's seams add to the FFD at the foot points (the
/// multiresolution map's counterpart of the Deformer's seam handling).
///
/// The embedding wraps a foot point into the box along periodic axes (embed.h), so
/// the spline is evaluated at its wrapped twin. The map of the point as given then
/// differs by the seam (lattice/periodic.h wrap_point):
///  * Shift: D(x) = D(wrapped) + k L e_a: the value gains the translation, the
///    Jacobian is unchanged;
///  * Closed: D(x) = D(wrapped): nothing to add;
///  * Twist (an odd number of turns): D(x) = D(mirror(x)), so J_D(x) = J M with M the
///    mirror of the two axes other than the twist axis (those columns negated).
/// Base points lie in or near the box, so few foot points need either; both are
/// kept sparse in the caller's vertex order.

#include <cstdint>
#include <vector>

#include "vpffd/lattice/periodic.h"

namespace vpffd {

/// Per foot point, the seam translation and whether it was mirrored.
class FootSeams {
 public:
  FootSeams() = default;
  /// @param[in] L  the lattice
  /// @param[in] X  foot points (#V x 3), caller order
  FootSeams(const Lattice& L, const Eigen::Ref<const RowMatrixX3d>& X) {
    if (!L.any_periodic()) return;
    shift_ = seam_translations(L, X);  // empty unless some point has one
    twist_ = twist_axis(L);
    if (twist_ >= 0) {
      mirrored_.assign(static_cast<size_t>(X.rows()), 0);
      bool any = false;
      for (Index i = 0; i < X.rows(); ++i) {
        bool flip = false;
        wrap_point(L, X.row(i).transpose(), &flip);
        mirrored_[static_cast<size_t>(i)] = flip ? 1 : 0;
        any |= flip;
      }
      if (!any) mirrored_.clear();
    }
  }

  /// Whether any foot point needs a change (false for a lattice without periodic axes).
  bool any() const { return shift_.rows() > 0 || !mirrored_.empty(); }

  /// Whether some foot point gains a translation (then shift() has #V rows).
  bool any_shift() const { return shift_.rows() > 0; }
  /// The translation a shift seam adds to the value at foot point i (world units).
  Vector3d shift(Index i) const { return shift_.rows() > 0 ? Vector3d(shift_.row(i).transpose()) : Vector3d::Zero(); }
  /// Whether a twist seam mirrored foot point i (then the columns of J other than
  /// twisted_axis() change sign; a device folds that into S_u and S_v: J M t = J (M t)).
  bool mirrored(Index i) const { return !mirrored_.empty() && mirrored_[static_cast<size_t>(i)]; }
  /// The twist axis, or -1 without a twist seam.
  int twisted_axis() const { return twist_; }

  /// The map at foot point i from the spline's value s and Jacobian J at its wrapped twin.
  VPFFD_ALWAYS_INLINE void apply(Index i, Vector3d& s, Matrix3d& J) const {
    if (shift_.rows() > 0) s += shift_.row(i).transpose();
    if (!mirrored_.empty() && mirrored_[static_cast<size_t>(i)])
      for (int c = 0; c < 3; ++c)
        if (c != twist_) J.col(c) = -J.col(c);
  }

 private:
  RowMatrixX3d shift_;              ///< #V x 3 or empty
  std::vector<std::uint8_t> mirrored_;  ///< #V or empty
  int twist_ = -1;
};

}  // namespace vpffd
