#pragma once
/// @file rbf_map.h
/// The RBF space deformation as a deformer of a decomposition's base (paper 002,
/// Section 6): S' = r(S(t_i)), S'_u = J_r S_u, S'_v = J_r S_v.

#include "vpffd/multires/rbf.h"
#include "vpffd/multires/reconstruct.h"

namespace vpffd {

/// One frame of the fine mesh under the solved RBF map W.
inline MultiresFrame rbf_deform(const Multires& m, const RbfMap& rbf, const RbfWeights& W, int threads = 0) {
  return reconstruct(
      m,
      [&](Index, const Vector3d& s, const Vector3d& su, const Vector3d& sv, Vector3d& s1, Vector3d& su1,
          Vector3d& sv1) {
        Matrix3d J;
        rbf.eval(W, s, s1, J);
        su1 = J * su;
        sv1 = J * sv;
      },
      threads);
}

}  // namespace vpffd
