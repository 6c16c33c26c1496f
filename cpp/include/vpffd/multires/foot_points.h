#pragma once
/// @file foot_points.h
/// Exact foot points of the fine vertices on the smooth base (paper 002, eq. 1):
/// per fine vertex p a point t on the base with p - S(t) parallel to N_S(t).
///
/// The base is the faired triangle mesh with a *continuous* normal field: on base
/// triangle (s0, s1, s2), S(u, v) = s0 + u (s1 - s0) + v (s2 - s0) and N_S(u, v) is
/// the unit of n0 + u (n1 - n0) + v (n2 - n0), with n_k the base's unit
/// area-weighted vertex normals (Phong normals). With the faces' own normals the
/// normal jumps at every edge: the points above a convex edge have no foot point
/// and those above a concave one have two, which is why a scan's vertices "needed
/// extrapolation" there. With the interpolated field, neighbouring fine vertices
/// get neighbouring foot points and displacement directions, and a deformation
/// moves them alike.
///
/// p = S(u, v) + t (n0 + u m1 + v m2) is three equations in (u, v, t), solved by
/// Newton steps from the orthogonal projection onto the triangle's plane. When the
/// solution lies outside the triangle the search steps into the neighbour across
/// the edge it leaves by and solves again, until the foot point is inside its
/// triangle (to kInsideTolerance in barycentric coordinates). A vertex's search
/// starts on the triangle of its own one-ring that needs the least extrapolation.
///
/// Where no exact foot point is found (the walk reaches a boundary or a non-manifold
/// edge, returns to a triangle it visited, exceeds kMaxFootPointSteps triangles, or
/// the interpolated normal turns more than ~87 degrees from its triangle's), the
/// vertex takes the walk's nearest candidate, clamped into its triangle, with the
/// interpolated normal there: its displacement direction stays continuous with its
/// neighbours'. It is reported (`exact` false, `residual` the tangential distance
/// p - S misses the normal by). The frame stores p - d N_S as its foot point, which
/// lies that residual off the surface in the tangent plane, so the identity and
/// rigid motions still reproduce it exactly. Only where no triangle of the walk can
/// be solved does it keep the affine representation p = s0 + u S_u + v S_v + d N_face
/// of its start triangle (residual: how far that foot point lies outside it).

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/LU>

#include "vpffd/core/check.h"
#include "vpffd/core/parallel.h"
#include "vpffd/core/types.h"
#include "vpffd/mesh/face_adjacency.h"
#include "vpffd/mesh/validate.h"

namespace vpffd {

/// Triangles a foot-point walk may visit before the vertex is reported as not found.
inline constexpr int kMaxFootPointSteps = 64;

/// A foot point counts as inside its triangle down to this barycentric coordinate:
/// on an edge, the solutions in the two triangles agree (the normal field is
/// continuous) and either may come out a rounding error outside.
inline constexpr double kInsideTolerance = 1e-10;

/// Foot point of one vertex.
struct FootPoint {
  std::int32_t face = -1;  ///< base triangle, -1 when none is usable
  double u = 0, v = 0;     ///< S = s0 + u (s1 - s0) + v (s2 - s0)
  double d = 0;            ///< signed distance from S along the unit normal N_S
  double residual = 0;     ///< world units: tangential residual when exact (rounding), else
                           ///< the affine foot point's distance outside its triangle
  bool exact = false;      ///< p - S parallel to the interpolated N_S, S inside its triangle
  Vector3d foot = Vector3d::Zero();    ///< S(t) (exact) or the affine foot point
  Vector3d normal = Vector3d::Zero();  ///< unit N_S used for d
};

namespace detail {

/// Distance from q to segment [a, b].
inline double segment_distance(const Vector3d& q, const Vector3d& a, const Vector3d& b) {
  const Vector3d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0 ? std::clamp((q - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (q - (a + t * ab)).norm();
}

/// max(0, -b) over the three barycentric coordinates (1 - u - v, u, v).
inline double outside_amount(double u, double v) { return std::max({0.0, -u, -v, u + v - 1.0}); }

/// The corner whose barycentric coordinate is most negative: the walk leaves through
/// the edge opposite it.
inline int exit_corner(double u, double v) {
  const double b[3] = {1.0 - u - v, u, v};
  int c = 0;
  for (int k = 1; k < 3; ++k)
    if (b[k] < b[c]) c = k;
  return c;
}

}  // namespace detail

/// (u, v, d) of point p in the affine frame of triangle (s0, s1, s2): the orthogonal
/// projection onto its plane, S_u = s1 - s0, S_v = s2 - s0. False when the triangle
/// is degenerate (area below 1e-14 of its squared edge lengths).
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
  fp.normal = n;
  fp.foot = s0 + fp.u * su + fp.v * sv;
  fp.exact = false;
  fp.residual = detail::outside_amount(fp.u, fp.v) == 0
                    ? 0.0
                    : std::min({detail::segment_distance(fp.foot, s0, s1), detail::segment_distance(fp.foot, s1, s2),
                                detail::segment_distance(fp.foot, s2, s0)});
  return true;
}

/// Newton steps for p = S(u, v) + t Ñ(u, v) on one triangle with vertex normals
/// n0, n1, n2 (Ñ not normalised), from the planar projection. Returns false when
/// the triangle is degenerate or the steps do not converge; on success (u, v) may
/// lie outside the triangle (the caller walks on).
inline bool solve_on_triangle(const Vector3d& p, const Vector3d& s0, const Vector3d& s1, const Vector3d& s2,
                              const Vector3d& n0, const Vector3d& n1, const Vector3d& n2, double& u, double& v,
                              double& t) {
  FootPoint planar;
  if (!triangle_frame_coordinates(p, s0, s1, s2, planar)) return false;
  const Vector3d e1 = s1 - s0, e2 = s2 - s0, m1 = n1 - n0, m2 = n2 - n0;
  u = planar.u;
  v = planar.v;
  t = planar.d;
  // A length scale of the equations: the residual G is compared with it.
  const double scale = e1.norm() + e2.norm() + std::abs(t) + (p - s0).norm();
  for (int it = 0; it < 40; ++it) {
    const Vector3d nt = n0 + u * m1 + v * m2;
    const Vector3d g = s0 + u * e1 + v * e2 + t * nt - p;
    Matrix3d J;
    J.col(0) = e1 + t * m1;
    J.col(1) = e2 + t * m2;
    J.col(2) = nt;
    const double det = J.determinant();
    if (!(std::abs(det) > 1e-14 * J.col(0).norm() * J.col(1).norm() * J.col(2).norm())) return false;
    const Vector3d step = J.partialPivLu().solve(-g);
    u += step[0];
    v += step[1];
    t += step[2];
    if (!std::isfinite(u) || !std::isfinite(v) || !std::isfinite(t) || std::abs(u) + std::abs(v) > 1e6) return false;
    // Quadratic convergence: once the step is at rounding level, one more is noise.
    if (step.template head<2>().cwiseAbs().maxCoeff() <= 1e-15 && std::abs(step[2]) <= 1e-15 * scale) return true;
    if (g.norm() <= 1e-16 * scale && it > 0) return true;
  }
  const Vector3d nt = n0 + u * m1 + v * m2;
  return (s0 + u * e1 + v * e2 + t * nt - p).norm() <= 1e-13 * scale;
}

namespace detail {

/// The point of the parameter triangle {u, v >= 0, u + v <= 1} nearest to (u, v).
inline void clamp_to_triangle(double& u, double& v) {
  if (u >= 0 && v >= 0 && u + v <= 1) return;
  auto seg = [](double au, double av, double bu, double bv, double pu, double pv, double& qu, double& qv) {
    const double du = bu - au, dv = bv - av;
    const double t = std::clamp(((pu - au) * du + (pv - av) * dv) / (du * du + dv * dv), 0.0, 1.0);
    qu = au + t * du;
    qv = av + t * dv;
    return (pu - qu) * (pu - qu) + (pv - qv) * (pv - qv);
  };
  double bu = 0, bv = 0, best = std::numeric_limits<double>::infinity();
  const double E[3][4] = {{0, 0, 1, 0}, {1, 0, 0, 1}, {0, 1, 0, 0}};
  for (const auto& e : E) {
    double qu, qv;
    const double d2 = seg(e[0], e[1], e[2], e[3], u, v, qu, qv);
    if (d2 < best) {
      best = d2;
      bu = qu;
      bv = qv;
    }
  }
  u = bu;
  v = bv;
}

/// Fills fp for point p at parameter (u, v) of triangle f: S, the unit interpolated
/// normal, d = (p - S) . N and the tangential residual. False where the normal is
/// unusable (see walk_foot_point).
inline bool set_foot(const Vector3d& p, const Eigen::Ref<const RowMatrixX3d>& S, const Eigen::Ref<const RowMatrixX3d>& NS,
                     const Eigen::Ref<const RowMatrixX3i>& F, std::int32_t f, double u, double v, FootPoint& fp) {
  const Vector3d s0 = S.row(F(f, 0)), s1 = S.row(F(f, 1)), s2 = S.row(F(f, 2));
  const Vector3d n0 = NS.row(F(f, 0)), n1 = NS.row(F(f, 1)), n2 = NS.row(F(f, 2));
  const Vector3d nt = n0 + u * (n1 - n0) + v * (n2 - n0);
  const Vector3d face_n = (s1 - s0).cross(s2 - s0);
  // The frame's tangents are the triangle's edges projected on the plane normal to
  // N_S: they must keep the triangle's orientation, well away from degenerate.
  if (!(nt.norm() > 0.5 && nt.dot(face_n) > 0.05 * nt.norm() * face_n.norm())) return false;
  fp.face = f;
  fp.u = u;
  fp.v = v;
  fp.normal = nt.normalized();
  fp.foot = s0 + u * (s1 - s0) + v * (s2 - s0);
  const Vector3d r = p - fp.foot;
  fp.d = r.dot(fp.normal);
  fp.residual = (r - fp.d * fp.normal).norm();
  return true;
}

}  // namespace detail

/// Exact foot point of p on the base (S, NS, F), walking from triangle `start`.
/// The walk steps across the edge a triangle's solution leaves by. Near a vertex
/// the solutions of its triangles can each point into the next one and the walk
/// circles (or one triangle's Newton steps find no root); then every triangle
/// around the vertices the walk visited is solved, and the inside solution nearest
/// along its normal (smallest |d|) is taken.
/// @param NS  #V x 3 unit vertex normals of the base
/// @param adj face_neighbours(F); vf vertex_faces(F, #V)
/// @returns the foot point with exact = true; where none was found, the nearest
///          candidate (exact = false): the solution that left its triangle least,
///          clamped into it, with its residual; face = -1 when no triangle tried
///          could be solved at all
inline FootPoint walk_foot_point(const Vector3d& p, const Eigen::Ref<const RowMatrixX3d>& S,
                                 const Eigen::Ref<const RowMatrixX3d>& NS, const Eigen::Ref<const RowMatrixX3i>& F,
                                 const RowMatrixX3i& adj, const VertexFaces& vf, std::int32_t start) {
  std::int32_t visited[kMaxFootPointSteps];
  int n_visited = 0;
  std::int32_t near_face = -1;
  double near_u = 0, near_v = 0, near_out = std::numeric_limits<double>::infinity();
  enum class Found { no_root, outside, exact };
  // Solves on f: fp is set when the solution is an exact foot point; (u, v) is the
  // solution otherwise (the walk leaves through it), and the nearest outside one
  // is kept for the fallback.
  auto try_face = [&](std::int32_t f, FootPoint& fp, double& u, double& v) {
    double t;
    if (!solve_on_triangle(p, S.row(F(f, 0)), S.row(F(f, 1)), S.row(F(f, 2)), NS.row(F(f, 0)), NS.row(F(f, 1)),
                           NS.row(F(f, 2)), u, v, t))
      return Found::no_root;
    const double out = detail::outside_amount(u, v);
    if (out <= kInsideTolerance && detail::set_foot(p, S, NS, F, f, u, v, fp)) return Found::exact;
    if (out < near_out) {
      near_out = out;
      near_face = f;
      near_u = u;
      near_v = v;
    }
    return Found::outside;
  };
  for (std::int32_t f = start; f >= 0 && n_visited < kMaxFootPointSteps;) {
    bool again = false;
    for (int k = 0; k < n_visited; ++k) again = again || visited[k] == f;
    if (again) break;
    visited[n_visited++] = f;
    FootPoint fp;
    double u, v;
    const Found r = try_face(f, fp, u, v);
    if (r == Found::exact) {
      fp.exact = true;
      return fp;
    }
    if (r == Found::no_root) break;
    f = adj(f, detail::exit_corner(u, v));
  }
  // The fans of the visited triangles' corners, each triangle once.
  std::vector<std::int32_t> fan;
  for (int k = 0; k < n_visited; ++k)
    for (int c = 0; c < 3; ++c) {
      const std::int32_t w = F(visited[k], c);
      for (std::int32_t q = vf.indptr[w]; q < vf.indptr[w + 1]; ++q) fan.push_back(vf.faces[q]);
    }
  std::sort(fan.begin(), fan.end());
  fan.erase(std::unique(fan.begin(), fan.end()), fan.end());
  FootPoint best;
  for (std::int32_t f : fan) {
    FootPoint fp;
    double u, v;
    if (try_face(f, fp, u, v) == Found::exact && (best.face < 0 || std::abs(fp.d) < std::abs(best.d))) best = fp;
  }
  if (best.face >= 0) {
    best.exact = true;
    return best;
  }
  FootPoint fp;
  if (near_face >= 0) {
    detail::clamp_to_triangle(near_u, near_v);
    if (!detail::set_foot(p, S, NS, F, near_face, near_u, near_v, fp)) fp.face = -1;
  }
  fp.exact = false;
  return fp;
}

/// Foot points of the fine vertices P on the base S (same faces F) with the base's
/// unit vertex normals NS (see the file comment).
/// @param[in] P  #V x 3 fine vertices
/// @param[in] S  #V x 3 base vertices
/// @param[in] NS #V x 3 unit vertex normals of the base
/// @param[in] F  #F x 3 triangles of both
/// @param[in] exact  false: only the affine representation in the least-extrapolated
///               one-ring triangle (the walk is skipped)
/// @returns one FootPoint per vertex
/// @throws InvalidInputError naming the first vertex with no usable one-ring
///         triangle (unreferenced, or all its base triangles degenerate)
inline std::vector<FootPoint> foot_points(const Eigen::Ref<const RowMatrixX3d>& P,
                                          const Eigen::Ref<const RowMatrixX3d>& S,
                                          const Eigen::Ref<const RowMatrixX3d>& NS,
                                          const Eigen::Ref<const RowMatrixX3i>& F, bool exact = true,
                                          int threads = 0) {
  VPFFD_CHECK(P.rows() == S.rows() && NS.rows() == S.rows(), "foot_points: ", P.rows(), " fine vertices, ",
              S.rows(), " base vertices, ", NS.rows(), " base normals");
  const VertexFaces vf = vertex_faces(F, P.rows());
  const RowMatrixX3i adj = exact ? face_neighbours(F) : RowMatrixX3i();
  std::vector<FootPoint> out(P.rows());
  parallel_range(P.rows(), threads, [&](Index b, Index e) {
    for (Index i = b; i < e; ++i) {
      const Vector3d p = P.row(i);
      FootPoint best;
      double best_out = std::numeric_limits<double>::infinity();
      for (std::int32_t k = vf.indptr[i]; k < vf.indptr[i + 1]; ++k) {
        const std::int32_t f = vf.faces[k];
        FootPoint fp;
        if (!triangle_frame_coordinates(p, S.row(F(f, 0)), S.row(F(f, 1)), S.row(F(f, 2)), fp)) continue;
        // Least extrapolation; among triangles that contain the projection (ties
        // at 0), the nearest plane. Strict comparisons keep the first in face order.
        const double o = detail::outside_amount(fp.u, fp.v);
        if (o < best_out || (o == best_out && std::abs(fp.d) < std::abs(best.d))) {
          fp.face = f;
          best = fp;
          best_out = o;
        }
      }
      if (exact && best.face >= 0) {
        const FootPoint w = walk_foot_point(p, S, NS, F, adj, vf, best.face);
        if (w.face >= 0) best = w;
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
