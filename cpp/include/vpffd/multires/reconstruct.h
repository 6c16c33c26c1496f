#pragma once
/// @file reconstruct.h
/// One frame of the multiresolution reconstruction (paper 002, eq. 1 and eqs. 6-7):
/// one independent pass per fine vertex, no neighbours.
///
///   N_S' = unit(S'_u x S'_v),  p' = S'(t_i) + d_i N_S',
///   N'   = unit((a_u S'_u + b_u S'_v + g_u N_S') x (a_v S'_u + b_v S'_v + g_v N_S')).
///
/// Any deformer of the base plugs in as a callable that maps the rest foot point
/// and tangents of vertex i to their images (an FFD: D(S), J_D S_u, J_D S_v; an RBF
/// map likewise). Each vertex writes only its own rows, so the result does not
/// depend on the thread count.

#include "vpffd/core/parallel.h"
#include "vpffd/multires/decomposition.h"

namespace vpffd {

/// Deformed fine vertices and normals, caller order.
struct MultiresFrame {
  RowMatrixX3d vertices;  ///< #V x 3
  RowMatrixX3d normals;   ///< #V x 3 unit (zero where the deformed tangents are parallel)
};

/// Reconstructs all vertices of m with `map(i, S, Su, Sv, S', Su', Sv')` (Vector3d
/// in, Vector3d& out). `map` is called concurrently for different i.
template <class Map>
MultiresFrame reconstruct(const Multires& m, Map&& map, int threads = 0) {
  MultiresFrame out;
  const Index n = m.n_vertices();
  out.vertices.resize(n, 3);
  out.normals.resize(n, 3);
  parallel_range(n, threads, [&](Index b, Index e) {
    for (Index i = b; i < e; ++i) {
      Vector3d s, su, sv;
      map(i, m.foot_point(i), m.tangent_u(i), m.tangent_v(i), s, su, sv);
      const Vector3d c = su.cross(sv);
      const double len = c.norm();
      const Vector3d ns = len > 0 ? Vector3d(c / len) : Vector3d::Zero();
      out.vertices.row(i) = (s + m.d[i] * ns).transpose();
      out.normals.row(i) = reconstruct_normal(m.coefficients(i), su, sv, ns).transpose();
    }
  });
  return out;
}

}  // namespace vpffd
