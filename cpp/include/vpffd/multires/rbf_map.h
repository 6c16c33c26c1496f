#pragma once
/// @file rbf_map.h
/// The RBF space deformation as a deformer of a decomposition's base (paper 002,
/// Section 6): S' = r(S(t_i)), S'_u = J_r S_u, S'_v = J_r S_v.
///
/// One frame is the back-substitution (RbfMap::solve) and one pass of the blocked
/// kernel (rbf_kernel.h) over the foot points, kRbfLanes at a time, each lane group
/// rebuilt as soon as its r and J_r are known (reconstruct_vertex).

#include "vpffd/multires/rbf.h"
#include "vpffd/multires/reconstruct.h"

namespace vpffd {

/// One frame of the fine mesh under the solved RBF map W, into the caller's #V x 3
/// row-major arrays X (vertices) and N (unit normals).
inline void rbf_deform(const Multires& m, const RbfMap& rbf, const RbfWeights& W, double* X, double* N,
                       int threads = 0) {
  VPFFD_CHECK(W.w.rows() == rbf.n_handles(), "RBF: weights for ", W.w.rows(), " handles, the map has ",
              rbf.n_handles());
  const RbfTerms t = rbf.terms(W);
  const Index n = m.n_vertices();
  const Index chunks = (n + kRbfChunk - 1) / kRbfChunk;
  parallel_items(chunks, n * t.size(), threads, [&](Index c) {
    const Index b = c * kRbfChunk, e = std::min(n, b + kRbfChunk);
    const double inv = 1.0 / t.scale;
    RbfLane xn[3], s[3], g[9];
    for (Index i = b; i < e; i += kRbfLanes) {
      for (int l = 0; l < kRbfLanes; ++l) {
        const Index k = std::min(i + l, e - 1);
        for (int a = 0; a < 3; ++a) xn[a][l] = (m.foot[a][k] - t.centre[a]) * inv;
      }
      rbf_lanes<true>(t, xn, s, g);
      for (int l = 0; l < kRbfLanes && i + l < e; ++l) {
        const Index v = i + l;
        Matrix3d J;
        for (int k = 0; k < 9; ++k) J(k / 3, k % 3) = g[k][l];
        const Vector3d s1(s[0][l], s[1][l], s[2][l]);
        Vector3d p, nrm;
        reconstruct_vertex(s1, J * m.tangent_u(v), J * m.tangent_v(v), m.d[v], m.coefficients(v), p, nrm);
        for (int a = 0; a < 3; ++a) {
          X[3 * v + a] = p[a];
          N[3 * v + a] = nrm[a];
        }
      }
    }
  });
}

/// The same as a new MultiresFrame.
inline MultiresFrame rbf_deform(const Multires& m, const RbfMap& rbf, const RbfWeights& W, int threads = 0) {
  MultiresFrame out;
  out.vertices.resize(m.n_vertices(), 3);
  out.normals.resize(m.n_vertices(), 3);
  rbf_deform(m, rbf, W, out.vertices.data(), out.normals.data(), threads);
  return out;
}

}  // namespace vpffd
