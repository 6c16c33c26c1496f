#pragma once
/// @file normal_coefficients.h
/// The six coefficients of the approximate normal reconstruction (paper 002,
/// Section 4.1, eqs. 6-7).
///
/// F_u = a_u S_u + b_u S_v + g_u N_S and F_v = a_v S_u + b_v S_v + g_v N_S, where
/// (F_u, F_v) = (T0, T1) are two orthonormal tangents of the rest normal N_F with
/// T0 x T1 = N_F. Solving the two 3x3 systems [S_u S_v N_S] (a, b, g) = T at rest
/// and replaying the combinations on the deformed S'_u, S'_v, N_S' gives the
/// deformed normal with no neighbours: at rest exactly N_F, and R N_F under a
/// rotation R (a rotation maps S_u, S_v, N_S and hence T0, T1 and their cross product).

#include <Eigen/LU>

#include "vpffd/core/types.h"

namespace vpffd {

/// (a_u, b_u, g_u, a_v, b_v, g_v).
using NormalCoefficients = Eigen::Matrix<double, 6, 1>;

/// Coefficients for base tangents (su, sv) and rest unit normal nf.
/// Requires su x sv != 0 and nf unit.
inline NormalCoefficients normal_coefficients(const Vector3d& su, const Vector3d& sv, const Vector3d& nf) {
  const Vector3d ns = su.cross(sv).normalized();
  // T0, T1: T0 from the axis least aligned with nf (well conditioned), T1 = nf x T0.
  Eigen::Index k;
  nf.cwiseAbs().minCoeff(&k);
  const Vector3d t0 = nf.cross(Vector3d::Unit(k)).normalized();
  const Vector3d t1 = nf.cross(t0);
  Matrix3d A;
  A.col(0) = su;
  A.col(1) = sv;
  A.col(2) = ns;
  // A is non-singular (su, sv independent, ns orthogonal to both); partial pivoting suffices.
  const Eigen::PartialPivLU<Matrix3d> lu(A);
  NormalCoefficients c;
  c.head<3>() = lu.solve(t0);
  c.tail<3>() = lu.solve(t1);
  return c;
}

/// The deformed unit normal from deformed tangents su', sv' and N_S' = unit(su' x sv').
VPFFD_ALWAYS_INLINE Vector3d reconstruct_normal(const NormalCoefficients& c, const Vector3d& su, const Vector3d& sv,
                                                const Vector3d& ns) {
  const Vector3d fu = c[0] * su + c[1] * sv + c[2] * ns;
  const Vector3d fv = c[3] * su + c[4] * sv + c[5] * ns;
  const Vector3d n = fu.cross(fv);
  const double len = n.norm();
  return len > 0 ? Vector3d(n / len) : Vector3d::Zero();
}

}  // namespace vpffd
