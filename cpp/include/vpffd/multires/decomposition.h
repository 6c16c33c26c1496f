#pragma once
/// @file decomposition.h
/// Two-scale decomposition of a fine mesh M (paper 002, Section 3.1): a smooth
/// base S with the same connectivity and, per fine vertex, what one frame needs to
/// rebuild it from any deformation of S with no neighbours (eq. 1 and eqs. 6-7).
///
/// Per-vertex frame data, structure of arrays (one contiguous array per scalar, as
/// a compute shader reads it): the foot point S(t_i) (3), the base tangents S_u,
/// S_v (6), the normal displacement d_i (1) and the six normal coefficients:
/// 16 doubles, 128 bytes (64 in float32). A deformer maps (S, S_u, S_v) to
/// (S', S'_u, S'_v); reconstruct() in reconstruct.h does the rest.

#include <array>
#include <memory>
#include <vector>

#include "vpffd/core/check.h"
#include "vpffd/core/parallel.h"
#include "vpffd/core/progress.h"
#include "vpffd/ffd/normals.h"
#include "vpffd/multires/fairing.h"
#include "vpffd/multires/fitting.h"
#include "vpffd/multires/foot_points.h"
#include "vpffd/multires/lift.h"
#include "vpffd/multires/normal_coefficients.h"

namespace vpffd {

/// The decomposition: base mesh, foot points and the per-vertex frame data.
struct Multires {
  RowMatrixX3d fine;     ///< #V x 3 rest fine vertices
  RowMatrixX3i faces;    ///< #F x 3 triangles (fine and base)
  RowMatrixX3d base;     ///< #V x 3 base vertices
  RowMatrixX3d rest_normals;  ///< #V x 3 unit area-weighted normals of the fine mesh
  double smoothing = 0;  ///< fair_mesh's diffusion time
  double fairness = 0;   ///< relative thin-plate weight of the fit (0: not fitted)
  /// RMS |d| (world units) before the fit and after each fit round (one entry when
  /// not fitted).
  std::vector<double> rms_displacement;

  // Frame data (SoA), one entry per vertex.
  std::array<std::vector<double>, 3> foot;  ///< S(t_i) = s0 + u S_u + v S_v
  std::array<std::vector<double>, 3> su;    ///< S_u of the foot triangle
  std::array<std::vector<double>, 3> sv;    ///< S_v of the foot triangle
  std::vector<double> d;                    ///< signed normal displacement
  std::array<std::vector<double>, 6> coef;  ///< a_u, b_u, g_u, a_v, b_v, g_v

  // Foot-point bookkeeping (not read by a frame).
  std::vector<std::int32_t> face;  ///< base triangle of each vertex
  std::vector<double> u, v;        ///< affine coordinates in it
  std::vector<double> residual;    ///< world units: how far p - S(u, v) misses the interpolated
                                   ///< normal N_S(u, v) (rounding where exact); with affine foot
                                   ///< points, the foot point's distance outside its triangle
  std::vector<std::uint8_t> exact; ///< 1 where the foot point is exact (eq. 1)
  /// Fraction w of each exact displacement handed to the base deformation (lift.h):
  /// d above is (1 - w) times the displacement from the foot point, which is lifted
  /// by w d along N_S. Empty when not lifted.
  std::vector<double> lift;

  Index n_vertices() const { return fine.rows(); }
  /// Bytes one frame reads per vertex (the SoA arrays above): 128.
  static constexpr int frame_bytes_per_vertex = 16 * sizeof(double);
  /// Per-vertex data kept: frame data, foot bookkeeping (4 + 1 + 4 x 8 bytes), and
  /// the fine, base and rest-normal rows (9 doubles): 128 + 37 + 72 = 237 bytes.
  static constexpr int bytes_per_vertex = frame_bytes_per_vertex + sizeof(std::int32_t) + sizeof(std::uint8_t) +
                                          4 * sizeof(double) + 9 * sizeof(double);
  /// Vertices with no exact foot point (kept in the affine frame of a triangle).
  Index unresolved_count() const {
    Index n = 0;
    for (std::uint8_t e : exact) n += e == 0;
    return n;
  }
  /// Vertices whose displacement is partly lifted (lift > 0).
  Index lifted_count() const {
    Index n = 0;
    for (double w : lift) n += w > 0;
    return n;
  }
  /// Fraction of the vertices with no exact foot point.
  double extrapolated_fraction() const {
    return n_vertices() ? double(unresolved_count()) / double(n_vertices()) : 0.0;
  }
  Vector3d foot_point(Index i) const { return {foot[0][i], foot[1][i], foot[2][i]}; }
  Vector3d tangent_u(Index i) const { return {su[0][i], su[1][i], su[2][i]}; }
  Vector3d tangent_v(Index i) const { return {sv[0][i], sv[1][i], sv[2][i]}; }
  NormalCoefficients coefficients(Index i) const {
    NormalCoefficients c;
    for (int k = 0; k < 6; ++k) c[k] = coef[k][i];
    return c;
  }
};

namespace detail {
inline double rms(const std::vector<double>& x) {
  double s = 0;
  for (double v : x) s += v * v;
  return x.empty() ? 0.0 : std::sqrt(s / double(x.size()));
}
}  // namespace detail

/// Phi (#V x #V): row i holds the barycentric weights of vertex i's foot point on
/// its base triangle, so Phi * base = the foot points S(t_i). An unresolved vertex's
/// parameter is clamped into its triangle (the nearest point of the base the search
/// found): an extrapolated affine parameter can carry weights of any size (1e7 was
/// seen on a scan's sliver), which would make the fit's normal equations singular.
inline RowSparse foot_point_weights(const Multires& m) {
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(3 * m.face.size());
  for (size_t i = 0; i < m.face.size(); ++i) {
    double u = m.u[i], v = m.v[i];
    detail::clamp_to_triangle(u, v);
    const double w[3] = {1.0 - u - v, u, v};
    for (int c = 0; c < 3; ++c) t.emplace_back(static_cast<int>(i), m.faces(m.face[i], c), w[c]);
  }
  RowSparse Phi(m.n_vertices(), m.base.rows());
  Phi.setFromTriplets(t.begin(), t.end());
  return Phi;
}

/// (Re)computes the foot points and the per-vertex frame data of m from its fine
/// mesh and base (after the base changed: fitting).
inline void set_foot_points(Multires& m, bool exact_foot_points, int threads = 0) {
  const Index n = m.fine.rows();
  const RowMatrixX3i& F = m.faces;
  const RowMatrixX3d NS = vertex_normals(m.base, F, threads);
  const std::vector<FootPoint> fp = foot_points(m.fine, m.base, NS, F, exact_foot_points, threads);
  for (int a = 0; a < 3; ++a) {
    m.foot[a].resize(n);
    m.su[a].resize(n);
    m.sv[a].resize(n);
  }
  for (auto& c : m.coef) c.resize(n);
  m.d.resize(n);
  m.face.resize(n);
  m.u.resize(n);
  m.v.resize(n);
  m.residual.resize(n);
  m.exact.resize(n);
  for (Index i = 0; i < n; ++i)
    VPFFD_CHECK(m.rest_normals.row(i).squaredNorm() > 0, "Multires: the area-weighted normal of vertex ", i,
                " vanishes (its triangles cancel out), so it has no tangent plane");
  // An exact foot point must also meet the tolerance of fitting.h (it does to
  // rounding where Newton converged; this keeps the flag honest).
  const double tol = kFootPointTolerance * (m.fine.colwise().maxCoeff() - m.fine.colwise().minCoeff()).norm();
  parallel_range(n, threads, [&](Index b, Index e) {
    for (Index i = b; i < e; ++i) {
      const FootPoint& f = fp[i];
      const Vector3d s0 = m.base.row(F(f.face, 0));
      Vector3d su = m.base.row(F(f.face, 1)).transpose() - s0;
      Vector3d sv = m.base.row(F(f.face, 2)).transpose() - s0;
      const bool exact = f.exact && f.residual <= tol;
      const Vector3d p = m.fine.row(i);
      double residual = f.residual;
      Vector3d foot;
      double d;
      if (exact || !exact_foot_points) {
        // The foot point as the frame stores it: p - d N_S, S(t) itself where it is
        // exact (to rounding); in the affine mode the planar projection.
        d = f.d;
        foot = p - d * f.normal;
        // Tangents of the plane normal to N_S: unit(S_u x S_v) = N_S, so a frame's
        // deformed normal is the image of N_S (cof(J) N_S). (For the affine mode
        // N_S is the face normal and this changes nothing.)
        su -= su.dot(f.normal) * f.normal;
        sv -= sv.dot(f.normal) * f.normal;
      } else {
        // The residual reported is the documented one whichever fallback gave the
        // foot point: how far p - S(u, v) misses the interpolated normal there.
        const Vector3d n0 = NS.row(F(f.face, 0)), n1 = NS.row(F(f.face, 1)), n2 = NS.row(F(f.face, 2));
        const Vector3d nt = n0 + f.u * (n1 - n0) + f.v * (n2 - n0);
        const Vector3d r = p - (s0 + f.u * su + f.v * sv);
        // (An extrapolated affine parameter can cancel the normals: then all of r misses.)
        residual = nt.norm() > 0 ? (r - r.dot(nt.normalized()) * nt.normalized()).norm() : r.norm();
        // No exact foot point: the vertex is its own foot point (d = 0) in the
        // tangent plane of its own normal, so a frame moves it by the base
        // deformation itself (an FFD: D(p), normal cof(J) n). Its neighbours' short
        // fitted displacements move almost alike, so nothing tears or turns; a
        // displacement measured from a foot point that is not one would point
        // elsewhere than theirs.
        d = 0;
        foot = p;
        detail::tangent_frame(m.rest_normals.row(i).transpose().normalized(), su, sv);
      }
      const NormalCoefficients c = normal_coefficients(su, sv, m.rest_normals.row(i).transpose());
      for (int a = 0; a < 3; ++a) {
        m.foot[a][i] = foot[a];
        m.su[a][i] = su[a];
        m.sv[a][i] = sv[a];
      }
      for (int k = 0; k < 6; ++k) m.coef[k][i] = c[k];
      m.d[i] = d;
      m.face[i] = f.face;
      m.u[i] = f.u;
      m.v[i] = f.v;
      m.residual[i] = residual;
      m.exact[i] = exact ? 1 : 0;
    }
  });
}

/// Shortens the displacements that a shear would turn over (lift.h): d becomes
/// (1 - w) d and the stored foot point p - d N_S moves with it, so identity and rigid
/// motions still rebuild every vertex exactly.
inline void lift_displacements(Multires& m, int threads = 0) {
  const Index n = m.n_vertices();
  RowMatrixX3d NS(n, 3);
  for (Index i = 0; i < n; ++i) NS.row(i) = m.tangent_u(i).cross(m.tangent_v(i)).normalized().transpose();
  m.lift = lift_fractions(m.fine, m.faces, NS, m.d, threads);
  for (Index i = 0; i < n; ++i) {
    if (!(m.lift[i] > 0)) continue;
    const double delta = (1.0 - m.lift[i]) * m.d[i];
    for (int a = 0; a < 3; ++a) m.foot[a][i] = m.fine(i, a) - delta * NS(i, a);
    m.d[i] = delta;
  }
}

/// decompose's stages: "faired base", "fit round k", "lift"; the figure is RMS |d|.
using DecomposeProgress = StageProgress;

/// Decomposes (V, F): base S = fair_mesh(V, F, smoothing), foot points, frame data.
/// @param[in] V  #V x 3 fine vertices; F #F x 3 triangles (any mesh; volume modes
///               need a closed one and check it themselves)
/// @param[in] exact_foot_points  true: exact foot points on the base with its
///               interpolated vertex normals (foot_points.h), the affine frame of a
///               one-ring triangle only where none is found; false: the affine frame
///               for every vertex
/// @throws InvalidInputError for a bad mesh or smoothing, a vertex in no triangle,
///         a vertex whose area-weighted normal vanishes, or a failed foot-point search
/// @param[in] lift  shorten the displacements that a shear would turn over
///               (lift_displacements; exact foot points only)
/// @param[in] progress  called after each stage (may be empty); what it throws
///               propagates
inline Multires decompose(const Eigen::Ref<const RowMatrixX3d>& V, const Eigen::Ref<const RowMatrixX3i>& F,
                          double smoothing, int threads = 0, bool exact_foot_points = true, int fit_rounds = 4,
                          double fairness = 100.0, bool lift = true, const DecomposeProgress& progress = {}) {
  VPFFD_CHECK(fit_rounds >= 0 && fit_rounds <= 100, "Multires: fit rounds must be in 0..100, got ", fit_rounds);
  VPFFD_CHECK(std::isfinite(fairness) && fairness > 0, "Multires: fairness must be a positive number, got ",
              fairness);
  Multires m;
  m.fine = V;
  m.faces = F;
  m.smoothing = smoothing;
  m.base = fair_mesh(V, F, smoothing, threads);
  m.rest_normals = vertex_normals(V, F, threads);
  set_foot_points(m, exact_foot_points, threads);
  m.rms_displacement.push_back(detail::rms(m.d));
  const bool lifting = lift && exact_foot_points;
  const int stages = 1 + fit_rounds + (lifting ? 1 : 0);
  if (progress) progress("faired base", 1, stages, m.rms_displacement.back());
  if (fit_rounds > 0) {
    m.fairness = fairness;
    const Eigen::SparseMatrix<double> K = umbrella_fairness(F, V.rows());
    // Vertices still without an exact foot point pull 4x harder each round: the
    // base comes closer to them until their displacement fits inside the region
    // where the base's normals do not cross (the fit's purpose, §4.1).
    VectorXd w = VectorXd::Ones(V.rows());
    for (int round = 0; round < fit_rounds; ++round) {
      for (Index i = 0; i < V.rows(); ++i)
        if (exact_foot_points && !m.exact[i]) w[i] = std::min(w[i] * 4.0, 1e4);
      m.base = fit_control_points(foot_point_weights(m), V, K, fairness, m.base, threads, nullptr, &w);
      set_foot_points(m, exact_foot_points, threads);
      m.rms_displacement.push_back(detail::rms(m.d));
      if (progress) progress(("fit round " + std::to_string(round + 1)).c_str(), round + 2, stages, m.rms_displacement.back());
    }
  }
  if (lifting) {
    lift_displacements(m, threads);
    if (progress) progress("lift", stages, stages, detail::rms(m.d));
  }
  return m;
}

}  // namespace vpffd
