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

/// One vertex from the deformed foot point s1 and tangents su1, sv1: p' (eq. 1) and
/// the approximate normal n' (eqs. 6-7; zero where su1 and sv1 are parallel).
VPFFD_ALWAYS_INLINE void reconstruct_vertex(const Vector3d& s1, const Vector3d& su1, const Vector3d& sv1, double d,
                                            const NormalCoefficients& c, Vector3d& p, Vector3d& n) {
  const Vector3d cr = su1.cross(sv1);
  const double len = cr.norm();
  const Vector3d ns = len > 0 ? Vector3d(cr / len) : Vector3d::Zero();
  p = s1 + d * ns;
  n = reconstruct_normal(c, su1, sv1, ns);
}

/// Reconstructs all vertices of m with `map(i, S, Su, Sv, S', Su', Sv')` (Vector3d
/// in, Vector3d& out). `map` is called concurrently for different i.
template <class Map>
MultiresFrame reconstruct(const Multires& m, Map&& map, int threads = 0) {
  MultiresFrame out;
  out.vertices.resize(m.n_vertices(), 3);
  out.normals.resize(m.n_vertices(), 3);
  reconstruct(m, map, out.vertices.data(), out.normals.data(), threads);
  return out;
}
/// The same into the caller's #V x 3 row-major arrays X (vertices) and N (normals).
template <class Map>
void reconstruct(const Multires& m, Map&& map, double* X, double* N, int threads = 0) {
  parallel_range(m.n_vertices(), threads, [&](Index b, Index e) {
    for (Index i = b; i < e; ++i) {
      Vector3d s, su, sv, p, n;
      map(i, m.foot_point(i), m.tangent_u(i), m.tangent_v(i), s, su, sv);
      reconstruct_vertex(s, su, sv, m.d[i], m.coefficients(i), p, n);
      for (int a = 0; a < 3; ++a) {
        X[3 * i + a] = p[a];
        N[3 * i + a] = n[a];
      }
    }
  });
}

}  // namespace vpffd
