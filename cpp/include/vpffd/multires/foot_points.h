#pragma once
/// @file foot_points.h
/// Foot points of the fine vertices on the base surface S (paper 002, eq. 1), in
/// the affine frame of one base triangle.
///
/// A base triangle (s0, s1, s2) is its own linear patch: S(u, v) = s0 + u S_u +
/// v S_v with S_u = s1 - s0, S_v = s2 - s0, N_S = unit(S_u x S_v). Every fine
/// vertex is written exactly as p = s0 + u S_u + v S_v + d N_S. The triangle is
/// the one of the vertex's own one-ring (same connectivity as the fine mesh) whose
/// (u, v) needs the least extrapolation; (u, v) may lie outside it (a prototype
/// found only 62-72 % of scan vertices project inside a one-ring triangle), which
/// keeps the identity and rigid motions exact with no separate residual. What
/// is reported as the residual is how far the affine foot point S(u, v) lies
/// outside its triangle, in world units (0 inside): the tangential distance an
/// exact foot point on the triangle would miss by.

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "vpffd/core/check.h"
#include "vpffd/core/parallel.h"
#include "vpffd/core/types.h"
#include "vpffd/mesh/validate.h"

namespace vpffd {

/// Foot point of one vertex: base triangle, affine coordinates and distance.
struct FootPoint {
  std::int32_t face = -1;  ///< base triangle, -1 when none is usable
  double u = 0, v = 0;     ///< affine coordinates along S_u, S_v
  double d = 0;            ///< signed distance along N_S
  double outside = 0;      ///< max(0, -u, -v, u + v - 1): barycentric extrapolation
  double residual = 0;     ///< world distance from S(u, v) to the triangle
};

namespace detail {

/// Distance from q to segment [a, b].
inline double segment_distance(const Vector3d& q, const Vector3d& a, const Vector3d& b) {
  const Vector3d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0 ? std::clamp((q - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (q - (a + t * ab)).norm();
}

}  // namespace detail

/// (u, v, d) of point p in the frame of triangle (s0, s1, s2), or false when the
/// triangle is degenerate (area below 1e-14 of its squared edge lengths).
inline bool triangle_frame_coordinates(const Vector3d& p, const Vector3d& s0, const Vector3d& s1, const Vector3d& s2,
                                       FootPoint& fp) {
  const Vector3d su = s1 - s0, sv = s2 - s0, c = su.cross(sv);
  const double cn = c.norm();
  if (!(cn > 1e-14 * (su.squaredNorm() + sv.squaredNorm()))) return false;
  const Vector3d n = c / cn, r = p - s0;
  // r = u S_u + v S_v + d N: the tangential part from the 2x2 Gram system
  // (Cramer with the cross product: u = ((r x S_v) . c) / |c|^2, ...).
  fp.u = r.cross(sv).dot(c) / (cn * cn);
  fp.v = su.cross(r).dot(c) / (cn * cn);
  fp.d = r.dot(n);
  fp.outside = std::max({0.0, -fp.u, -fp.v, fp.u + fp.v - 1.0});
  if (fp.outside == 0) {
    fp.residual = 0;
  } else {
    const Vector3d q = s0 + fp.u * su + fp.v * sv;
    fp.residual = std::min({detail::segment_distance(q, s0, s1), detail::segment_distance(q, s1, s2),
                            detail::segment_distance(q, s2, s0)});
  }
  return true;
}

/// Foot points of the fine vertices P on the base S (same faces F).
/// @param[in] P  #V x 3 fine vertices
/// @param[in] S  #V x 3 base vertices
/// @param[in] F  #F x 3 triangles of both
/// @returns one FootPoint per vertex
/// @throws InvalidInputError naming the first vertex with no usable one-ring
///         triangle (unreferenced, or all its base triangles degenerate)
inline std::vector<FootPoint> foot_points(const Eigen::Ref<const RowMatrixX3d>& P,
                                          const Eigen::Ref<const RowMatrixX3d>& S,
                                          const Eigen::Ref<const RowMatrixX3i>& F, int threads = 0) {
  VPFFD_CHECK(P.rows() == S.rows(), "foot_points: ", P.rows(), " fine vertices, ", S.rows(), " base vertices");
  const VertexFaces vf = vertex_faces(F, P.rows());
  std::vector<FootPoint> out(P.rows());
  parallel_range(P.rows(), threads, [&](Index b, Index e) {
    for (Index i = b; i < e; ++i) {
      const Vector3d p = P.row(i);
      FootPoint best;
      best.outside = std::numeric_limits<double>::infinity();
      for (std::int32_t k = vf.indptr[i]; k < vf.indptr[i + 1]; ++k) {
        const std::int32_t f = vf.faces[k];
        FootPoint fp;
        if (!triangle_frame_coordinates(p, S.row(F(f, 0)), S.row(F(f, 1)), S.row(F(f, 2)), fp)) continue;
        // Least extrapolation; among triangles that contain the projection (ties
        // at 0), the nearest plane. Strict comparisons keep the first in face order.
        if (fp.outside < best.outside || (fp.outside == best.outside && std::abs(fp.d) < std::abs(best.d))) {
          fp.face = f;
          best = fp;
        }
      }
      out[i] = best;
    }
  });
  for (Index i = 0; i < P.rows(); ++i)
    VPFFD_CHECK(out[i].face >= 0, "foot_points: the foot-point search failed for vertex ", i, ": ",
                vf.indptr[i + 1] == vf.indptr[i] ? "it is in no triangle"
                                                 : "all its triangles on the base surface are degenerate (zero area)",
                "; remove unreferenced vertices or use less smoothing");
  return out;
}

}  // namespace vpffd
