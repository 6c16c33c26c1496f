#pragma once
/// @file part_coefficients.h
/// The volume coefficients of one axis for each part of a mesh made of several
/// closed parts (mesh/parts.h): K rows alpha_k with V_k + alpha_k . delta the
/// volume of part k after moving the control points by delta along that axis.
///
/// The vertices must be in processing order with each part's vertices contiguous,
/// [part_start[k], part_start[k+1]). Since every face lies in one part, a vertex's
/// weight (coefficients_rings) is a derivative of its own part's volume only, and
/// part k's coefficients are the scatter of its own vertices' weights.

#include <vector>

#include "vpffd/volume/coefficients.h"

namespace vpffd {

/// Coefficients and current volumes of the K parts, computed together.
struct PartCoefficients {
  RowMatrixXd alpha;  ///< K x N, row k the coefficients of part k
  VectorXd volume;    ///< K part volumes
};

namespace detail {

/// A range of one part's vertices within one of the fixed chunks of a vertex pass.
struct PartPiece {
  int part;
  Index b, e;
};

/// The parts [part_start[k], part_start[k+1]) cut at the boundaries of the
/// chunk_count(nv) chunks of [0, nv), in order. With one part these are the chunks.
inline std::vector<PartPiece> part_pieces(const std::vector<Index>& part_start, Index nv) {
  const int K = static_cast<int>(part_start.size()) - 1;
  const int chunks = chunk_count(nv);
  std::vector<PartPiece> pieces;
  for (int k = 0; k < K; ++k) {
    Index b = part_start[k];
    while (b < part_start[k + 1]) {
      int c = static_cast<int>(std::min<Index>((b * chunks) / nv, chunks - 1));
      while (nv * (c + 1) / chunks <= b) ++c;  // the chunk that holds b
      const Index e = std::min(part_start[k + 1], nv * (c + 1) / chunks);
      pieces.push_back({k, b, e});
      b = e;
    }
  }
  return pieces;
}

}  // namespace detail

/// One pass over the vertices as coefficients_fans (closed parts, b = p_v). The
/// work is split at part boundaries and at the usual fixed chunk boundaries; each
/// piece scatters into its own buffer (a part in one piece into its row directly)
/// and the pieces are summed in order: same result for any thread count.
/// @param part_start  K + 1 offsets into the processing order
/// @param runs  if not null, E's cell runs (as coefficients_rings)
/// @param row_vertex  if not null, fan row -> vertex (as coefficients_fans)
/// @param weights  if not null, #V: receives the w_v (else a buffer is allocated)
/// @param measure  false: the volumes are left 0 and the `axis` coordinates not read
///                 (as coefficients_fans)
inline PartCoefficients part_coefficients_rings(const BasisTables& T, const Embedding& E, const PaddedFans& fans,
                                                const double* X, int axis, const Vector3d& origin,
                                                const std::vector<Index>& part_start, int threads = 0,
                                                const CellRuns* runs = nullptr,
                                                const std::int32_t* row_vertex = nullptr,
                                                double* weights = nullptr, bool measure = true) {
  const Index nv = E.size();
  const Index N = Index(T.dims[0]) * T.dims[1] * T.dims[2];
  const int K = static_cast<int>(part_start.size()) - 1;
  VPFFD_CHECK(K >= 1 && part_start.back() == nv, "part_coefficients_rings: part offsets do not cover the ", nv,
              " vertices");
  struct Piece {
    int part;
    Index b, e;
    double* acc;
    double volume = 0;
  };
  // Pieces: each part cut at the multiples of the whole pass's chunk size.
  std::vector<Piece> pieces;
  std::vector<int> pieces_of(K, 0);
  for (const detail::PartPiece& p : detail::part_pieces(part_start, nv)) {
    pieces.push_back({p.part, p.b, p.e, nullptr});
    ++pieces_of[p.part];
  }
  PartCoefficients out;
  out.alpha = RowMatrixXd::Zero(K, N);
  size_t extra = 0;
  for (const Piece& p : pieces) extra += pieces_of[p.part] > 1;
  std::vector<double> buf(extra * N, 0.0);
  size_t next = 0;
  for (Piece& p : pieces)
    p.acc = pieces_of[p.part] > 1 ? buf.data() + (next++) * N : out.alpha.row(p.part).data();

  const double o = origin[axis];
  std::vector<double> own(weights ? 0 : nv);  // the weights first, row by row (coefficients_fans)
  double* wv = weights ? weights : own.data();
  // Axis and `measure` as compile-time constants (weighted_scatter).
  auto pieces_pass = [&](auto axis_c, auto measure_c) {
    constexpr int ax = decltype(axis_c)::value;
    detail::fan_weights<ax>(X, fans, row_vertex, wv, threads);
    parallel_items(Index(pieces.size()), nv, threads, [&](Index q) {
      Piece& piece = pieces[q];
      double vsum = 0;
      auto weight = [&](Index v) {
        const double w = wv[v];
        if constexpr (decltype(measure_c)::value) vsum += (X[3 * v + ax] - o) * w;
        return w;
      };
      detail::scatter(T, E, runs, weight, piece.acc, piece.b, piece.e);
      piece.volume = vsum;
    });
  };
  detail::with_axis(axis, [&](auto axis_c) {
    if (measure)
      pieces_pass(axis_c, std::true_type{});
    else
      pieces_pass(axis_c, std::false_type{});
  });

  out.volume = VectorXd::Zero(K);
  for (const Piece& p : pieces) {
    out.volume[p.part] += p.volume;
    if (pieces_of[p.part] > 1)
      Eigen::Map<VectorXd>(out.alpha.row(p.part).data(), N) += Eigen::Map<const VectorXd>(p.acc, N);
  }
  return out;
}

/// Volume of each part: the signed volume of its faces, which are contiguous in
/// processing order, [face_start[k], face_start[k+1]) of `F`.
inline VectorXd part_volumes(const double* X, const Eigen::Ref<const RowMatrixX3i>& F,
                             const std::vector<Index>& face_start, const Vector3d& origin, int threads = 0) {
  const int K = static_cast<int>(face_start.size()) - 1;
  VectorXd vol(K);
  for (int k = 0; k < K; ++k)
    vol[k] = signed_volume(X, F.middleRows(face_start[k], face_start[k + 1] - face_start[k]), origin, threads);
  return vol;
}

/// The same for vertices in any row stride (a strided view is copied once).
inline VectorXd part_volumes(const Eigen::Ref<const RowMatrixX3d>& X, const Eigen::Ref<const RowMatrixX3i>& F,
                             const std::vector<Index>& face_start, const Vector3d& origin, int threads = 0) {
  if (X.rows() > 1 && X.outerStride() != 3) return part_volumes(RowMatrixX3d(X).data(), F, face_start, origin, threads);
  return part_volumes(X.data(), F, face_start, origin, threads);
}

}  // namespace vpffd
