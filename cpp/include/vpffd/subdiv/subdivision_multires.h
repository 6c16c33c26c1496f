#pragma once
/// @file subdivision_multires.h
/// Displaced subdivision surfaces (paper 002, §5): a fine triangle mesh M as the
/// limit surface S of a coarse control mesh (Loop or Catmull-Clark) plus a normal
/// displacement per fine vertex, p_i = S(t_i) + d_i N_S(t_i), with t_i an exact foot
/// point (p_i - S(t_i) parallel to N_S(t_i), eq. 1).
///
/// S, S_u and S_v at every t_i are linear in the control points C (M x 3): their
/// weights (limit stencils, eq. 8) are computed once, so a frame with new control
/// points C' is one pass over the fine vertices that reads no connectivity
/// (subdivision_frame.h). Everything here is plain arrays: OpenSubdiv, which the
/// decomposition uses, is confined to the compiled part vpffd::subdiv
/// (cpp/src/subdiv), so this header and the frame are free of it.

#include <array>
#include <cstdint>
#include <utility>
#include <vector>

#include "vpffd/core/types.h"
#include "vpffd/core/progress.h"
#include "vpffd/multires/normal_coefficients.h"

namespace vpffd {

/// Subdivision scheme of the base surface. Loop needs a triangle control mesh;
/// Catmull-Clark takes triangles and quads (a triangle is split into three quad
/// sub-patches of the limit surface).
enum class SubdivScheme { Loop, CatmullClark };

/// Options of decompose_subdivision.
struct SubdivOptions {
  SubdivScheme scheme = SubdivScheme::Loop;
  /// Relative fairness weight lambda of fit_control_points (multires/fitting.h), with
  /// K = L^T L of the control mesh's uniform Laplacian. >= 0.
  double fairness = 1e-3;
  /// Rounds of (foot points, control-point fit); 0 keeps the control points given.
  int iterations = 2;
  /// OpenSubdiv's approximation level of the limit surface around irregular
  /// features (extraordinary vertices): its default of 2 differs from the exact limit
  /// by ~1e-3 of the patch size there; 6 is below 1e-6 of it.
  int approx_level = 6;
  /// Fine vertices allowed to have no exact foot point; more is an InvalidInputError
  /// that says how many and which. Accepted ones keep the best point found and
  /// their tangential residual in `residual` (their identity frame misses p_i by
  /// about that much).
  Index max_unresolved = 0;
  int threads = 0;
  /// Called after the control mesh is decimated (when it is), after the first foot
  /// points and after each fit round; the figure is RMS |p - S| (0 for decimation).
  StageProgress progress;
  /// Stages already reported before this decomposition (internal: 1 after decimation).
  int progress_offset = 0;
};

/// Weights of S, S_u and S_v over the control points at each fine vertex's foot
/// point (CSR, one row per fine vertex, the three share the sparsity):
/// S(t_i) = sum_k w[k] C[indices[k]] for k in [indptr[i], indptr[i+1]).
struct LimitStencils {
  std::vector<std::int64_t> indptr;   ///< #V + 1
  std::vector<std::int32_t> indices;  ///< control point of each weight
  std::vector<double> w, wu, wv;      ///< position, d/du, d/dv weights (w sums to 1)
  Index rows() const { return indptr.empty() ? 0 : Index(indptr.size()) - 1; }
  Index nnz() const { return Index(indices.size()); }
};

/// The decomposition. Parameters t_i = (patch, u, v): `patch` counts the control
/// faces' limit patches in face order (one per Loop triangle or Catmull-Clark quad,
/// three per Catmull-Clark triangle: its normalised sub-faces, which are Ptex faces),
/// (u, v) in [0,1]^2 (quads) or the unit triangle u, v >= 0, u + v <= 1 (Loop).
struct SubdivisionMultires {
  SubdivScheme scheme = SubdivScheme::Loop;
  RowMatrixX3d fine;          ///< #V x 3 rest fine vertices
  RowMatrixX3i faces;         ///< #F x 3 fine triangles
  RowMatrixX3d rest_normals;  ///< #V x 3 unit area-weighted normals of the fine mesh
  double diagonal = 0;        ///< bounding-box diagonal of the fine mesh, world units

  RowMatrixX3d control_points;                   ///< M x 3 fitted control points C0
  std::vector<std::int32_t> control_face_sizes;  ///< 3 or 4 per control face
  std::vector<std::int32_t> control_faces;       ///< their vertices, concatenated

  // Per fine vertex.
  std::vector<std::int32_t> patch;          ///< limit patch of the foot point
  std::vector<double> u, v;                 ///< its parameters in the patch
  std::vector<double> d;                    ///< signed displacement along N_S, world units
  std::vector<double> residual;             ///< tangential residual |(p - S) x N_S|, world units
  std::array<std::vector<double>, 6> coef;  ///< a_u, b_u, g_u, a_v, b_v, g_v (eqs. 6-7)
  LimitStencils stencils;

  // What the decomposition did.
  std::vector<std::int32_t> unresolved;  ///< vertices with residual > kFootPointTolerance * diagonal
  double rms_initial = 0;  ///< RMS |p_i - S(t_i)| on the initial control mesh, world units
  double rms_final = 0;    ///< the same after the fit (the RMS of d)
  std::vector<double> rms_rounds;  ///< after each fitting round's foot-point update
  double seconds = 0;              ///< decomposition wall time (decimation included)

  Index n_vertices() const { return fine.rows(); }
  Index n_control() const { return control_points.rows(); }
  /// Bytes a frame reads per fine vertex: the stencils (3 weights + an index per
  /// entry, 28 bytes, ~12-20 entries), the row pointer (8), d (8) and the
  /// coefficients (48).
  double frame_bytes_per_vertex() const {
    const Index n = n_vertices();
    if (n == 0) return 0;
    return double(stencils.nnz()) * (3 * sizeof(double) + sizeof(std::int32_t)) / double(n) +
           sizeof(std::int64_t) + 7 * sizeof(double);
  }
};

/// Decomposes the fine mesh (V, F) over the given control mesh.
/// @param[in] V  #V x 3 fine vertices; F #F x 3 triangles (manifold, consistently
///               oriented; boundaries allowed)
/// @param[in] CV M x 3 initial control points
/// @param[in] face_sizes, face_vertices  the control polygons (3 for Loop; 3 or 4
///               for Catmull-Clark), vertices counter-clockwise seen from outside
/// @throws InvalidInputError for a bad mesh or control mesh (a non-manifold or
///         misoriented edge, a face of the wrong size, an index out of range, a
///         control point in no face), bad options, or more than
///         options.max_unresolved vertices without an exact foot point
SubdivisionMultires decompose_subdivision(const Eigen::Ref<const RowMatrixX3d>& V,
                                          const Eigen::Ref<const RowMatrixX3i>& F,
                                          const Eigen::Ref<const RowMatrixX3d>& CV,
                                          const std::vector<std::int32_t>& face_sizes,
                                          const std::vector<std::int32_t>& face_vertices,
                                          const SubdivOptions& options = {});

/// The same with a control mesh made by decimating (V, F) to about
/// `control_vertices` vertices (quadric error, no normal flips; OpenMesh).
SubdivisionMultires decompose_subdivision(const Eigen::Ref<const RowMatrixX3d>& V,
                                          const Eigen::Ref<const RowMatrixX3i>& F, Index control_vertices,
                                          const SubdivOptions& options = {});

/// A control triangle mesh of about `target` vertices by decimating (V, F) with
/// OpenMesh's quadric error and normal-flip modules (halfedge collapses: the
/// control points are a subset of the fine vertices).
/// @returns the control points and their triangles
std::pair<RowMatrixX3d, RowMatrixX3i> decimate_mesh(const Eigen::Ref<const RowMatrixX3d>& V,
                                                    const Eigen::Ref<const RowMatrixX3i>& F, Index target);

}  // namespace vpffd
