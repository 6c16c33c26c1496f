#pragma once
/// @file normals.h
/// Normals of a surface deformed by an FFD D: R^3 -> R^3.
///
/// Exact: a tangent vector t maps to J t (J = dD/dx), so the image of the tangent
/// plane with normal n = t1 x t2 has normal (J t1) x (J t2) = cof(J) n, where
/// cof(J) = det(J) J^-T is the cofactor matrix. It needs no inverse and stays
/// defined where J is singular.
///
/// Approximate (Section 2.4 of 001_589bf8d97509b8d4.txt, the GPU FFD paper): two
/// tangents T1, T2 orthogonal to n are mapped by finite differences,
/// F(T) ~ D(x + eps T) - D(x), and N = [D(x) - D(x + eps T1)] x [D(x) - D(x + eps T2)].
/// Its error is O(eps) plus the rounding of the differences, O(u / eps).

#include <cmath>

#include <Eigen/Geometry>  // cross products (Core alone declares them without a definition)

#include "vpffd/core/check.h"
#include "vpffd/core/parallel.h"
#include "vpffd/core/types.h"
#include "vpffd/ffd/points.h"
#include "vpffd/mesh/validate.h"

namespace vpffd {

namespace detail {

inline Vector3d normalized_or_zero(const Vector3d& n) {
  const double len = n.norm();
  return len > 0 && std::isfinite(len) ? Vector3d(n / len) : Vector3d::Zero();
}

/// Two unit tangents with t1 x t2 = n for a unit n (any frame; n = 0 gives zeros).
inline void tangent_frame(const Vector3d& n, Vector3d& t1, Vector3d& t2) {
  if (n.squaredNorm() == 0) {
    t1.setZero();
    t2.setZero();
    return;
  }
  // Cross with the axis least aligned with n, for a well-conditioned t1.
  Eigen::Index k;
  n.cwiseAbs().minCoeff(&k);
  t1 = n.cross(Vector3d::Unit(k)).normalized();
  t2 = n.cross(t1);
}

/// cof(J) n0 normalised (zero where it vanishes), J row-major (j[3 r + c] = dD_r / dx_c):
/// n0's components times the cross products of J's columns, the images of the axes.
inline Vector3d cofactor_normal(const double* j, const Vector3d& n0) {
  const Vector3d c0(j[0], j[3], j[6]), c1(j[1], j[4], j[7]), c2(j[2], j[5], j[8]);
  return normalized_or_zero(n0[0] * c1.cross(c2) + n0[1] * c2.cross(c0) + n0[2] * c0.cross(c1));
}

}  // namespace detail

/// Unit vertex normals: the sum of the area-weighted face normals around each
/// vertex, normalised (zero for unreferenced vertices or where they cancel).
/// @param[in] V  #V x 3 vertex positions
/// @param[in] F  #F x 3 triangles, counter-clockwise seen from outside
/// @param[in] vf vertex_faces(F, #V) of a mesh checked before (validate_mesh): for a
///               mesh that moves, built once
/// @returns #V x 3 unit normals
/// @throws InvalidInputError for lists of another mesh size
inline RowMatrixX3d vertex_normals(const Eigen::Ref<const RowMatrixX3d>& V, const Eigen::Ref<const RowMatrixX3i>& F,
                                   const VertexFaces& vf, int threads = 0) {
  VPFFD_CHECK(vf.indptr.size() == static_cast<size_t>(V.rows()) + 1 &&
                  vf.faces.size() == 3 * static_cast<size_t>(F.rows()),
              "vertex_normals: the vertex-face lists are not those of this mesh");
  RowMatrixX3d N(V.rows(), 3);
  // Gathered per vertex (no scatter), so threads never write the same row.
  parallel_range(V.rows(), threads, [&](Index b, Index e) {
    for (Index v = b; v < e; ++v) {
      Vector3d n = Vector3d::Zero();
      for (std::int32_t k = vf.indptr[v]; k < vf.indptr[v + 1]; ++k) {
        const std::int32_t f = vf.faces[k];
        const Vector3d p0 = V.row(F(f, 0));
        n += (V.row(F(f, 1)).transpose() - p0).cross(V.row(F(f, 2)).transpose() - p0);
      }
      N.row(v) = detail::normalized_or_zero(n).transpose();
    }
  });
  return N;
}

/// The same for any mesh: checks it and builds its vertex-face lists.
/// @throws InvalidInputError for a bad mesh
inline RowMatrixX3d vertex_normals(const Eigen::Ref<const RowMatrixX3d>& V, const Eigen::Ref<const RowMatrixX3i>& F,
                                   int threads = 0) {
  validate_mesh(V, F, "vertex_normals");
  return vertex_normals(V, F, vertex_faces(F, V.rows()), threads);
}

/// Exact normals of the deformed surface: cof(J_v) n_v, normalised.
/// @param[in] J   #V x 9 Jacobians, row-major per vertex: J(v, 3 r + c) = dD_r / dx_c
///                (Deformer::jacobians)
/// @param[in] N0  #V x 3 rest normals (need not be unit)
/// @returns #V x 3 unit normals (zero where cof(J) n vanishes)
/// @throws InvalidInputError for mismatched shapes or non-finite input
inline RowMatrixX3d deformed_normals_exact(const Eigen::Ref<const RowMatrixXd>& J,
                                           const Eigen::Ref<const RowMatrixX3d>& N0, int threads = 0) {
  VPFFD_CHECK(J.cols() == 9, "deformed_normals_exact: J has ", J.cols(), " columns, expected 9");
  VPFFD_CHECK(J.rows() == N0.rows(), "deformed_normals_exact: ", J.rows(), " Jacobians for ", N0.rows(), " normals");
  VPFFD_CHECK(J.allFinite() && N0.allFinite(), "deformed_normals_exact: input contains NaN or Inf");
  RowMatrixX3d N(N0.rows(), 3);
  parallel_range(N0.rows(), threads, [&](Index b, Index e) {
    for (Index v = b; v < e; ++v)
      N.row(v) = detail::cofactor_normal(J.row(v).data(), N0.row(v).transpose()).transpose();
  });
  return N;
}

/// Approximate normals of the deformed surface by mapped tangents (Section 2.4 of
/// the GPU FFD paper): N = [D(x) - D(x + eps T1)] x [D(x) - D(x + eps T2)],
/// normalised, with T1 x T2 = n0.
/// @param[in] L    lattice
/// @param[in] P    N x 3 control points
/// @param[in] X    #X x 3 rest-space points (the rest vertices)
/// @param[in] N0   #X x 3 rest normals
/// @param[in] eps  finite-difference step in world units (> 0)
/// @returns #X x 3 unit normals. Points (and offsets x + eps T) outside the
///          lattice box are evaluated on the extended boundary polynomial pieces.
/// @throws InvalidInputError for bad shapes or eps <= 0
inline RowMatrixX3d deformed_normals_tangent(const Lattice& L, const Eigen::Ref<const RowMatrixX3d>& P,
                                             const Eigen::Ref<const RowMatrixX3d>& X,
                                             const Eigen::Ref<const RowMatrixX3d>& N0, double eps, int threads = 0) {
  VPFFD_CHECK(X.rows() == N0.rows(), "deformed_normals_tangent: ", X.rows(), " points for ", N0.rows(), " normals");
  VPFFD_CHECK(std::isfinite(eps) && eps > 0, "deformed_normals_tangent: eps must be positive, got ", eps);
  VPFFD_CHECK(N0.allFinite(), "deformed_normals_tangent: normals contain NaN or Inf");
  const Index n = X.rows();
  RowMatrixX3d Y(3 * n, 3);
  for (Index v = 0; v < n; ++v) {
    Vector3d t1, t2;
    detail::tangent_frame(detail::normalized_or_zero(N0.row(v).transpose()), t1, t2);
    Y.row(3 * v) = X.row(v);
    Y.row(3 * v + 1) = X.row(v) + eps * t1.transpose();
    Y.row(3 * v + 2) = X.row(v) + eps * t2.transpose();
  }
  const RowMatrixX3d D = ffd_points(L, P, Y, OutsidePolicy::Extrapolate, threads);
  RowMatrixX3d N(n, 3);
  for (Index v = 0; v < n; ++v) {
    const Vector3d d0 = D.row(3 * v), d1 = D.row(3 * v + 1), d2 = D.row(3 * v + 2);
    N.row(v) = detail::normalized_or_zero((d0 - d1).cross(d0 - d2)).transpose();
  }
  return N;
}

}  // namespace vpffd
