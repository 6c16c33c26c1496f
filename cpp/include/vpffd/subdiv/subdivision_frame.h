#pragma once
/// @file subdivision_frame.h
/// A frame of a displaced subdivision surface (paper 002, §5.2): new control points
/// C' (M x 3) -> S' = Phi C', S'_u = Phi_u C', S'_v = Phi_v C' at every fine
/// vertex's foot point from the precomputed stencils (eq. 8), then the per-vertex
/// rebuild of reconstruct.h (p' = S' + d N_S', approximate normal of eqs. 6-7).
/// One independent pass over the fine vertices, no connectivity; each vertex writes
/// only its own rows, so the result does not depend on the thread count.
///
/// An affine edit of a group G of control points (§5.2.2), c_j -> A c_j + t for
/// j in G, is S' = R_i + A G_i + t g_i with, per fine vertex, the fixed part
/// R_i = sum_{j not in G} w_ij c_j, the group moment G_i = sum_{j in G} w_ij c_j and
/// weight g_i = sum_{j in G} w_ij (and likewise for S_u, S_v): 21 numbers per
/// vertex the group reaches, so a frame reads no control point at all.

#include <algorithm>
#include <vector>

#include <Eigen/Core>

#include "vpffd/core/check.h"
#include "vpffd/core/parallel.h"
#include "vpffd/multires/reconstruct.h"
#include "vpffd/subdiv/subdivision_multires.h"

namespace vpffd {

/// Deformed fine vertices, their normals and the deformed base points S'(t_i).
struct SubdivFrame {
  RowMatrixX3d vertices;  ///< #V x 3
  RowMatrixX3d normals;   ///< #V x 3 unit approximate normals (zero where S'_u || S'_v)
  RowMatrixX3d base;      ///< #V x 3 S'(t_i)
};

namespace detail {

inline void require_control_points(const SubdivisionMultires& m, const Eigen::Ref<const RowMatrixX3d>& C,
                                   const char* where) {
  VPFFD_CHECK(C.rows() == m.n_control(), where, ": expected ", m.n_control(), " control points, got ", C.rows());
  for (Index j = 0; j < C.rows(); ++j)
    VPFFD_CHECK(C.row(j).allFinite(), where, ": control point ", j, " is not finite (NaN or infinity)");
}

inline SubdivFrame allocate_frame(Index n) {
  SubdivFrame f;
  f.vertices.resize(n, 3);
  f.normals.resize(n, 3);
  f.base.resize(n, 3);
  return f;
}

VPFFD_ALWAYS_INLINE void write_vertex(SubdivFrame& f, Index i, const SubdivisionMultires& m, const Vector3d& s,
                                      const Vector3d& su, const Vector3d& sv) {
  NormalCoefficients c;
  for (int k = 0; k < 6; ++k) c[k] = m.coef[k][i];
  Vector3d p, n;
  reconstruct_vertex(s, su, sv, m.d[i], c, p, n);
  f.vertices.row(i) = p;
  f.normals.row(i) = n;
  f.base.row(i) = s;
}

}  // namespace detail

/// S, S_u, S_v of fine vertex i for control points C (M x 3, row-major).
VPFFD_ALWAYS_INLINE void evaluate_stencils(const LimitStencils& st, const double* C, Index i, Vector3d& s,
                                           Vector3d& su, Vector3d& sv) {
  s.setZero();
  su.setZero();
  sv.setZero();
  for (std::int64_t k = st.indptr[i]; k < st.indptr[i + 1]; ++k) {
    const Eigen::Map<const Vector3d> c(C + 3 * std::int64_t(st.indices[k]));
    s += st.w[k] * c;
    su += st.wu[k] * c;
    sv += st.wv[k] * c;
  }
}

/// One frame from new control points C (M x 3).
/// @throws InvalidInputError when C has the wrong number of rows or a non-finite entry
inline SubdivFrame deform_subdivision(const SubdivisionMultires& m, const Eigen::Ref<const RowMatrixX3d>& C,
                                      int threads = 0) {
  detail::require_control_points(m, C, "SubdivisionMultires.deform");
  const RowMatrixX3d Cc = C;  // contiguous row-major whatever the caller's strides
  SubdivFrame f = detail::allocate_frame(m.n_vertices());
  parallel_range(m.n_vertices(), threads, [&](Index b, Index e) {
    for (Index i = b; i < e; ++i) {
      Vector3d s, su, sv;
      evaluate_stencils(m.stencils, Cc.data(), i, s, su, sv);
      detail::write_vertex(f, i, m, s, su, sv);
    }
  });
  return f;
}

/// A group of control points with its basis precomputed per fine vertex, for
/// affine edits of the group (see the file comment). Only the fine vertices whose
/// stencils reach the group move; the others keep the frame of the held control
/// points, computed once here, so a frame copies that and rebuilds the influenced
/// vertices alone (a few % of the mesh for a few control points).
struct AffineGroup {
  std::vector<std::int32_t> indices;  ///< the group's control points, ascending, distinct
  std::vector<std::int32_t> rows;     ///< fine vertices whose stencils reach the group, ascending
  /// rows.size() x 21 row-major: R, R_u, R_v (9), G, G_u, G_v (9), g, g_u, g_v (3).
  std::vector<double> data;
  SubdivFrame held;  ///< the frame of the held control points (every vertex)
  static constexpr int kStride = 21;
  /// Bytes held per fine vertex: the held frame (72) and 168 per influenced vertex.
  double bytes_per_vertex() const {
    const double n = double(held.vertices.rows());
    return n > 0 ? 9 * sizeof(double) + double(data.size() * sizeof(double) + rows.size() * 4) / n : 0;
  }
};

/// Precomputes the group `indices` of control points, the others held at C (M x 3).
/// @throws InvalidInputError for an empty group, an index out of range or repeated,
///         or a bad C
inline AffineGroup make_affine_group(const SubdivisionMultires& m, const Eigen::Ref<const RowMatrixX3d>& C,
                                     const std::vector<std::int32_t>& indices, int threads = 0) {
  detail::require_control_points(m, C, "SubdivisionMultires.affine_group");
  VPFFD_CHECK(!indices.empty(), "SubdivisionMultires.affine_group: the group is empty");
  std::vector<char> in(m.n_control(), 0);
  for (std::int32_t j : indices) {
    VPFFD_CHECK(j >= 0 && j < m.n_control(), "SubdivisionMultires.affine_group: control point ", j,
                " out of range [0, ", m.n_control(), ")");
    VPFFD_CHECK(!in[j], "SubdivisionMultires.affine_group: control point ", j, " is listed twice");
    in[j] = 1;
  }
  AffineGroup g;
  g.indices = indices;
  std::sort(g.indices.begin(), g.indices.end());
  g.held = deform_subdivision(m, C, threads);
  const LimitStencils& st = m.stencils;
  for (Index i = 0; i < m.n_vertices(); ++i)
    for (std::int64_t k = st.indptr[i]; k < st.indptr[i + 1]; ++k)
      if (in[st.indices[k]]) {
        g.rows.push_back(std::int32_t(i));
        break;
      }
  const Index n = Index(g.rows.size());
  g.data.assign(size_t(n) * AffineGroup::kStride, 0.0);
  parallel_range(n, threads, [&](Index b, Index e) {
    for (Index r = b; r < e; ++r) {
      const Index i = g.rows[r];
      double* out = g.data.data() + r * AffineGroup::kStride;
      for (std::int64_t k = st.indptr[i]; k < st.indptr[i + 1]; ++k) {
        const std::int32_t j = st.indices[k];
        const double w[3] = {st.w[k], st.wu[k], st.wv[k]};
        double* moment = in[j] ? out + 9 : out;
        for (int q = 0; q < 3; ++q)
          for (int a = 0; a < 3; ++a) moment[3 * q + a] += w[q] * C(j, a);
        if (in[j])
          for (int q = 0; q < 3; ++q) out[18 + q] += w[q];
      }
    }
  });
  return g;
}

/// The frame where the group moves by the affine map x -> A x + t (T = [A t; 0 1],
/// 4 x 4) and every other control point stays where make_affine_group held it.
/// Equal to deform_subdivision with those control points up to rounding (and
/// bit for bit on the vertices the group does not reach).
/// @throws InvalidInputError for a non-finite T or a last row other than (0, 0, 0, 1)
inline SubdivFrame deform_affine_group(const SubdivisionMultires& m, const AffineGroup& g, const Eigen::Matrix4d& T,
                                       int threads = 0) {
  VPFFD_CHECK(T.allFinite(), "AffineGroup.deform: the transform is not finite");
  VPFFD_CHECK(T(3, 0) == 0 && T(3, 1) == 0 && T(3, 2) == 0 && T(3, 3) == 1,
              "AffineGroup.deform: the last row of an affine transform must be (0, 0, 0, 1)");
  VPFFD_CHECK(g.held.vertices.rows() == m.n_vertices() && g.data.size() == g.rows.size() * AffineGroup::kStride,
              "AffineGroup.deform: the group was made for another decomposition");
  const Matrix3d A = T.topLeftCorner<3, 3>();
  const Vector3d t = T.topRightCorner<3, 1>();
  SubdivFrame f = g.held;
  parallel_range(Index(g.rows.size()), threads, [&](Index b, Index e) {
    for (Index r = b; r < e; ++r) {
      const double* d = g.data.data() + r * AffineGroup::kStride;
      Vector3d out[3];
      for (int q = 0; q < 3; ++q)
        out[q] = Eigen::Map<const Vector3d>(d + 3 * q) + A * Eigen::Map<const Vector3d>(d + 9 + 3 * q) + d[18 + q] * t;
      detail::write_vertex(f, g.rows[r], m, out[0], out[1], out[2]);
    }
  });
  return f;
}

}  // namespace vpffd
