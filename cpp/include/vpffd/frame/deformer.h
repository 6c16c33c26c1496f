#pragma once
/// @file deformer.h
/// The frame layer: from control points to corrected vertices, above ffd/, volume/
/// and correction/ (docs/architecture.md).
/// Volume-preserving B-spline FFD of one triangle mesh (Hahmann et al. 2012):
/// embeds the mesh once and then deforms it for any number of control point sets
/// (frames), while the rest mesh may move between them.
///
/// @code
///   vpffd::Deformer d(V, F, lattice);
///   auto r = d.deform(P, {});   // r.vertices, r.volume == d.rest_volume()
/// @endcode
///
/// State: what no move changes (frame/topology.h) and the current rest state
/// (frame/rest_state.h), an immutable snapshot built by the moves (frame/rest_moves.h).
/// A frame is a function of (topology, rest state, control points, options)
/// (frame/frame_loop.h); the Deformer only holds the two and swaps in a new rest state
/// when the rest mesh moves.
///
/// Threads: every public member may be called from any number of threads at once,
/// moves of the rest mesh (set_rest_vertices, set_rest_offsets) included. Each frame
/// (deform, plan, ffd, jacobians, jacobian_determinants, deformed_normals,
/// basis_transpose, basis_matrix, volume_coefficients, rest volumes) takes the current
/// rest state once and works on it to the end, so it sees the rest mesh before a move
/// or after it, never a mix; frames never wait for a move, nor a move for frames.
/// Moves run one at a time. Accessors that return references into the rest state
/// (rest_vertices, base_vertices, processing_order, processing_embedding,
/// processing_faces, processing_adjacency, face_matrix) are valid until the next move;
/// a caller that may race with one holds rest_state() and reads from it (the
/// functions of frame/rest_state.h), which keeps that state alive.

#include <memory>
#include <mutex>
#include <string>

#include "vpffd/correction/options.h"
#include "vpffd/correction/plan.h"
#include "vpffd/ffd/basis_matrix.h"
#include "vpffd/ffd/normals.h"
#include "vpffd/ffd/reorder.h"
#include "vpffd/frame/frame_loop.h"
#include "vpffd/frame/frame_passes.h"
#include "vpffd/frame/frame_plan.h"
#include "vpffd/frame/rest_moves.h"
#include "vpffd/frame/rest_state.h"
#include "vpffd/frame/topology.h"
#include "vpffd/mesh/parts.h"
#include "vpffd/mesh/validate.h"
#include "vpffd/mesh/volume.h"

namespace vpffd {

class Deformer {
 public:
  /// Embeds the mesh (V, F) in lattice L.
  /// @param[in] V  #V x 3 rest vertices
  /// @param[in] F  #F x 3 triangles (indices into V)
  /// @param parts  null, or the mesh's parts (mesh/parts.h): each part then keeps
  ///               its own volume (one volume row per part in every axis step)
  /// @throws InvalidInputError for a bad mesh, a bad lattice, vertices outside it,
  ///         or parts that do not each bound a volume
  Deformer(const Eigen::Ref<const RowMatrixX3d>& V, const Eigen::Ref<const RowMatrixX3i>& F, Lattice L,
           OutsidePolicy policy = OutsidePolicy::Error, int threads = 0, const MeshParts* parts = nullptr)
      : topo_(make_topology(V, F, std::move(L), policy, parts)),
        state_(embed_rest(*topo_, nullptr, V, threads, "Deformer", scratch_)) {}

  /// A Deformer on a topology and rest state built elsewhere (make_topology, embed_rest):
  /// it shares them and embeds nothing. The Vulkan backend's host side is one.
  Deformer(std::shared_ptr<const FrameTopology> topology, std::shared_ptr<const RestState> state)
      : topo_(std::move(topology)), state_(std::move(state)) {
    VPFFD_CHECK(topo_ && state_ && state_->V && state_->V->rows() == topo_->n_vertices,
                "Deformer: the rest state is not one of this topology");
  }

  Deformer(const Deformer&) = delete;
  Deformer& operator=(const Deformer&) = delete;

  /// Moves the rest mesh to X (same faces): the next frame deforms X as a Deformer
  /// built on it would (same embedding, processing order, rest volumes; the same
  /// results bit for bit). The faces, their checks and the parts are kept, and X
  /// becomes the base of later set_rest_offsets. The rest volumes are summed on first
  /// use (frame/rest_volume.h). Frames in flight on other threads finish on the rest
  /// state they started with. With parts, those whose rows of X are their rest
  /// positions, bit for bit, keep their embedding: where at most half of the vertices
  /// move, only the moved parts are embedded (frame/rest_moves.h).
  /// @param[in] X  #V x 3 new rest vertices
  /// @throws InvalidInputError for a wrong shape, non-finite coordinates, or vertices
  ///         outside the lattice box (unless built with OutsidePolicy::Extrapolate);
  ///         the Deformer is unchanged then.
  void set_rest_vertices(const Eigen::Ref<const RowMatrixX3d>& X, int threads = 0) {
    VPFFD_CHECK(X.rows() == n_vertices(), "set_rest_vertices: ", X.rows(), " vertices, the mesh has ", n_vertices(),
                " (the faces stay; give every vertex a new position)");
    std::lock_guard<std::mutex> moving(move_mutex_);
    std::shared_ptr<RestState> next;
    try {
      next = reposition(*topo_, *state_, X, threads, scratch_);
    } catch (const InvalidInputError&) {
      // The embedding refuses non-finite coordinates (with points too far away) in the
      // pass it makes anyway; only a refused move looks for them, to name them as such.
      require_finite_rows(X, "set_rest_vertices");
      throw;
    }
    publish(std::move(next));
  }

  /// Moves the rest mesh by translations: every vertex of part k (of the whole mesh
  /// without parts) to its base position plus row k of `offsets`. The base is the rest
  /// mesh of construction or of the last set_rest_vertices, never an earlier offset
  /// move: offsets do not accumulate. The paper's per-frame input (001 §2.3: an object's
  /// rest positions x + o(t)): the next frame deforms what set_rest_vertices(base +
  /// offsets) would give, with the same embedding, processing order and frames bit for
  /// bit, but for the rest volumes: a translation leaves a closed surface's enclosed
  /// volume unchanged, so those of the base are kept (summed once, on first use, not
  /// after every move; the moved positions' own sum would differ from them by rounding
  /// only). An open mesh without parts (allow_open frames: cone volumes from origin(),
  /// which a translation changes) sums its moved positions as set_rest_vertices does.
  /// Parts whose offset is the last move's, bit for bit, keep their embedding: where at
  /// most half of the vertices move, only the moved parts are embedded.
  /// @param[in] offsets  n_parts() x 3 translations, in the parts' order (part_labels)
  /// @throws InvalidInputError for a wrong shape, non-finite offsets, or vertices moved
  ///         outside the lattice box (unless built with OutsidePolicy::Extrapolate); the
  ///         Deformer is unchanged then.
  void set_rest_offsets(const Eigen::Ref<const RowMatrixX3d>& offsets, int threads = 0) {
    VPFFD_CHECK(offsets.rows() == n_parts(), "set_rest_offsets: ", offsets.rows(), " offsets, expected one per part (",
                n_parts(), has_parts() ? " parts)" : ": the Deformer has no parts, so one for the whole mesh)");
    for (Index k = 0; k < offsets.rows(); ++k)
      VPFFD_CHECK(offsets.row(k).allFinite(), "set_rest_offsets: offset ", k, " (", offsets(k, 0), ", ",
                  offsets(k, 1), ", ", offsets(k, 2), ") is not finite");
    std::lock_guard<std::mutex> moving(move_mutex_);
    std::shared_ptr<RestState> next = offset(*topo_, *state_, offsets, threads, scratch_);
    if (next) publish(std::move(next));  // null: the offsets the rest mesh has already
  }

  /// The current rest state: held by the caller, it stays valid (and unchanged) however
  /// the rest mesh moves meanwhile. Read it with the functions of frame/rest_state.h.
  std::shared_ptr<const RestState> rest_state() const {
    std::lock_guard<std::mutex> lock(state_mutex_);
    return state_;
  }
  /// What no move changes: lattice, faces, parts, tables.
  const FrameTopology& topology() const { return *topo_; }

  /// Whether the rest mesh is its base moved by set_rest_offsets (base_vertices()).
  bool rest_is_offset() const { return rest_state()->base != nullptr; }
  /// The positions set_rest_offsets moves from (empty before the first such move).
  const RowMatrixX3d& base_vertices() const {
    static const RowMatrixX3d kNone(0, 3);
    const RestState& s = current();
    return s.base ? *s.base : kNone;
  }

  /// With parts: which of them have vertices outside the lattice box (the test of the
  /// embedding), to name them in its error, e.g. an object that swam out of the
  /// lattice ("" when none is, or without parts; also the Vulkan backend's messages).
  std::string parts_outside(const Eigen::Ref<const RowMatrixX3d>& V) const { return vpffd::parts_outside(*topo_, V); }

  const Lattice& lattice() const { return topo_->lattice; }
  const RowMatrixX3d& rest_vertices() const { return *current().V; }
  const RowMatrixX3i& faces() const { return topo_->faces; }
  Index n_vertices() const { return topo_->n_vertices; }
  Index n_faces() const { return topo_->faces.rows(); }
  /// Control points a frame takes: the distinct ones of a periodic lattice.
  Index n_control_points() const { return topo_->ties.n_distinct; }
  /// The periodic tie map (identity without periodic axes).
  const Ties& ties() const { return topo_->ties; }
  const EdgeReport& edges() const { return topo_->edges; }
  bool is_closed() const { return topo_->closed(); }
  /// Per-vertex basis data in the caller's vertex order (a copy).
  Embedding embedding() const {
    const auto s = rest_state();
    return permute_embedding(s->embedding, *s->rank);
  }
  /// Processing order of the frames: position -> vertex index (sorted by cell).
  /// Other backends run in the same order with the three views below.
  const std::vector<std::int32_t>& processing_order() const { return *current().order; }
  /// Per-vertex basis data in processing order.
  const Embedding& processing_embedding() const { return current().embedding; }
  /// Faces in face_processing_order(), numbered by processing position. Built on
  /// first use after each change of the processing order: the CPU's volume-preserving
  /// frames of a closed mesh do not need them (the weights come from the fans), so a
  /// moving object's set_rest_vertices does not renumber them.
  const RowMatrixX3i& processing_faces() const {
    const auto s = rest_state();  // held while it is built: a move may replace it meanwhile
    return vpffd::processing_faces(*topo_, *s);
  }
  /// Vertex -> faces lists of processing_faces(), built on first use (CPU frames use
  /// the vertex fans or rings instead).
  const VertexFaces& processing_adjacency() const {
    const auto s = rest_state();
    return vpffd::processing_adjacency(*topo_, *s);
  }
  const BasisTables& tables() const { return topo_->tables; }
  OutsidePolicy outside_policy() const { return topo_->policy; }
  /// Reference point of the volume sums (the lattice box centre).
  const Vector3d& origin() const { return topo_->origin; }

  /// Whether the Deformer was built with parts (then n_parts() may still be 1).
  bool has_parts() const { return topo_->has_parts; }
  /// Number of parts (1 without parts: the whole mesh).
  int n_parts() const { return topo_->parts.count; }
  /// The parts (vertex_part is empty without parts).
  const MeshParts& parts() const { return topo_->parts; }
  /// Each part's vertices in processing order: [part_start()[k], part_start()[k+1]).
  const std::vector<Index>& part_start() const { return topo_->part_start; }
  /// Each part's faces: [part_face_start()[k], part_face_start()[k+1]) of
  /// processing_faces() and of part_faces() (K + 1; [0, F] without parts).
  const std::vector<Index>& part_face_start() const { return topo_->face_start; }
  /// With parts: the faces in face_processing_order(), in the caller's vertex numbering
  /// (each part's faces together); empty without parts. Fixed at construction.
  const RowMatrixX3i& part_faces() const { return topo_->part_faces; }
  /// Processing order of the faces: position -> face index (the columns of face_matrix()).
  const std::vector<std::int32_t>& face_processing_order() const { return topo_->face_order; }

  /// Enclosed volume of each part of the rest mesh (K; the whole mesh without parts,
  /// and then only when it is closed). @throws InvalidInputError for an open mesh
  VectorXd rest_part_volumes() const {
    if (!has_parts()) return VectorXd::Constant(1, rest_volume());
    return vpffd::rest_volumes(*topo_, *rest_state()).parts;
  }
  /// Enclosed volume of the rest mesh, summed on its first use after a move
  /// (frame/rest_volume.h) and kept. @throws InvalidInputError if it is not
  /// closed, unless `allow_open` (then: the cone volume from origin()).
  double rest_volume(bool allow_open = false) const {
    if (!allow_open) require_closed(topo_->edges, "rest_volume");
    return vpffd::rest_volumes(*topo_, *rest_state()).total;
  }
  /// Whether the rest volume is summed already (rest_volume() then costs nothing).
  bool rest_volume_known() const { return rest_state()->volumes->known(); }
  /// The rest volume a move to X would give, without moving: the same sum, faces
  /// and parts, so the same bits as rest_volume(true) after set_rest_vertices(X)
  /// (for a rest mesh this Deformer no longer holds). X is not embedded: its
  /// vertices may lie anywhere.
  /// @throws InvalidInputError for a wrong shape or a volume past double range
  double rest_volume_of(const Eigen::Ref<const RowMatrixX3d>& X, int threads = 0) const {
    VPFFD_CHECK(X.rows() == n_vertices(), "rest_volume_of: ", X.rows(), " vertices, the mesh has ", n_vertices());
    return measure_rest(*topo_, X, threads, "rest_volume_of").total;
  }

  /// Memory the Deformer holds, in bytes per vertex: the current rest state's (the
  /// embedding, 36; orders, 8; rest positions, 24, and the base positions after
  /// set_rest_offsets, 24; cell runs, with 24 K bytes of basis values for each vertex
  /// in a run shorter than kShortRun: 96 for cubic lattices; the vertex fans of a
  /// closed mesh, ~28-36 with their row order, or the rings of an open one, ~52; once
  /// built, the renumbered faces and vertex-face lists, about 190 bytes for a closed
  /// mesh, F = 2V) and what is fixed (faces as given and, with parts, grouped by part
  /// with each part's vertices), plus the buffers kept for the next move. A fan or
  /// ring list not yet relabelled for the current order counts as the older one it
  /// will be relabelled from. States held by frames in flight are not counted.
  double bytes_per_vertex() const {
    const auto s = rest_state();
    const FrameTopology& t = *topo_;
    const double per_int = sizeof(std::int32_t);
    double bytes = double(s->V->size()) * sizeof(double) +
                   double(t.faces.size() + t.part_faces.size() + t.face_order.size() + t.part_vertices.size()) *
                       per_int;
    if (s->base && s->base != s->V) bytes += double(s->base->size()) * sizeof(double);
    bytes += double(s->order->size() + s->rank->size()) * per_int;
    if (const RowMatrixX3i* Fs = s->faces->if_known()) bytes += double(Fs->size()) * per_int;
    if (const VertexFaces* a = s->face_lists->if_known()) bytes += double(a->indptr.size() + a->faces.size()) * per_int;
    const std::shared_ptr<const WeightAdjacency>* built = s->adjacency->if_known();
    const WeightAdjacency& adj = built ? **built : *s->adjacency_source;
    bytes += double(adj.fans.bytes()) + double(adj.rings.indptr.size() + adj.rings.pairs.size()) * per_int +
             double(adj.weight_order.size() + adj.order.size()) * per_int;
    bytes += double(n_vertices()) * Embedding::bytes_per_point + double(s->runs.bytes());
    {
      std::lock_guard<std::mutex> moving(move_mutex_);
      bytes += double(scratch_.embedding.size()) * Embedding::bytes_per_point +
               double(scratch_.cells.size()) * per_int +
               (scratch_.positions ? double(scratch_.positions->size()) * sizeof(double) : 0.0);
      if (const WeightAdjacency* a = scratch_.adjacency.get())
        bytes += double(a->fans.bytes()) + double(a->weight_order.size() + a->order.size()) * per_int;
    }
    return bytes / double(n_vertices());
  }

  /// Plain FFD of the mesh vertices. @param P N x 3 control points. @returns #V x 3
  RowMatrixX3d ffd(const Eigen::Ref<const RowMatrixX3d>& P, int threads = 0) const {
    RowMatrixX3d X(n_vertices(), 3);
    ffd(P, X.data(), threads);
    return X;
  }
  /// ffd() into the caller's #V x 3 row-major array `out` (the same bits).
  void ffd(const Eigen::Ref<const RowMatrixX3d>& P, double* out, int threads = 0) const {
    frame::check_control_points(*topo_, P, "ffd");
    const auto s = rest_state();
    frame::eval_ffd(*topo_, *s, P, out, threads, s->order->data());
  }

  /// Jacobians dD/dx at the vertices: #V x 9, row-major 3x3 per vertex.
  RowMatrixXd jacobians(const Eigen::Ref<const RowMatrixX3d>& P, int threads = 0) const {
    frame::check_control_points(*topo_, P, "jacobians");
    const auto s = rest_state();
    const int twist = twist_axis(lattice());
    const RowMatrixX3d& V = *s->V;
    RowMatrixXd J(n_vertices(), 9);
    frame::for_each_jacobian(*topo_, *s, P, threads, [&](Index v, double* j) {
      unmirror_jacobian(lattice(), twist, V.row(v).transpose(), j);
      std::copy(j, j + 9, J.row(v).data());
    });
    return J;
  }

  /// det dD/dx at the vertices (#V, caller order): the local volume ratio of the FFD
  /// (below 1 compressed, above 1 expanded, <= 0 folded). The same values as the
  /// determinants of jacobians(), without its #V x 9 arrays: blocks of Jacobians in a
  /// small buffer. (A twist seam's mirroring flips two columns: det is unchanged.)
  VectorXd jacobian_determinants(const Eigen::Ref<const RowMatrixX3d>& P, int threads = 0) const {
    frame::check_control_points(*topo_, P, "jacobian_determinants");
    const auto s = rest_state();
    VectorXd det(n_vertices());
    frame::for_each_jacobian(*topo_, *s, P, threads, [&](Index v, double* j) {
      det[v] = j[0] * (j[4] * j[8] - j[5] * j[7]) - j[1] * (j[3] * j[8] - j[5] * j[6]) +
               j[2] * (j[3] * j[7] - j[4] * j[6]);
    });
    return det;
  }

  /// Exact unit normals of the deformed surface, cof(J_v) n_v normalised per vertex
  /// (deformed_normals_exact of jacobians(P) and N0), without the #V x 9 Jacobians:
  /// blocks of them in a small buffer.
  /// @param P   N x 3 control points
  /// @param N0  #V x 3 rest normals (caller order; need not be unit)
  /// @returns #V x 3 unit normals (zero where cof(J) n vanishes)
  RowMatrixX3d deformed_normals(const Eigen::Ref<const RowMatrixX3d>& P, const Eigen::Ref<const RowMatrixX3d>& N0,
                                int threads = 0) const {
    RowMatrixX3d N(n_vertices(), 3);
    deformed_normals(P, N0, N.data(), threads);
    return N;
  }
  /// deformed_normals() into the caller's #V x 3 row-major array `out` (the same bits).
  void deformed_normals(const Eigen::Ref<const RowMatrixX3d>& P, const Eigen::Ref<const RowMatrixX3d>& N0,
                        double* out, int threads = 0) const {
    frame::check_control_points(*topo_, P, "deformed_normals");
    VPFFD_CHECK(N0.rows() == n_vertices(), "deformed_normals: ", N0.rows(), " rest normals for ", n_vertices(),
                " vertices");
    VPFFD_CHECK(N0.allFinite(), "deformed_normals: the rest normals contain NaN or Inf");
    const auto s = rest_state();
    const int twist = twist_axis(lattice());
    const RowMatrixX3d& V = *s->V;
    frame::for_each_jacobian(*topo_, *s, P, threads, [&](Index v, double* j) {
      unmirror_jacobian(lattice(), twist, V.row(v).transpose(), j);
      const Vector3d n = detail::cofactor_normal(j, N0.row(v).transpose());
      for (int a = 0; a < 3; ++a) out[3 * v + a] = n[a];
    });
  }

  /// B^T w: sum_v B_c(u_v) w_v for each distinct control point c (the copies of a
  /// periodic point summed), the transpose of ffd(), without the #V x N matrix: the
  /// frames' scatter, in fixed chunks summed in order (the same bits for any thread count).
  /// @param w  #V values per vertex (caller order)
  /// @returns n_control_points() sums
  VectorXd basis_transpose(const Eigen::Ref<const VectorXd>& w, int threads = 0) const {
    VPFFD_CHECK(w.size() == n_vertices(), "basis_transpose: ", w.size(), " values for ", n_vertices(), " vertices");
    VPFFD_CHECK(w.allFinite(), "basis_transpose: the values contain NaN or Inf");
    const auto s = rest_state();
    const std::vector<std::int32_t>& order = *s->order;
    const Index nv = n_vertices();
    const Index N = topo_->n_cells();
    const int chunks = detail::scatter_chunks(nv, N);
    std::vector<double> buf(static_cast<size_t>(chunks) * N, 0.0);
    parallel_chunks(nv, chunks, threads, [&](int c, Index b, Index e) {
      detail::scatter(tables(), s->embedding, &s->runs, [&](Index i) { return w[order[i]]; },
                      buf.data() + static_cast<size_t>(c) * N, b, e);
    });
    return fold(ties(), detail::sum_chunks(buf, chunks, N, threads));
  }

  /// #V x N vertex basis matrix: ffd(P) == B * P.
  CsrMatrix basis_matrix(int threads = 0) const {
    const auto s = rest_state();
    return vertex_basis_matrix(tables(), permute_embedding(s->embedding, *s->rank), threads);
  }

  /// The paper's N x F face matrix, built on first use after a move and kept. Its
  /// column j is face face_processing_order()[j] (the identity without parts).
  const CsrMatrix& face_matrix(int threads = 0) const {
    const auto s = rest_state();
    return vpffd::face_matrix(*topo_, *s, threads);
  }

  /// Volume coefficients of `axis` (0, 1, 2) for the current vertices X (#V x 3)
  /// (for an open mesh: of the cone volume from origin()).
  AxisCoefficients volume_coefficients(const Eigen::Ref<const RowMatrixX3d>& X, int axis,
                                       CoefficientMethod method = CoefficientMethod::Traversal,
                                       int threads = 0) const {
    VPFFD_CHECK(X.rows() == n_vertices(), "volume_coefficients: X has ", X.rows(), " rows, expected ",
                n_vertices());
    VPFFD_CHECK(axis >= 0 && axis < 3, "volume_coefficients: axis ", axis, " not in 0..2");
    const auto s = rest_state();
    const std::vector<std::int32_t>& order = *s->order;
    RowMatrixX3d Xs(n_vertices(), 3);
    for (Index i = 0; i < n_vertices(); ++i) Xs.row(i) = X.row(order[i]);
    return frame::coefficients(*topo_, *s, Xs.data(), axis, method, threads);
  }

  /// One frame: plain FFD with control points P (N x 3), then the volume
  /// correction and point constraints of `opt`.
  /// @throws InvalidInputError for bad options, SolverError when no correction exists
  DeformResult deform(const Eigen::Ref<const RowMatrixX3d>& P, const CorrectionOptions& opt) const {
    return deform(P, opt, nullptr);
  }
  /// deform() with the vertices written into the caller's #V x 3 row-major array
  /// `out` (the same bits; the result's `vertices` is then empty). Null: into the result.
  DeformResult deform(const Eigen::Ref<const RowMatrixX3d>& P, const CorrectionOptions& opt, double* out) const {
    const auto s = rest_state();
    return frame::run_frame(*topo_, *s, P, opt, out);
  }

  /// Checks P and `opt` and prepares what any backend needs for the frame.
  /// @throws InvalidInputError with the same messages as deform()
  FramePlan plan(const Eigen::Ref<const RowMatrixX3d>& P, const CorrectionOptions& opt) const {
    const auto s = rest_state();
    return frame::make_plan(*topo_, *s, P, opt);
  }

 private:
  /// The current state, for the reference accessors (valid until the next move).
  const RestState& current() const { return *rest_state(); }

  /// Makes `next` the current rest state (move_mutex_ held). The replaced state stays
  /// alive while frames hold it; if none does, its buffers serve the next move.
  void publish(std::shared_ptr<RestState> next) {
    std::shared_ptr<const RestState> old;
    {
      std::lock_guard<std::mutex> lock(state_mutex_);
      old = std::move(state_);
      state_ = std::move(next);
    }
    recycle(std::move(old), scratch_);
  }

  std::shared_ptr<const FrameTopology> topo_;
  mutable std::mutex move_mutex_;  ///< moves one at a time (and scratch_)
  MoveScratch scratch_;            ///< buffers of replaced states, for the next move
  mutable std::mutex state_mutex_;  ///< guards the pointer state_ only (not what it points to)
  std::shared_ptr<const RestState> state_;
};

}  // namespace vpffd
