#pragma once
/// @file frame_passes.h
/// The passes a CPU frame is made of, as functions of (topology, rest state, inputs):
/// plain FFD, Jacobians, coefficient passes, gathers, the reorder into the caller's
/// vertex order. They read nothing but their arguments (frame/frame_loop.h strings
/// them together).

#include <algorithm>
#include <vector>

#include "vpffd/correction/options.h"
#include "vpffd/correction/plan.h"
#include "vpffd/ffd/kernels.h"
#include "vpffd/ffd/normals.h"
#include "vpffd/ffd/points.h"
#include "vpffd/frame/rest_state.h"
#include "vpffd/lattice/periodic.h"
#include "vpffd/volume/coefficients.h"
#include "vpffd/volume/part_coefficients.h"

namespace vpffd::frame {

inline void check_control_points(const FrameTopology& t, const Eigen::Ref<const RowMatrixX3d>& P, const char* where) {
  VPFFD_CHECK(P.rows() == t.ties.n_distinct, where, ": ", P.rows(), " control points, the lattice has ",
              t.ties.n_distinct);
  VPFFD_CHECK(P.allFinite(), where, ": control points contain NaN or Inf");
}

/// The FFD of the vertices into out: row i is processing position i, or vertex
/// rows[i] when rows is given (the order: the caller's order, without a reordering
/// pass). Coordinate `skip` (0-2; -1 none) is written as 0 (see first_step_sets).
inline void eval_ffd(const FrameTopology& t, const RestState& s, const Eigen::Ref<const RowMatrixX3d>& P, double* out,
                     int threads, const std::int32_t* rows = nullptr, int skip = -1) {
  const PointColumns Q(expand_points(t.ties, P));
  const BasisTables& T = t.tables;
  parallel_range(t.n_vertices, threads, [&](Index b, Index e) {
    detail::dispatch_order(T, [&](auto K) {
      constexpr int k = decltype(K)::value;
      if constexpr (k > 0)
        detail::ffd_runs<k>(T, s.embedding, s.runs, Q.x.data(), Q.y.data(), Q.z.data(), out, b, e, rows, skip);
      else
        detail::ffd_kernel<k>(T, s.embedding, Q.x.data(), Q.y.data(), Q.z.data(), out, b, e, rows, skip);
    });
    if (s.seam_shift.rows() > 0)
      for (Index i = b; i < e; ++i)
        for (int c = 0; c < 3; ++c) out[3 * (rows ? Index(rows[i]) : i) + c] += s.seam_shift(i, c);
  });
}

/// Whether a volume-preserving frame may take an axis step's volume from the step's
/// coefficients instead of summing it over the vertices: the vertices' `a`
/// coordinates are B P_a (P_a the current control points' `a` coordinates, the
/// tied copies included), so V = sum_v w_v (x_v - o) = sum_c alpha_c (P_a,c - o)
/// (alpha = B^T w; the B_c sum to 1). The coefficient pass then reads no `a`
/// coordinates (one stream of X fewer: the dragon's three coefficient passes 0.97x
/// on 1 and 2 threads, bench_frame alternated three times). Not where a
/// "shift" seam adds per-vertex translations to the FFD (x is then not B P), nor
/// for the CSR method (its volume is a face pass over X). The last step still sums
/// over the vertices: its volume decides what the frame ends at, and the vertex sum
/// carries no rounding of the whole volume through alpha (the result stays within
/// a few ulps of the target, as before).
inline bool volume_by_coefficients(const FrameTopology& t, const RestState& s, const CorrectionOptions& opt) {
  return s.seam_shift.rows() == 0 && (t.parts.count > 1 || opt.method == CoefficientMethod::Traversal);
}

/// The axis whose coordinate a volume-preserving frame's plain FFD leaves out, or -1.
/// The first axis step's weights do not read that step's own coordinate (a vertex's
/// weight for x is a sum of 2x2 determinants in y and z), so the FFD computes only
/// the other two; the step's volume comes from its coefficients
/// (volume_by_coefficients), and its gather sets the coordinate to B (P + delta) at
/// once. That saves a third of the FFD. Not for a one-step frame, whose only volume
/// is summed over the vertices.
inline int first_step_sets(const FrameTopology& t, const RestState& s, const FramePlan& pl,
                           const CorrectionOptions& opt) {
  if (!pl.correcting || !opt.preserve_volume || opt.axes.size() * opt.rounds < 2) return -1;
  return volume_by_coefficients(t, s, opt) ? opt.axes[0] : -1;
}

/// The field an axis step's gather adds along its axis: the offsets delta (distinct
/// points), extended to the tied copies; where the FFD left that coordinate at 0
/// (`sets`, first_step_sets), the corrected points themselves, Pa + delta (Pa the
/// step's extended control point coordinates).
inline VectorXd gather_field(const FrameTopology& t, const VectorXd& delta, const VectorXd& Pa, bool sets) {
  VectorXd field = expand_offsets(t.ties, delta);
  if (sets) field += Pa;
  return field;
}

/// Calls f(v, j) for every vertex v (caller index) with j its Jacobian dD/dx (9,
/// row-major; at a twist seam's wrapped points that of the wrapped twin, see
/// unmirror_jacobian), computed in blocks of the processing order in a small buffer
/// (no #V x 9 array). f may change j; it runs on the frame's threads.
template <class F>
void for_each_jacobian(const FrameTopology& t, const RestState& s, const Eigen::Ref<const RowMatrixX3d>& P,
                       int threads, F&& f) {
  const PointColumns Q(expand_points(t.ties, P));
  const Vector3d scale = parameter_scale(t.lattice);
  const std::vector<std::int32_t>& order = *s.order;
  parallel_range(t.n_vertices, threads, [&](Index b, Index e) {
    constexpr Index kBlock = 256;
    std::vector<double> J(9 * kBlock);
    for (Index c = b; c < e; c += kBlock) {
      const Index ce = std::min(e, c + kBlock);
      detail::jacobian_kernel(t.tables, s.embedding, s.runs, Q.x.data(), Q.y.data(), Q.z.data(), scale, J.data(), c,
                              ce, c);
      for (Index i = c; i < ce; ++i) f(Index(order[i]), J.data() + 9 * (i - c));
    }
  });
}

/// Rows of Xs (processing order) back in the caller's vertex order. Each row read
/// from where it is (rank) and written in sequence: written where it goes instead,
/// the scattered stores cost twice as much (dragon, 1 thread, fused into the last
/// gather: 5.4-5.9 ms for that gather against 3.6-4.0 for the gather and this copy).
inline void to_caller_order(const RestState& s, const RowMatrixX3d& Xs, double* dst, int threads) {
  const double* src = Xs.data();
  const std::vector<std::int32_t>& rank = *s.rank;
  parallel_range(Xs.rows(), threads, [&](Index b, Index e) {
    for (Index v = b; v < e; ++v) {
      const double* p = src + 3 * Index(rank[v]);
      dst[3 * v] = p[0];
      dst[3 * v + 1] = p[1];
      dst[3 * v + 2] = p[2];
    }
  });
}

inline void gather(const FrameTopology& t, const RestState& s, const VectorXd& D, double* X, int axis, int threads) {
  parallel_range(t.n_vertices, threads, [&](Index b, Index e) {
    detail::dispatch_order(t.tables, [&](auto K) {
      constexpr int k = decltype(K)::value;
      if constexpr (k > 0)
        detail::gather_runs<k>(t.tables, s.embedding, s.runs, D.data(), X, axis, b, e);
      else
        detail::gather_kernel<k>(t.tables, s.embedding, D.data(), X, axis, b, e);
    });
  });
}

/// The last gather of a frame (gather_final_kernel): moves X along `axis` by the
/// offset field D and returns each part's volume (one entry without parts), summed
/// over the part's pieces (its vertices cut at the fixed chunk boundaries,
/// detail::part_pieces) in order: the same bits for any thread count.
inline VectorXd gather_final(const FrameTopology& t, const RestState& s, const VectorXd& D, double* X, int axis,
                             const double* w, int threads) {
  const std::vector<detail::PartPiece> pieces = detail::part_pieces(t.part_start, t.n_vertices);
  std::vector<double> sums(pieces.size(), 0.0);
  const double o = t.origin[axis];
  parallel_items(Index(pieces.size()), t.n_vertices, threads, [&](Index q) {
    const Index b = pieces[q].b, e = pieces[q].e;
    detail::dispatch_order(t.tables, [&](auto K) {
      constexpr int k = decltype(K)::value;
      if constexpr (k > 0)
        sums[q] = detail::gather_final_runs<k>(t.tables, s.embedding, s.runs, D.data(), X, axis, w, o, b, e);
      else
        sums[q] = detail::gather_final_kernel<k>(t.tables, s.embedding, D.data(), X, axis, w, o, b, e);
    });
  });
  VectorXd out = VectorXd::Zero(Index(t.part_start.size()) - 1);
  for (size_t q = 0; q < pieces.size(); ++q) out[pieces[q].part] += sums[q];
  return out;
}

/// The paper's matrix holds the projection form, which on an open surface differs
/// from the cone volume that is measured and kept.
inline void check_method(const FrameTopology& t, CoefficientMethod method) {
  if (!t.closed())
    VPFFD_CHECK(method == CoefficientMethod::Traversal,
                "deform: method='csr' needs a closed mesh; use method='traversal' with allow_open");
}

/// Volume coefficients of `axis` for X (processing order). `weights` (#V, may be
/// null) receives the traversal's per-vertex weights; `measure` false: the traversal
/// leaves the volume 0 (coefficients_fans).
inline AxisCoefficients coefficients(const FrameTopology& t, const RestState& s, const double* X, int axis,
                                     CoefficientMethod method, int threads, double* weights = nullptr,
                                     bool measure = true) {
  check_method(t, method);
  if (method == CoefficientMethod::Csr)
    return coefficients_csr(face_matrix(t, s, threads), X, processing_faces(t, s), axis, t.origin, threads);
  const WeightAdjacency& adj = weight_adjacency(t, s, threads);
  if (t.closed())
    return coefficients_fans(t.tables, s.embedding, adj.fans, X, axis, t.origin, threads, weights, &s.runs,
                             adj.weight_order.data(), measure);
  return coefficients_rings(t.tables, s.embedding, adj.rings, X, axis, t.origin, threads, true, weights, &s.runs,
                            measure);
}

}  // namespace vpffd::frame
