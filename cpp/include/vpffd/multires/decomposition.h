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
#include "vpffd/ffd/normals.h"
#include "vpffd/multires/fairing.h"
#include "vpffd/multires/foot_points.h"
#include "vpffd/multires/normal_coefficients.h"

namespace vpffd {

/// The decomposition: base mesh, foot points and the per-vertex frame data.
struct Multires {
  RowMatrixX3d fine;     ///< #V x 3 rest fine vertices
  RowMatrixX3i faces;    ///< #F x 3 triangles (fine and base)
  RowMatrixX3d base;     ///< #V x 3 base vertices
  RowMatrixX3d rest_normals;  ///< #V x 3 unit area-weighted normals of the fine mesh
  double smoothing = 0;  ///< fair_mesh's diffusion time

  // Frame data (SoA), one entry per vertex.
  std::array<std::vector<double>, 3> foot;  ///< S(t_i) = s0 + u S_u + v S_v
  std::array<std::vector<double>, 3> su;    ///< S_u of the foot triangle
  std::array<std::vector<double>, 3> sv;    ///< S_v of the foot triangle
  std::vector<double> d;                    ///< signed normal displacement
  std::array<std::vector<double>, 6> coef;  ///< a_u, b_u, g_u, a_v, b_v, g_v

  // Foot-point bookkeeping (not read by a frame).
  std::vector<std::int32_t> face;  ///< base triangle of each vertex
  std::vector<double> u, v;        ///< affine coordinates in it
  std::vector<double> residual;    ///< world distance of S(u, v) outside its triangle (0 inside)

  Index n_vertices() const { return fine.rows(); }
  /// Bytes one frame reads per vertex (the SoA arrays above): 128.
  static constexpr int frame_bytes_per_vertex = 16 * sizeof(double);
  /// Per-vertex data kept: frame data, foot bookkeeping (4 + 3 doubles), and the
  /// fine, base and rest-normal rows (9 doubles): 128 + 28 + 72 = 228 bytes.
  static constexpr int bytes_per_vertex = frame_bytes_per_vertex + sizeof(std::int32_t) + 3 * sizeof(double) +
                                          9 * sizeof(double);
  /// Fraction of the vertices whose affine foot point lies outside its triangle.
  double extrapolated_fraction() const {
    Index n = 0;
    for (double r : residual) n += r > 0;
    return n_vertices() ? double(n) / double(n_vertices()) : 0.0;
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

/// Decomposes (V, F): base S = fair_mesh(V, F, smoothing), foot points, frame data.
/// @param[in] V  #V x 3 fine vertices; F #F x 3 triangles (any mesh; volume modes
///               need a closed one and check it themselves)
/// @throws InvalidInputError for a bad mesh or smoothing, a vertex in no triangle,
///         a vertex whose area-weighted normal vanishes, or a failed foot-point search
inline Multires decompose(const Eigen::Ref<const RowMatrixX3d>& V, const Eigen::Ref<const RowMatrixX3i>& F,
                          double smoothing, int threads = 0) {
  Multires m;
  m.fine = V;
  m.faces = F;
  m.smoothing = smoothing;
  m.base = fair_mesh(V, F, smoothing, threads);
  m.rest_normals = vertex_normals(V, F, threads);
  const std::vector<FootPoint> fp = foot_points(V, m.base, F, threads);
  const Index n = V.rows();
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
  for (Index i = 0; i < n; ++i)
    VPFFD_CHECK(m.rest_normals.row(i).squaredNorm() > 0, "Multires: the area-weighted normal of vertex ", i,
                " vanishes (its triangles cancel out), so it has no tangent plane");
  parallel_range(n, threads, [&](Index b, Index e) {
    for (Index i = b; i < e; ++i) {
      const FootPoint& f = fp[i];
      const Vector3d s0 = m.base.row(F(f.face, 0));
      const Vector3d su = m.base.row(F(f.face, 1)).transpose() - s0;
      const Vector3d sv = m.base.row(F(f.face, 2)).transpose() - s0;
      const Vector3d foot = s0 + f.u * su + f.v * sv;
      const NormalCoefficients c = normal_coefficients(su, sv, m.rest_normals.row(i).transpose());
      for (int a = 0; a < 3; ++a) {
        m.foot[a][i] = foot[a];
        m.su[a][i] = su[a];
        m.sv[a][i] = sv[a];
      }
      for (int k = 0; k < 6; ++k) m.coef[k][i] = c[k];
      m.d[i] = f.d;
      m.face[i] = f.face;
      m.u[i] = f.u;
      m.v[i] = f.v;
      m.residual[i] = f.residual;
    }
  });
  return m;
}

}  // namespace vpffd
