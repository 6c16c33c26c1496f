#pragma once
/// @file rest_moves.h
/// Building rest states (frame/rest_state.h): the first one from the rest mesh, and
/// each later one from the state before it and a move (new positions, or translations
/// of the parts). Pure functions of (topology, previous state, move): the previous
/// state is only read (frames may be reading it too) and the new one shares with it
/// what the move did not change. A refused move throws before anything is published.
///
/// The buffers a move writes are recycled from states no frame holds any more
/// (MoveScratch): a moving object's frames then do not fault in fresh pages of
/// embedding and positions on every move.

#include <algorithm>
#include <atomic>
#include <cstring>
#include <exception>
#include <memory>
#include <string>
#include <vector>

#include "vpffd/ffd/cell_runs.h"
#include "vpffd/ffd/vertex_order.h"
#include "vpffd/frame/rest_state.h"
#include "vpffd/lattice/embed.h"
#include "vpffd/lattice/periodic.h"
#include "vpffd/mesh/validate.h"

namespace vpffd {

/// Buffers of earlier states, reused by the next move. Owned by one deformer and used
/// only by its moves, one at a time.
struct MoveScratch {
  std::vector<std::int32_t> cells;
  Embedding embedding;
  std::shared_ptr<RowMatrixX3d> positions;
  std::shared_ptr<WeightAdjacency> adjacency;

  /// Storage for #V x 3 positions: a recycled matrix or a new one.
  std::shared_ptr<RowMatrixX3d> take_positions(Index nv) {
    std::shared_ptr<RowMatrixX3d> X = positions ? std::move(positions) : std::make_shared<RowMatrixX3d>();
    X->resize(nv, 3);
    return X;
  }
};

/// Gives the buffers of `old` to the scratch when nothing else holds it: a deformer
/// calls this with the state it has just replaced, which no new frame can reach, so a
/// count of one means no frame holds it either.
inline void recycle(std::shared_ptr<const RestState>&& old, MoveScratch& scratch) {
  if (!old || old.use_count() != 1) return;
  // Pairs with the release of the last frame's reference: its reads of the buffers
  // happen before they are written again.
  std::atomic_thread_fence(std::memory_order_acquire);
  // Built non-const by this file; nobody else can see it any more.
  RestState& s = const_cast<RestState&>(*old);
  scratch.embedding = std::move(s.embedding);
  if (s.volume_positions == s.V) s.volume_positions.reset();
  if (s.V.use_count() == 1) {
    std::atomic_thread_fence(std::memory_order_acquire);
    scratch.positions = std::const_pointer_cast<RowMatrixX3d>(std::move(s.V));
  }
  // The adjacency this state relabelled from is read by no later state once this one
  // is gone (they start from this state's own, or from that of a state after it).
  if (s.adjacency_spare) {
    scratch.adjacency = std::move(s.adjacency_spare);
  } else if (s.adjacency_source && s.adjacency_source.use_count() == 1) {
    std::atomic_thread_fence(std::memory_order_acquire);
    scratch.adjacency = std::const_pointer_cast<WeightAdjacency>(std::move(s.adjacency_source));
  }
}

/// With parts: which of them have vertices outside the lattice box (the test of the
/// embedding), to name them in its error, e.g. an object that swam out of the lattice
/// ("" when none is, or without parts).
inline std::string parts_outside(const FrameTopology& t, const Eigen::Ref<const RowMatrixX3d>& V) {
  if (!t.has_parts || t.policy != OutsidePolicy::Error || V.rows() != Index(t.parts.vertex_part.size())) return {};
  std::vector<Index> out(t.parts.count, 0), size(t.parts.count, 0);
  const bool periodic = t.lattice.any_periodic();
  for (Index v = 0; v < V.rows(); ++v) {
    const int k = t.parts.vertex_part[v];
    ++size[k];
    const Vector3d x = periodic ? wrap_point(t.lattice, V.row(v).transpose()) : Vector3d(V.row(v).transpose());
    bool outside = !x.allFinite();
    for (int a = 0; a < 3; ++a) outside |= !accepted_box(t.lattice, a).contains(x[a]);
    out[k] += outside;
  }
  std::string named;
  int n = 0;
  for (int k = 0; k < t.parts.count; ++k) {
    if (out[k] == 0) continue;
    if (n++ < 8)
      named += detail::concat(n > 1 ? ", " : "", "part ", k, " (label ", t.parts.labels[k], "): ", out[k], " of its ",
                              size[k], " vertices");
  }
  if (n == 0) return {};
  return detail::concat("; parts outside: ", named, n > 8 ? detail::concat(" and ", n - 8, " more") : "");
}

namespace detail {

/// The cell runs of the embedding, with the basis values of their short runs' points
/// (cache_short_run_basis: a mesh with few points per cell then evaluates them once
/// per move, not in each of a frame's seven per-point passes).
inline void set_runs(const FrameTopology& t, RestState& s, int threads) {
  s.runs = cell_runs(s.embedding, threads);
  cache_short_run_basis(t.tables, s.embedding, s.runs, threads);
}

/// Along a "shift" seam a wrapped vertex maps to D(wrapped) + its translation
/// (lattice/periodic.h), kept per vertex in processing order.
inline void set_seam_shifts(const FrameTopology& t, RestState& s) {
  s.seam_shift.resize(0, 3);
  const RowMatrixX3d T = seam_translations(t.lattice, *s.V);
  if (T.rows() == 0) return;
  s.seam_shift.resize(T.rows(), 3);
  const std::vector<std::int32_t>& order = *s.order;
  for (Index i = 0; i < T.rows(); ++i) s.seam_shift.row(i) = T.row(order[i]);
}

/// What depends on the processing order alone: shared with `prev` where the order is
/// the same (a moved object often keeps it: no vertex changed cell, or all moved
/// together), else built anew on first use, the adjacency relabelled from prev's.
inline void set_numbering(RestState& s, const RestState* prev, bool same_order, MoveScratch& scratch) {
  if (prev && same_order) {
    s.order = prev->order;
    s.rank = prev->rank;
    s.faces = prev->faces;
    s.face_lists = prev->face_lists;
    s.adjacency = prev->adjacency;
    s.adjacency_source = prev->adjacency_source;
    return;
  }
  s.faces = std::make_shared<Lazy<RowMatrixX3i>>();
  s.face_lists = std::make_shared<Lazy<VertexFaces>>();
  s.adjacency = std::make_shared<Lazy<std::shared_ptr<const WeightAdjacency>>>();
  if (prev) s.adjacency_source = adjacency_source_after(*prev);
  s.adjacency_spare = std::move(scratch.adjacency);
}

}  // namespace detail

/// Where a new state's rest volumes come from.
enum class RestVolumesFrom {
  Positions,  ///< its own positions, summed on first use (or at once where they might overflow)
  Kept        ///< the previous state's (a translation of each closed part keeps its volume)
};

/// A rest state for positions X (#V x 3, caller order): cells, processing order (by
/// part, then by cell), embedding, cell runs, seam shifts; the rest derived lazily.
/// `storage`, if given, already holds X (the caller built the positions in it);
/// otherwise X is copied into recycled storage. `prev`: the state this one follows
/// (null for the first); with RestVolumesFrom::Kept its rest volumes are kept.
/// @throws InvalidInputError naming `where` for positions the lattice refuses
inline std::shared_ptr<RestState> embed_rest(const FrameTopology& t, const RestState* prev,
                                             const Eigen::Ref<const RowMatrixX3d>& X, int threads, const char* where,
                                             MoveScratch& scratch, RestVolumesFrom volumes = RestVolumesFrom::Positions,
                                             std::shared_ptr<RowMatrixX3d> storage = nullptr) {
  const Index nv = X.rows();
  // First only each vertex's cell, reading X in its own order (this pass checks X);
  // the embedding is computed afterwards, straight into the processing order sorted
  // by these cells. (This replaced embedding into the previous order, reading the
  // cells back and permuting the six arrays; with the vectorised embedding loops a
  // move became 0.73-0.82x as costly, bench/results/vm/move_ab_vm.md.)
  std::vector<std::int32_t>& cell = scratch.cells;
  try {
    embed_cells(t.lattice, X, t.policy, cell, threads, "vertex");
  } catch (const InvalidInputError& e) {
    throw InvalidInputError(std::string(where) + ": " + e.what() + parts_outside(t, X));
  }
  auto s = std::make_shared<RestState>();
  if (volumes == RestVolumesFrom::Kept && prev) {
    s->volumes = prev->volumes;
    s->volume_positions = prev->volume_positions;
  } else if (!rest_volume_stays_finite(t.lattice, t.faces.rows(), X, threads)) {
    // Volumes that might overflow are summed, and refused, now (frame/rest_volume.h).
    s->volumes = std::make_shared<Lazy<RestVolumes>>(measure_rest(t, X, threads, where));
  } else {
    s->volumes = std::make_shared<Lazy<RestVolumes>>();
  }
  if (!storage) {
    storage = scratch.take_positions(nv);
    RowMatrixX3d& V = *storage;
    parallel_range(nv, threads, [&](Index b, Index e) { V.middleRows(b, e - b) = X.middleRows(b, e - b); });
  }
  s->V = storage;
  if (!s->volume_positions) s->volume_positions = s->V;

  std::vector<std::int32_t> order = counting_sort(cell, t.n_cells(), threads);
  if (!prev) std::vector<std::int32_t>().swap(cell);  // kept only by a deformer that moves
  if (t.has_parts) {
    // Each part's vertices together (in cell order within it): a part's coefficients
    // are then the scatter of one range of vertices.
    std::vector<std::int32_t> key(nv);
    for (Index i = 0; i < nv; ++i) key[i] = t.parts.vertex_part[order[i]];
    const std::vector<std::int32_t> by_part = counting_sort(key, t.parts.count, threads);
    std::vector<std::int32_t> sorted(nv);
    for (Index i = 0; i < nv; ++i) sorted[i] = order[by_part[i]];
    order.swap(sorted);
  }
  // X passed the same checks in embed_cells: this does not throw.
  s->embedding = std::move(scratch.embedding);
  embed_into(t.lattice, X, t.policy, s->embedding, threads, "vertex", order.data());
  const bool same_order = prev && order == *prev->order;
  if (!same_order) {
    s->rank = std::make_shared<const std::vector<std::int32_t>>(inverse_order(order, threads));
    s->order = std::make_shared<const std::vector<std::int32_t>>(std::move(order));
  }
  detail::set_numbering(*s, prev, same_order, scratch);
  detail::set_runs(t, *s, threads);
  detail::set_seam_shifts(t, *s);
  if (!prev) {
    // The fans (closed mesh: half the reads of the rings) or rings, once, in the first
    // processing order's runs; later states relabel them.
    s->adjacency_source = build_weight_adjacency(t, *s, threads);
    s->adjacency = std::make_shared<Lazy<std::shared_ptr<const WeightAdjacency>>>(s->adjacency_source);
  }
  return s;
}

/// A move of some parts only: the parts in `moved` (n_moved vertices) go to
/// position(k, v, a) (part k, vertex v, axis a); the others keep their rest positions,
/// cells, places in the processing order and embedding. Only the moved ones are
/// embedded again, each into its own range of the order (a part's vertices are
/// together there, sorted by cell and then by vertex, which sorting a part alone
/// reproduces), so the state is that of the whole move, bit for bit, but for what the
/// caller sets: the offsets and the rest volumes. Costs the moved parts' vertices plus
/// copies and cell runs of the whole mesh: a car driving over a terrain that other
/// parts share, or one object dragged among many.
/// @returns null where the whole move is as cheap (over half of the vertices moved) or
///          a moved part is refused (the whole move then throws its error, which names
///          every part outside)
template <class Position>
std::shared_ptr<RestState> move_parts(const FrameTopology& t, const RestState& prev, const std::vector<int>& moved,
                                      Index n_moved, Position&& position, int threads, MoveScratch& scratch) {
  const Index nv = t.n_vertices;
  if (2 * n_moved > nv) return nullptr;
  // Each moved part: its positions (in ascending vertex order), their cells (the
  // check of the whole move), its new order within the part and its embedding.
  struct Part {
    RowMatrixX3d X;                         ///< in ascending vertex order
    std::vector<std::int32_t> cell, order;  ///< order: its vertices in processing order
    Embedding E;
  };
  std::vector<Part> parts(moved.size());
  // The parts side by side, each on one thread (one part alone: on all of them).
  // Errors stay in their part (none may leave a parallel region).
  const int inner = moved.size() > 1 ? 1 : threads;
  std::vector<std::exception_ptr> error(moved.size());
  std::vector<char> refused(moved.size(), 0);
  parallel_items(Index(moved.size()), n_moved, threads, [&](Index q) {
    try {
      const int k = moved[q];
      const Index b = t.part_start[k], m = t.part_start[k + 1] - b;
      Part& P = parts[q];
      P.X.resize(m, 3);
      for (Index i = 0; i < m; ++i)
        for (int a = 0; a < 3; ++a) P.X(i, a) = position(k, Index(t.part_vertices[b + i]), a);
      try {
        embed_cells(t.lattice, P.X, t.policy, P.cell, inner, "vertex");
      } catch (const InvalidInputError&) {
        refused[q] = 1;
        return;
      }
      P.order = counting_sort(P.cell, t.n_cells(), inner);
      embed_into(t.lattice, P.X, t.policy, P.E, inner, "vertex", P.order.data());
      for (std::int32_t& i : P.order) i = t.part_vertices[b + i];  // rows of X -> vertices
    } catch (...) {
      error[q] = std::current_exception();
    }
  });
  for (const std::exception_ptr& e : error)
    if (e) std::rethrow_exception(e);
  for (char r : refused)
    if (r) return nullptr;
  bool reordered = false;
  for (size_t q = 0; q < moved.size() && !reordered; ++q)
    reordered = !std::equal(parts[q].order.begin(), parts[q].order.end(), prev.order->begin() + t.part_start[moved[q]]);

  auto s = std::make_shared<RestState>();
  std::shared_ptr<RowMatrixX3d> V = scratch.take_positions(nv);
  *V = *prev.V;
  s->embedding = std::move(scratch.embedding);
  for (int a = 0; a < 3; ++a) {
    s->embedding.span[a] = prev.embedding.span[a];
    s->embedding.tau[a] = prev.embedding.tau[a];
  }
  std::vector<std::int32_t> order, rank;
  if (reordered) {
    order = *prev.order;
    rank = *prev.rank;
  }
  for (size_t q = 0; q < moved.size(); ++q) {
    const Index b = t.part_start[moved[q]];
    const Part& P = parts[q];
    for (Index i = 0; i < P.X.rows(); ++i) {
      V->row(t.part_vertices[b + i]) = P.X.row(i);
      if (reordered) {
        const std::int32_t v = P.order[i];
        order[b + i] = v;
        rank[v] = static_cast<std::int32_t>(b + i);
      }
    }
    for (int a = 0; a < 3; ++a) {
      std::copy(P.E.span[a].begin(), P.E.span[a].end(), s->embedding.span[a].begin() + b);
      std::copy(P.E.tau[a].begin(), P.E.tau[a].end(), s->embedding.tau[a].begin() + b);
    }
  }
  s->V = V;
  if (reordered) {
    s->order = std::make_shared<const std::vector<std::int32_t>>(std::move(order));
    s->rank = std::make_shared<const std::vector<std::int32_t>>(std::move(rank));
  }
  detail::set_numbering(*s, &prev, !reordered, scratch);
  detail::set_runs(t, *s, threads);
  detail::set_seam_shifts(t, *s);
  return s;
}

/// The state after set_rest_vertices(X) from `prev`. With parts, those whose rows of
/// X are their rest positions, bit for bit, keep their embedding: where at most half
/// of the vertices move, only the moved parts are embedded (move_parts; each part is
/// read until its first difference). The rest volumes are X's, summed on first use;
/// X becomes the base of later offset moves.
/// @throws InvalidInputError for positions the lattice refuses
inline std::shared_ptr<RestState> reposition(const FrameTopology& t, const RestState& prev,
                                             const Eigen::Ref<const RowMatrixX3d>& X, int threads,
                                             MoveScratch& scratch) {
  std::shared_ptr<RestState> s;
  if (t.has_parts && rest_volume_stays_finite(t.lattice, t.faces.rows(), X, threads)) {
    std::vector<int> moved;
    Index n_moved = 0;
    const RowMatrixX3d& V = *prev.V;
    for (int k = 0; k < t.parts.count && 2 * n_moved <= t.n_vertices; ++k) {
      const Index b = t.part_start[k], e = t.part_start[k + 1];
      for (Index i = b; i < e; ++i) {
        const Index v = t.part_vertices[i];
        const double x[3] = {X(v, 0), X(v, 1), X(v, 2)}, was[3] = {V(v, 0), V(v, 1), V(v, 2)};
        if (std::memcmp(x, was, sizeof x) != 0) {
          moved.push_back(k);
          n_moved += e - b;
          break;
        }
      }
    }
    s = move_parts(t, prev, moved, n_moved, [&](int, Index v, int a) { return X(v, a); }, threads, scratch);
    if (s) {
      s->volumes = std::make_shared<Lazy<RestVolumes>>();  // of X, on first use
      s->volume_positions = s->V;
    }
  }
  if (!s) s = embed_rest(t, &prev, X, threads, "set_rest_vertices", scratch);
  return s;  // base and offsets: none (later offsets move from X)
}

/// The state after set_rest_offsets(offsets) from `prev`: every vertex of part k (of
/// the whole mesh without parts) at its base position plus row k. The base is prev's
/// (its positions before its first offset move). A closed mesh's or parts' rest
/// volumes are the base's (translations keep them); an open mesh without parts sums
/// its moved positions. Parts whose offset is the last move's, bit for bit, keep their
/// embedding (move_parts). Null when nothing would change (the same offsets again).
/// @throws InvalidInputError for positions the lattice refuses
inline std::shared_ptr<RestState> offset(const FrameTopology& t, const RestState& prev,
                                         const Eigen::Ref<const RowMatrixX3d>& offsets, int threads,
                                         MoveScratch& scratch) {
  const bool first = !prev.base;
  const std::shared_ptr<const RowMatrixX3d> base = first ? prev.V : prev.base;
  const RowMatrixX3d& B = *base;
  std::shared_ptr<RestState> s;
  if (!first && t.has_parts && prev.offsets.rows() == offsets.rows()) {
    std::vector<int> moved;
    Index n_moved = 0;
    for (int k = 0; k < t.parts.count; ++k)
      for (int a = 0; a < 3; ++a) {
        const double o = offsets(k, a), was = prev.offsets(k, a);
        if (std::memcmp(&o, &was, sizeof o) != 0) {
          moved.push_back(k);
          n_moved += t.part_start[k + 1] - t.part_start[k];
          break;
        }
      }
    if (moved.empty()) return nullptr;  // the whole move would compute the state there is
    s = move_parts(t, prev, moved, n_moved, [&](int k, Index v, int a) { return B(v, a) + offsets(k, a); }, threads,
                   scratch);
    if (s) {
      s->volumes = prev.volumes;  // as the whole move: the parts' volumes are translations'
      s->volume_positions = prev.volume_positions;
    }
  }
  if (!s) {
    std::shared_ptr<RowMatrixX3d> X = scratch.take_positions(t.n_vertices);
    const std::int32_t* part = t.has_parts ? t.parts.vertex_part.data() : nullptr;
    RowMatrixX3d& Xm = *X;
    parallel_range(t.n_vertices, threads, [&](Index b, Index e) {
      for (Index v = b; v < e; ++v) {
        const Index k = part ? Index(part[v]) : 0;
        for (int a = 0; a < 3; ++a) Xm(v, a) = B(v, a) + offsets(k, a);
      }
    });
    // Each part is closed (require_closed_parts), or the whole mesh is: translations
    // keep every volume. prev's volumes are of the base (or prev is the base).
    const bool keep = t.has_parts || t.closed();
    try {
      s = embed_rest(t, &prev, Xm, threads, "set_rest_offsets", scratch,
                     keep ? RestVolumesFrom::Kept : RestVolumesFrom::Positions, X);
    } catch (...) {
      scratch.positions = std::move(X);
      throw;
    }
  }
  s->base = base;
  s->offsets = offsets;
  return s;
}

}  // namespace vpffd
