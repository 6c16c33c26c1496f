#pragma once
/// @file kernels.h
/// The per-point loops of a frame: FFD evaluation (gather of 3 coordinates), the
/// coefficient scatter (alpha = B^T w), the single-coordinate gather of an offset
/// field, and the Jacobian. Control points are passed as separate x, y, z arrays
/// (structure of arrays), so the innermost loop over k reads contiguous memory.

#include "vpffd/ffd/vertex_basis.h"

namespace vpffd::detail {

/// out[v] = sum_ijk B_ijk(u_v) P_ijk for v in [b, e); out is #points x 3 row-major.
template <int K>
void ffd_kernel(const BasisTables& T, const Embedding& E, const double* Px, const double* Py, const double* Pz,
                double* out, Index b, Index e) {
  const Orders<K> o(T);
  const Index sj = T.dims[2], si = Index(T.dims[1]) * T.dims[2];
  double bu[kMaxOrder], bv[kMaxOrder], bw[kMaxOrder];
  for (Index v = b; v < e; ++v) {
    const Index base = point_basis<K>(T, E, v, bu, bv, bw);
    double x = 0, y = 0, z = 0;
    for (int i = 0; i < o.u; ++i) {
      double xi = 0, yi = 0, zi = 0;
      for (int j = 0; j < o.v; ++j) {
        const Index row = base + i * si + j * sj;
        double xj = 0, yj = 0, zj = 0;
        for (int k = 0; k < o.w; ++k) {
          xj += bw[k] * Px[row + k];
          yj += bw[k] * Py[row + k];
          zj += bw[k] * Pz[row + k];
        }
        xi += bv[j] * xj;
        yi += bv[j] * yj;
        zi += bv[j] * zj;
      }
      x += bu[i] * xi;
      y += bu[i] * yi;
      z += bu[i] * zi;
    }
    out[3 * v] = x;
    out[3 * v + 1] = y;
    out[3 * v + 2] = z;
  }
}

/// acc[c] += weight(v) * B_c(u_v) for v in [b, e): the transpose product B^T w.
template <int K, class Weight>
void scatter_kernel(const BasisTables& T, const Embedding& E, Weight&& weight, double* acc, Index b, Index e) {
  const Orders<K> o(T);
  const Index sj = T.dims[2], si = Index(T.dims[1]) * T.dims[2];
  double bu[kMaxOrder], bv[kMaxOrder], bw[kMaxOrder];
  for (Index v = b; v < e; ++v) {
    const double wv = weight(v);
    if (wv == 0.0) continue;
    const Index base = point_basis<K>(T, E, v, bu, bv, bw);
    for (int i = 0; i < o.u; ++i) {
      const double wi = wv * bu[i];
      for (int j = 0; j < o.v; ++j) {
        const double wij = wi * bv[j];
        double* a = acc + base + i * si + j * sj;
        for (int k = 0; k < o.w; ++k) a[k] += wij * bw[k];
      }
    }
  }
}

/// out[3 v + axis] += sum_c B_c(u_v) D[c] for v in [b, e): one coordinate of an
/// offset field. After a correction along one axis only that coordinate moves,
/// so the corrected mesh is the plain FFD plus one such gather per axis.
template <int K>
void gather_kernel(const BasisTables& T, const Embedding& E, const double* D, double* out, int axis, Index b,
                   Index e) {
  const Orders<K> o(T);
  const Index sj = T.dims[2], si = Index(T.dims[1]) * T.dims[2];
  double bu[kMaxOrder], bv[kMaxOrder], bw[kMaxOrder];
  for (Index v = b; v < e; ++v) {
    const Index base = point_basis<K>(T, E, v, bu, bv, bw);
    double s = 0;
    for (int i = 0; i < o.u; ++i) {
      double si_ = 0;
      for (int j = 0; j < o.v; ++j) {
        const double* d = D + base + i * si + j * sj;
        double sk = 0;
        for (int k = 0; k < o.w; ++k) sk += bw[k] * d[k];
        si_ += bv[j] * sk;
      }
      s += bu[i] * si_;
    }
    out[3 * v + axis] += s;
  }
}

/// J[v] = dD/dx at point v as a row-major 3x3 (J[r][c] = d D_r / d x_c), x the
/// world coordinates of the rest point: derivatives in the parameter times the
/// parameter map's scale `du_dx`.
inline void jacobian_kernel(const BasisTables& T, const Embedding& E, const double* Px, const double* Py,
                            const double* Pz, const Vector3d& du_dx, double* J, Index b, Index e) {
  const Index sj = T.dims[2], si = Index(T.dims[1]) * T.dims[2];
  double N[3][kMaxOrder], dN[3][kMaxOrder];
  const double* P[3] = {Px, Py, Pz};
  for (Index v = b; v < e; ++v) {
    Index first[3];
    for (int a = 0; a < 3; ++a) {
      const int s = E.span[a][v];
      eval_span_derivs(T.poly[a].span_coef(s), T.order[a], E.tau[a][v], N[a], dN[a]);
      const double scale = T.poly[a].inv_width[s - T.poly[a].first_span] * du_dx[a];
      for (int r = 0; r < T.order[a]; ++r) dN[a][r] *= scale;
      first[a] = s - T.poly[a].degree;
    }
    const Index base = (first[0] * T.dims[1] + first[1]) * T.dims[2] + first[2];
    double acc[3][3] = {};
    for (int i = 0; i < T.order[0]; ++i)
      for (int j = 0; j < T.order[1]; ++j)
        for (int k = 0; k < T.order[2]; ++k) {
          const Index c = base + i * si + j * sj + k;
          const double g[3] = {dN[0][i] * N[1][j] * N[2][k], N[0][i] * dN[1][j] * N[2][k],
                               N[0][i] * N[1][j] * dN[2][k]};
          for (int r = 0; r < 3; ++r)
            for (int q = 0; q < 3; ++q) acc[r][q] += P[r][c] * g[q];
        }
    for (int r = 0; r < 3; ++r)
      for (int q = 0; q < 3; ++q) J[9 * v + 3 * r + q] = acc[r][q];
  }
}

}  // namespace vpffd::detail
