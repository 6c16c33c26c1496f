#pragma once
/// @file rest_state.h
/// Everything a deformer's frame reads that depends on where the rest mesh is: the
/// rest positions, the processing order, the embedding and its cell runs, and what is
/// derived from them. One RestState is immutable once a deformer publishes it; a move
/// of the rest mesh (frame/rest_moves.h) builds a new one, sharing what did not change,
/// and the deformer swaps it in (frame/deformer.h). A frame holds one state from its
/// plan to its result, so it sees the rest mesh before a move or after it, never a mix.
///
/// Some members are read by few frames and built on their first read (core/lazy.h):
/// the faces renumbered by processing position and their vertex-face lists (CSR and
/// face frames), the face matrix (method="csr"), the rest volumes (frames that keep
/// the rest volume), and the fans or rings the weight passes read, relabelled from
/// the last state that built them (volume-preserving frames). States with the same
/// processing order share the first two and the fans; offset moves (translations)
/// share the rest volumes.

#include <memory>
#include <vector>

#include "vpffd/core/lazy.h"
#include "vpffd/ffd/basis_matrix.h"
#include "vpffd/ffd/cell_runs.h"
#include "vpffd/ffd/reorder.h"
#include "vpffd/ffd/vertex_order.h"
#include "vpffd/frame/rest_volume.h"
#include "vpffd/frame/topology.h"
#include "vpffd/mesh/padded_fans.h"
#include "vpffd/sparse/csr.h"

namespace vpffd {

/// The vertex adjacency the weight passes sum over, labelled by processing positions
/// of `order`: a closed mesh's padded fans, whose rows are stored in weight_order
/// (fan row -> processing position: the first state's cell runs, by valence within a
/// run, so that neighbouring rows have equal lengths; relabelling keeps each row's
/// vertex), or an open mesh's rings.
struct WeightAdjacency {
  PaddedFans fans;
  std::vector<std::int32_t> weight_order;
  VertexRings rings;
  std::vector<std::int32_t> order;
};

struct RestState {
  using Order = std::shared_ptr<const std::vector<std::int32_t>>;

  std::shared_ptr<const RowMatrixX3d> V;     ///< #V x 3 rest vertices, caller order
  std::shared_ptr<const RowMatrixX3d> base;  ///< set_rest_offsets' base positions (null before its first move)
  RowMatrixX3d offsets;                      ///< the last set_rest_offsets' (empty before it, and after set_rest_vertices)
  Order order;                               ///< processing position -> vertex (by part, then by cell)
  Order rank;                                ///< vertex -> processing position
  Embedding embedding;                       ///< in processing order
  CellRuns runs;                             ///< the embedding's cell runs
  RowMatrixX3d seam_shift;  ///< processing order: what "shift" seams add to wrapped vertices (or empty)

  /// The rest volumes of *volume_positions (V, or the base of an offset move: a
  /// translation keeps every closed part's volume).
  std::shared_ptr<const Lazy<RestVolumes>> volumes;
  std::shared_ptr<const RowMatrixX3d> volume_positions;

  std::shared_ptr<const Lazy<RowMatrixX3i>> faces;       ///< face_order's faces, by processing position
  std::shared_ptr<const Lazy<VertexFaces>> face_lists;   ///< vertex -> faces of `faces`
  Lazy<CsrMatrix> face_matrix;                           ///< the paper's N x F matrix (of this embedding)
  std::shared_ptr<const Lazy<std::shared_ptr<const WeightAdjacency>>> adjacency;
  /// Where `adjacency` is relabelled from: the last earlier state's that was built.
  std::shared_ptr<const WeightAdjacency> adjacency_source;
  /// Buffers of an adjacency no state reads any more (rest_moves.h's recycle), for the
  /// one build of `adjacency` to write into; read and taken only inside that build.
  mutable std::shared_ptr<WeightAdjacency> adjacency_spare;
};

/// The rest volumes of V over the topology's faces (each part's with parts).
/// @throws InvalidInputError naming `where` when they overflow double precision
inline RestVolumes measure_rest(const FrameTopology& t, const Eigen::Ref<const RowMatrixX3d>& V, int threads,
                                const char* where) {
  return measure_rest_volumes(V, t.faces, t.has_parts ? &t.part_faces : nullptr, t.face_start, t.origin, threads,
                              where);
}

/// The state's rest volumes, summed on first use.
inline const RestVolumes& rest_volumes(const FrameTopology& t, const RestState& s) {
  return s.volumes->get([&] { return measure_rest(t, *s.volume_positions, 0, "rest_volume"); });
}

/// Faces in face_order, numbered by processing position, built on first use.
inline const RowMatrixX3i& processing_faces(const FrameTopology& t, const RestState& s) {
  return s.faces->get([&] {
    RowMatrixX3i Fs(t.faces.rows(), 3);
    const std::vector<std::int32_t>& rank = *s.rank;
    parallel_range(t.faces.rows(), 0, [&](Index b, Index e) {
      for (Index f = b; f < e; ++f)
        for (int c = 0; c < 3; ++c) Fs(f, c) = rank[t.faces(t.face_order[f], c)];
    });
    return Fs;
  });
}

/// Vertex -> faces lists of processing_faces(), built on first use.
inline const VertexFaces& processing_adjacency(const FrameTopology& t, const RestState& s) {
  return s.face_lists->get([&] { return vertex_faces(processing_faces(t, s), t.n_vertices); });
}

/// The paper's N x F face matrix (columns in face_order), built on first use.
inline const CsrMatrix& face_matrix(const FrameTopology& t, const RestState& s, int threads) {
  return s.face_matrix.get([&] { return face_basis_matrix(t.tables, s.embedding, processing_faces(t, s), threads); });
}

/// The first state's adjacency: built from the faces in the mesh's own face order (so
/// the terms of a weight come in an order no move changes), in processing positions.
inline std::shared_ptr<const WeightAdjacency> build_weight_adjacency(const FrameTopology& t, const RestState& s,
                                                                     int threads) {
  auto a = std::make_shared<WeightAdjacency>();
  const Index nv = t.n_vertices;
  const std::vector<std::int32_t>& order = *s.order;
  if (t.closed()) {
    const VertexRings rings = vertex_rings(t.faces, nv);
    std::vector<std::uint8_t> valence(nv);  // the ring's faces (63 for more)
    for (Index v = 0; v < nv; ++v)
      valence[v] = static_cast<std::uint8_t>(std::min(rings.indptr[v + 1] - rings.indptr[v], 63));
    a->weight_order = order_within_runs(s.runs.start, order, valence, threads);
    std::vector<std::int32_t> row_vertex(nv);
    for (Index j = 0; j < nv; ++j) row_vertex[j] = order[a->weight_order[j]];
    a->fans = pad_fans(permute_fans(vertex_fans(rings), row_vertex, *s.rank, threads), 0, threads,
                       a->weight_order.data());
  } else {
    a->rings = permute_rings(vertex_rings(t.faces, nv), order, *s.rank, threads);
  }
  a->order = order;
  return a;
}

/// The source's adjacency relabelled into the state's processing order (entries only:
/// the fans' rows keep their vertices, so the labels are the same whichever moves lay
/// between the two states).
inline std::shared_ptr<const WeightAdjacency> relabel_weight_adjacency(const FrameTopology& t, const RestState& s,
                                                                       const WeightAdjacency& src, int threads) {
  // The state's spare buffers when it has them: a moving object's frames then do not
  // fault in fresh pages for the fans on every move.
  std::shared_ptr<WeightAdjacency> a = s.adjacency_spare ? std::move(s.adjacency_spare)
                                                         : std::make_shared<WeightAdjacency>();
  const Index nv = t.n_vertices;
  const std::vector<std::int32_t>& order = *s.order;
  const std::vector<std::int32_t>& rank = *s.rank;
  std::vector<std::int32_t> old_to_new(nv);
  parallel_range(nv, threads, [&](Index b, Index e) {
    for (Index i = b; i < e; ++i) old_to_new[i] = rank[src.order[i]];
  });
  if (t.closed()) {
    relabel_fans_into(src.fans, old_to_new, a->fans, threads);
    a->weight_order.resize(nv);
    parallel_range(nv, threads, [&](Index b, Index e) {
      for (Index j = b; j < e; ++j) a->weight_order[j] = old_to_new[src.weight_order[j]];
    });
  } else {
    const std::vector<std::int32_t> old_rank = inverse_order(src.order, threads);
    std::vector<std::int32_t> new_to_old(nv);
    parallel_range(nv, threads, [&](Index b, Index e) {
      for (Index i = b; i < e; ++i) new_to_old[i] = old_rank[order[i]];
    });
    a->rings = permute_rings(src.rings, new_to_old, old_to_new, threads);
  }
  a->order = order;
  return a;
}

/// The fans or rings in the state's processing order, relabelled on first use.
inline const WeightAdjacency& weight_adjacency(const FrameTopology& t, const RestState& s, int threads) {
  return *s.adjacency->get([&] {
    const std::shared_ptr<const WeightAdjacency>& src = s.adjacency_source;
    if (src->order == *s.order) return src;
    return relabel_weight_adjacency(t, s, *src, threads);
  });
}

/// The adjacency a state derived from `prev` starts from: prev's own if it is built,
/// else what prev would have relabelled (so at most one older adjacency stays alive).
inline std::shared_ptr<const WeightAdjacency> adjacency_source_after(const RestState& prev) {
  const std::shared_ptr<const WeightAdjacency>* built = prev.adjacency->if_known();
  return built ? *built : prev.adjacency_source;
}

}  // namespace vpffd
