#pragma once
/// @file kernels.h
/// The per-point loops of a frame: FFD evaluation (gather of 3 coordinates), the
/// coefficient scatter (alpha = B^T w), the single-coordinate gather of an offset
/// field, and the Jacobian. Control points are passed as separate x, y, z arrays
/// (structure of arrays), so the innermost loop over k reads contiguous memory.

#include "vpffd/ffd/vertex_basis.h"

namespace vpffd {

/// Control points (N x 3) as the kernels take them: three coordinate arrays
/// (structure of arrays), a copy.
struct PointColumns {
  explicit PointColumns(const Eigen::Ref<const RowMatrixX3d>& P) : x(P.col(0)), y(P.col(1)), z(P.col(2)) {
    c[0] = x.data();
    c[1] = y.data();
    c[2] = z.data();
  }
  PointColumns(const PointColumns&) = delete;  // c points into this object's arrays
  PointColumns& operator=(const PointColumns&) = delete;
  Eigen::VectorXd x, y, z;
  const double* c[3];  ///< x, y, z data
};

}  // namespace vpffd

namespace vpffd::detail {

// Loop structure shared by the kernels: for each (i, j) the K_w control points
// along k are contiguous, so the kernels accumulate K-wide vectors over all
// (i, j) rows and reduce against the k basis once per point. With a
// compile-time K the vectors are Eigen fixed-size arrays, which Eigen maps to
// SIMD packets explicitly (GCC does not vectorise this loop nest on its own);
// K = 0 (mixed degrees) takes the plain scalar loops.

template <int K>
using KVec = Eigen::Array<double, K, 1>;

template <int K>
inline Eigen::Map<const KVec<K>> kload(const double* p) {
  return Eigen::Map<const KVec<K>>(p);
}

/// out[v] = sum_ijk B_ijk(u_v) P_ijk for v in [b, e); out is #points x 3 row-major.
/// @param rows  if not null, point v goes to row rows[v] of out instead (the
///              caller's vertex order, written without a reordering pass)
/// @param skip  0-2: that coordinate is written as 0 instead (a volume-preserving
///              frame sets it in its first axis step, frame/deformer.h); -1: none
template <int K>
void ffd_kernel(const BasisTables& T, const Embedding& E, const double* Px, const double* Py, const double* Pz,
                double* out, Index b, Index e, const std::int32_t* rows = nullptr, int skip = -1) {
  const Index sj = T.dims[2], si = Index(T.dims[1]) * T.dims[2];
  alignas(32) double bu[kMaxOrder], bv[kMaxOrder], bw[kMaxOrder];
  for (Index v = b; v < e; ++v) {
    const Index base = point_basis<K>(T, E, v, bu, bv, bw);
    double x = 0, y = 0, z = 0;
    if constexpr (K > 0) {
      KVec<K> ax = KVec<K>::Zero(), ay = KVec<K>::Zero(), az = KVec<K>::Zero();
      for (int i = 0; i < K; ++i)
        for (int j = 0; j < K; ++j) {
          const double c = bu[i] * bv[j];
          const Index row = base + i * si + j * sj;
          ax += c * kload<K>(Px + row);
          ay += c * kload<K>(Py + row);
          az += c * kload<K>(Pz + row);
        }
      const KVec<K> w = kload<K>(bw);
      x = (w * ax).sum();
      y = (w * ay).sum();
      z = (w * az).sum();
    } else {
      for (int i = 0; i < T.order[0]; ++i)
        for (int j = 0; j < T.order[1]; ++j) {
          const double c = bu[i] * bv[j];
          const Index row = base + i * si + j * sj;
          for (int k = 0; k < T.order[2]; ++k) {
            x += c * bw[k] * Px[row + k];
            y += c * bw[k] * Py[row + k];
            z += c * bw[k] * Pz[row + k];
          }
        }
    }
    double* o = out + 3 * (rows ? Index(rows[v]) : v);
    o[0] = skip == 0 ? 0.0 : x;
    o[1] = skip == 1 ? 0.0 : y;
    o[2] = skip == 2 ? 0.0 : z;
  }
}

/// One point's share of a scatter, w B_ijk, added into a cell's block (K^2 K-vectors,
/// block[i K + j] along k). Factored as bu_i (bv_j w bw): K products, then K^2
/// multiply-adds.
template <int K>
VPFFD_ALWAYS_INLINE void scatter_point(double wv, const double* bu, const double* bv, const double* bw,
                                       KVec<K>* block) {
  const KVec<K> wk = wv * kload<K>(bw);
  KVec<K> t[K];
  for (int j = 0; j < K; ++j) t[j] = bv[j] * wk;
  for (int i = 0; i < K; ++i)
    for (int j = 0; j < K; ++j) block[i * K + j] += bu[i] * t[j];
}

/// A cell's block added to the control values from its first one, `at`.
template <int K>
VPFFD_ALWAYS_INLINE void add_block(const KVec<K>* block, double* at, Index si, Index sj) {
  for (int i = 0; i < K; ++i)
    for (int j = 0; j < K; ++j) {
      Eigen::Map<KVec<K>> a(at + i * si + j * sj);
      a += block[i * K + j];
    }
}

/// acc[c] += weight(v) * B_c(u_v) for v in [b, e): the transpose product B^T w.
template <int K, class Weight>
void scatter_kernel(const BasisTables& T, const Embedding& E, Weight&& weight, double* acc, Index b, Index e) {
  const Index sj = T.dims[2], si = Index(T.dims[1]) * T.dims[2];
  alignas(32) double bu[kMaxOrder], bv[kMaxOrder], bw[kMaxOrder];
  constexpr int KB = K > 0 ? K * K : 1;
  constexpr int KW = K > 0 ? K : 1;
  KVec<KW> block[KB];
  for (auto& x : block) x.setZero();
  Index block_base = -1;
  auto flush = [&] {
    if constexpr (K > 0) {
      if (block_base < 0) return;
      add_block<K>(block, acc + block_base, si, sj);
      for (auto& x : block) x.setZero();
    }
  };
  for (Index v = b; v < e; ++v) {
    const double wv = weight(v);
    if (wv == 0.0) continue;
    const Index base = point_basis<K>(T, E, v, bu, bv, bw);
    if constexpr (K > 0) {
      // Consecutive points of one cell (vertex_order.h) add into a local block;
      // it goes to memory when the cell changes.
      if (base != block_base) {
        flush();
        block_base = base;
      }
      scatter_point<K>(wv, bu, bv, bw, block);
    } else {
      for (int i = 0; i < T.order[0]; ++i)
        for (int j = 0; j < T.order[1]; ++j) {
          const double c = wv * bu[i] * bv[j];
          double* a = acc + base + i * si + j * sj;
          for (int k = 0; k < T.order[2]; ++k) a[k] += c * bw[k];
        }
    }
  }
  flush();
}

/// sum_c B_c D[c] from one point's basis values (bu, bv, bw) and first control point.
template <int K>
VPFFD_ALWAYS_INLINE double basis_dot(const BasisTables& T, const double* D, Index base, const double* bu,
                                     const double* bv, const double* bw, Index si, Index sj) {
  double s = 0;
  if constexpr (K > 0) {
    // Factored as sum_i bu_i (sum_j bv_j D_ij.): K^2 + K multiply-adds, no products bu_i bv_j.
    KVec<K> a = KVec<K>::Zero();
    for (int i = 0; i < K; ++i) {
      KVec<K> ai = bv[0] * kload<K>(D + base + i * si);
      for (int j = 1; j < K; ++j) ai += bv[j] * kload<K>(D + base + i * si + j * sj);
      a += bu[i] * ai;
    }
    s = (kload<K>(bw) * a).sum();
  } else {
    for (int i = 0; i < T.order[0]; ++i)
      for (int j = 0; j < T.order[1]; ++j) {
        const double c = bu[i] * bv[j];
        const double* d = D + base + i * si + j * sj;
        for (int k = 0; k < T.order[2]; ++k) s += c * bw[k] * d[k];
      }
  }
  return s;
}

/// sum_c B_c(u_v) D[c]: an offset field's value at point v.
template <int K>
VPFFD_ALWAYS_INLINE double gather_value(const BasisTables& T, const Embedding& E, const double* D, Index v, Index si,
                                        Index sj) {
  alignas(32) double bu[kMaxOrder], bv[kMaxOrder], bw[kMaxOrder];
  const Index base = point_basis<K>(T, E, v, bu, bv, bw);
  return basis_dot<K>(T, D, base, bu, bv, bw, si, sj);
}

/// out[3 v + axis] += sum_c B_c(u_v) D[c] for v in [b, e): one coordinate of an
/// offset field. After a correction along one axis only that coordinate moves,
/// so the corrected mesh is the plain FFD plus one such gather per axis.
template <int K>
void gather_kernel(const BasisTables& T, const Embedding& E, const double* D, double* out, int axis, Index b,
                   Index e) {
  const Index sj = T.dims[2], si = Index(T.dims[1]) * T.dims[2];
  for (Index v = b; v < e; ++v) out[3 * v + axis] += gather_value<K>(T, E, D, v, si, sj);
}

/// One point of the last gather: x_v moved by g along `axis`, in place; returns its
/// volume term w[v] (x_v[axis] - o).
VPFFD_ALWAYS_INLINE double move_final(double* X, Index v, int axis, double g, const double* w, double o) {
  double& x = X[3 * v + axis];
  x += g;
  return w[v] * (x - o);
}

/// The last gather of a frame, fused with the volume: point v moves by the offset
/// field D along `axis`, and the return value is sum_v w[v] (x_v[axis] - o) over
/// [b, e). With w the weights of this axis (coefficients_rings), which do not
/// depend on the `axis` coordinates, that sum is the corrected mesh's volume.
template <int K>
double gather_final_kernel(const BasisTables& T, const Embedding& E, const double* D, double* X, int axis,
                           const double* w, double o, Index b, Index e) {
  const Index sj = T.dims[2], si = Index(T.dims[1]) * T.dims[2];
  double vsum = 0;
  for (Index v = b; v < e; ++v) vsum += move_final(X, v, axis, gather_value<K>(T, E, D, v, si, sj), w, o);
  return vsum;
}

/// J[v] = dD/dx at point v as a row-major 3x3 (J[r][c] = d D_r / d x_c), x the
/// world coordinates of the rest point, for v in [b, e): derivatives in the
/// parameter times the parameter map's scale `du_dx`. K > 0: the uniform order,
/// K = 0: any orders (the plain triple loop, also the reference for tests).
template <int K>
void jacobian_points(const BasisTables& T, const Embedding& E, const double* Px, const double* Py, const double* Pz,
                     const Vector3d& du_dx, double* J, Index b, Index e, Index j_first = 0) {
  const Index sj = T.dims[2], si = Index(T.dims[1]) * T.dims[2];
  alignas(32) double N[3][kMaxOrder], dN[3][kMaxOrder];
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
    double* out = J + 9 * (v - j_first);  // J holds points j_first, j_first + 1, ...
    if constexpr (K > 0) {
      // Factored like the FFD kernels: per row i the K-vectors along k are
      // reduced over j with the v values and derivatives (t, dt), those over i
      // with the u values and derivatives, and the three sums against the k
      // values or derivatives once at the end: 2 K^2 + 3 K multiply-adds of
      // K-vectors per coordinate instead of 9 K^3 scalar ones.
      for (int r = 0; r < 3; ++r) {
        KVec<K> gu = KVec<K>::Zero(), gv = KVec<K>::Zero(), gw = KVec<K>::Zero();
        for (int i = 0; i < K; ++i) {
          const double* row = P[r] + base + i * si;
          KVec<K> t = N[1][0] * kload<K>(row), dt = dN[1][0] * kload<K>(row);
          for (int j = 1; j < K; ++j) {
            t += N[1][j] * kload<K>(row + j * sj);
            dt += dN[1][j] * kload<K>(row + j * sj);
          }
          gu += dN[0][i] * t;
          gw += N[0][i] * t;
          gv += N[0][i] * dt;
        }
        const KVec<K> nw = kload<K>(N[2]), dnw = kload<K>(dN[2]);
        out[3 * r] = (nw * gu).sum();
        out[3 * r + 1] = (nw * gv).sum();
        out[3 * r + 2] = (dnw * gw).sum();
      }
    } else {
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
        for (int q = 0; q < 3; ++q) out[3 * r + q] = acc[r][q];
    }
  }
}

}  // namespace vpffd::detail
