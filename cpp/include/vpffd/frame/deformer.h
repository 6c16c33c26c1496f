#pragma once
/// @file deformer.h
/// The frame layer: from control points to corrected vertices, above ffd/, volume/
/// and correction/ (docs/architecture.md).
/// Volume-preserving B-spline FFD of one triangle mesh (Hahmann et al. 2012):
/// a stateful object that embeds the mesh once and then deforms it for any
/// number of control point sets (frames).
///
/// @code
///   vpffd::Deformer d(V, F, lattice);
///   auto r = d.deform(P, {});   // r.vertices, r.volume == d.rest_volume()
/// @endcode
///
/// Threads: every public member may be called from any number of threads at once,
/// moves of the rest mesh (set_rest_vertices, set_rest_offsets) included. Frames
/// (deform, plan, ffd, jacobians, jacobian_determinants, deformed_normals,
/// basis_transpose, basis_matrix, volume_coefficients, rest volumes) run side by
/// side; a move waits for the frames in flight and holds back new ones
/// (core/rest_lock.h), so each frame sees the rest state before the move or after it,
/// never a mix. Accessors that return references into the rest state
/// (rest_vertices, base_vertices, processing_order, processing_embedding,
/// processing_faces, processing_adjacency, face_matrix, part_start) are valid until
/// the next move: a caller that may race with one holds read_lock() while it uses
/// them.
///
/// Length: one class because its set-up (embedding, cell order, renumbered faces,
/// rings), its plan() and its frame loop share that private state; the constraint
/// helpers and the plan's type live in correction/ (constraints.h, plan.h).

#include <algorithm>
#include <chrono>
#include <cstring>
#include <exception>
#include <memory>
#include <mutex>
#include <shared_mutex>
#include <string>

#include "vpffd/core/rest_lock.h"
#include "vpffd/correction/constraints.h"
#include "vpffd/correction/options.h"
#include "vpffd/correction/plan.h"
#include "vpffd/correction/solve.h"
#include "vpffd/correction/tied_solve.h"
#include "vpffd/frame/rest_volume.h"
#include "vpffd/ffd/basis_matrix.h"
#include "vpffd/ffd/cell_runs.h"
#include "vpffd/ffd/kernels.h"
#include "vpffd/ffd/normals.h"
#include "vpffd/ffd/points.h"
#include "vpffd/ffd/reorder.h"
#include "vpffd/ffd/vertex_order.h"
#include "vpffd/lattice/embed.h"
#include "vpffd/lattice/periodic.h"
#include "vpffd/mesh/parts.h"
#include "vpffd/mesh/validate.h"
#include "vpffd/volume/coefficients.h"
#include "vpffd/volume/part_coefficients.h"
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
      : lattice_(std::move(L)), F_(F), policy_(policy), nv_(V.rows()) {
    validate_mesh(V, F_, "Deformer");
    validate_lattice(lattice_);
    ties_ = make_ties(lattice_);
    if (parts) {
      VPFFD_CHECK(Index(parts->vertex_part.size()) == V.rows() && parts->count >= 1 &&
                      Index(parts->labels.size()) == parts->count,
                  "Deformer: the parts are for another mesh (", parts->vertex_part.size(), " vertex labels, ",
                  V.rows(), " vertices)");
      require_closed_parts(F_, *parts);
      parts_ = *parts;
      has_parts_ = true;
    }
    tables_ = basis_tables(lattice_);
    edges_ = edge_report(F_);
    origin_ = 0.5 * (lattice_.box_min + lattice_.box_max);
    set_face_order();
    embed_rest(V, threads, "Deformer");
  }

  /// Moves the rest mesh to X (same faces): the next frame deforms X as a Deformer
  /// built on it would (same embedding, processing order, rest volumes; the same
  /// results bit for bit). The faces, their checks and the parts are kept, and X
  /// becomes the base of later set_rest_offsets. The rest volumes are summed on first use (frame/rest_volume.h).
  /// Safe beside frames on other threads: it waits for those in flight. With parts, those whose rows of X are their rest
  /// positions, bit for bit, keep their embedding: where at most half of the vertices
  /// move, only the moved parts are embedded (reposition_parts).
  /// @param[in] X  #V x 3 new rest vertices
  /// @throws InvalidInputError for a wrong shape, non-finite coordinates, or vertices
  ///         outside the lattice box (unless built with OutsidePolicy::Extrapolate);
  ///         the Deformer is unchanged then.
  void set_rest_vertices(const Eigen::Ref<const RowMatrixX3d>& X, int threads = 0) {
    VPFFD_CHECK(X.rows() == n_vertices(), "set_rest_vertices: ", X.rows(), " vertices, the mesh has ", n_vertices(),
                " (the faces stay; give every vertex a new position)");
    std::unique_lock<RestLock> moving(rest_lock_);  // waits for the frames in flight
    try {
      // Parts whose rows of X are their rest positions keep their embedding.
      if (!(has_parts_ && reposition_parts(X, threads))) embed_rest(X, threads, "set_rest_vertices");
      base_.resize(0, 3);  // later offsets move from X
      offsets_.resize(0, 3);
    } catch (const InvalidInputError&) {
      // The embedding refuses non-finite coordinates (with points too far away) in the
      // pass it makes anyway; only a refused move looks for them, to name them as such.
      require_finite_rows(X, "set_rest_vertices");
      throw;
    }
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
  /// most half of the vertices move, only the moved parts are embedded (move_parts).
  /// @param[in] offsets  n_parts() x 3 translations, in the parts' order (part_labels)
  /// @throws InvalidInputError for a wrong shape, non-finite offsets, or vertices moved
  ///         outside the lattice box (unless built with OutsidePolicy::Extrapolate); the
  ///         Deformer is unchanged then.
  void set_rest_offsets(const Eigen::Ref<const RowMatrixX3d>& offsets, int threads = 0) {
    VPFFD_CHECK(offsets.rows() == n_parts(), "set_rest_offsets: ", offsets.rows(), " offsets, expected one per part (",
                n_parts(), has_parts_ ? " parts)" : ": the Deformer has no parts, so one for the whole mesh)");
    for (Index k = 0; k < offsets.rows(); ++k)
      VPFFD_CHECK(offsets.row(k).allFinite(), "set_rest_offsets: offset ", k, " (", offsets(k, 0), ", ",
                  offsets(k, 1), ", ", offsets(k, 2), ") is not finite");
    std::unique_lock<RestLock> moving(rest_lock_);  // waits for the frames in flight
    const bool first = base_.rows() == 0;
    // Parts whose offset is the one they have (bit for bit) keep their vertices, cells
    // and embedding: a move of some parts only re-embeds those (move_parts).
    if (!first && has_parts_ && offsets_.rows() == offsets.rows() && offset_parts(offsets, threads)) return;
    if (first) base_ = V_;  // V_'s rest volumes (known or not) are then the base's too
    RowMatrixX3d& X = spare_rest_;
    X.resize(n_vertices(), 3);
    const std::int32_t* part = has_parts_ ? parts_.vertex_part.data() : nullptr;
    parallel_range(n_vertices(), threads, [&](Index b, Index e) {
      for (Index v = b; v < e; ++v) {
        const Index k = part ? Index(part[v]) : 0;
        for (int a = 0; a < 3; ++a) X(v, a) = base_(v, a) + offsets(k, a);
      }
    });
    // Each part is closed (require_closed_parts), or the whole mesh is: translations
    // keep every volume.
    const bool keep_volumes = has_parts_ || is_closed();
    try {
      embed_rest(X, threads, "set_rest_offsets", keep_volumes ? &base_ : nullptr, /*adopt=*/true);
    } catch (...) {
      if (first) base_.resize(0, 3);
      throw;
    }
    offsets_ = offsets;
  }

  /// Whether the rest mesh is its base moved by set_rest_offsets (base_vertices()).
  bool rest_is_offset() const { return base_.rows() != 0; }
  /// The positions set_rest_offsets moves from (empty before the first such move).
  const RowMatrixX3d& base_vertices() const { return base_; }

  /// With parts: which of them have vertices outside the lattice box (the test of
  /// embed()), to name them in its error, e.g. an object that swam out of the lattice
  /// ("" when none is, or without parts; also the Vulkan backend's messages).
  std::string parts_outside(const Eigen::Ref<const RowMatrixX3d>& V) const {
    if (!has_parts_ || policy_ != OutsidePolicy::Error || V.rows() != Index(parts_.vertex_part.size())) return {};
    std::vector<Index> out(parts_.count, 0), size(parts_.count, 0);
    const bool periodic = lattice_.any_periodic();
    for (Index v = 0; v < V.rows(); ++v) {
      const int k = parts_.vertex_part[v];
      ++size[k];
      const Vector3d x = periodic ? wrap_point(lattice_, V.row(v).transpose()) : Vector3d(V.row(v).transpose());
      bool outside = !x.allFinite();
      for (int a = 0; a < 3; ++a) outside |= !accepted_box(lattice_, a).contains(x[a]);
      out[k] += outside;
    }
    std::string named;
    int n = 0;
    for (int k = 0; k < parts_.count; ++k) {
      if (out[k] == 0) continue;
      if (n++ < 8)
        named += detail::concat(n > 1 ? ", " : "", "part ", k, " (label ", parts_.labels[k], "): ", out[k], " of its ",
                                size[k], " vertices");
    }
    if (n == 0) return {};
    return detail::concat("; parts outside: ", named, n > 8 ? detail::concat(" and ", n - 8, " more") : "");
  }

  Deformer(const Deformer&) = delete;
  Deformer& operator=(const Deformer&) = delete;

  /// Holds back moves of the rest mesh while the caller reads the references below
  /// (frames take it themselves; taking it twice on one thread may deadlock).
  std::shared_lock<RestLock> read_lock() const { return std::shared_lock<RestLock>(rest_lock_); }

  const Lattice& lattice() const { return lattice_; }
  const RowMatrixX3d& rest_vertices() const { return V_; }
  const RowMatrixX3i& faces() const { return F_; }
  Index n_vertices() const { return nv_; }
  Index n_faces() const { return F_.rows(); }
  /// Control points a frame takes: the distinct ones of a periodic lattice.
  Index n_control_points() const { return ties_.n_distinct; }
  /// The periodic tie map (identity without periodic axes).
  const Ties& ties() const { return ties_; }
  const EdgeReport& edges() const { return edges_; }
  bool is_closed() const { return edges_.closed(); }
  /// Per-vertex basis data in the caller's vertex order (a copy).
  Embedding embedding() const {
    std::shared_lock<RestLock> frame(rest_lock_);
    return permute_embedding(embedding_, rank_);
  }
  /// Processing order of the frames: position -> vertex index (sorted by cell).
  /// Other backends run in the same order with the three views below.
  const std::vector<std::int32_t>& processing_order() const { return order_; }
  /// Per-vertex basis data in processing order.
  const Embedding& processing_embedding() const { return embedding_; }
  /// Faces in face_processing_order(), numbered by processing position. Built on
  /// first use after each change of the processing order and kept: the CPU's
  /// volume-preserving frames of a closed mesh do not need them (the weights come
  /// from the fans), so a moving object's set_rest_vertices does not renumber them.
  const RowMatrixX3i& processing_faces() const {
    std::lock_guard<std::mutex> lock(faces_mutex_);
    if (faces_stale_) {
      Fs_.resize(F_.rows(), 3);
      parallel_range(F_.rows(), 0, [&](Index b, Index e) {
        for (Index f = b; f < e; ++f)
          for (int c = 0; c < 3; ++c) Fs_(f, c) = rank_[F_(face_order_[f], c)];
      });
      faces_stale_ = false;
    }
    return Fs_;
  }
  /// Vertex -> faces lists of processing_faces().
  /// Built on first use and kept (CPU frames use the vertex rings instead).
  const VertexFaces& processing_adjacency() const {
    std::lock_guard<std::mutex> lock(adjacency_mutex_);
    if (!adjacency_) adjacency_ = std::make_unique<VertexFaces>(vertex_faces(processing_faces(), n_vertices()));
    return *adjacency_;
  }
  const BasisTables& tables() const { return tables_; }
  OutsidePolicy outside_policy() const { return policy_; }
  /// Reference point of the volume sums (the lattice box centre).
  const Vector3d& origin() const { return origin_; }

  /// Whether the Deformer was built with parts (then n_parts() may still be 1).
  bool has_parts() const { return has_parts_; }
  /// Number of parts (1 without parts: the whole mesh).
  int n_parts() const { return parts_.count; }
  /// The parts (vertex_part is empty without parts).
  const MeshParts& parts() const { return parts_; }
  /// Each part's vertices in processing order: [part_start()[k], part_start()[k+1]).
  const std::vector<Index>& part_start() const { return part_start_; }
  /// Each part's faces: [part_face_start()[k], part_face_start()[k+1]) of
  /// processing_faces() and of part_faces() (K + 1; [0, F] without parts).
  const std::vector<Index>& part_face_start() const { return face_start_; }
  /// With parts: the faces in face_processing_order(), in the caller's vertex numbering
  /// (each part's faces together); empty without parts. Fixed at construction.
  const RowMatrixX3i& part_faces() const { return Fp_; }
  /// Enclosed volume of each part of the rest mesh (K; the whole mesh without parts,
  /// and then only when it is closed). @throws InvalidInputError for an open mesh
  VectorXd rest_part_volumes() const {
    if (!has_parts_) return VectorXd::Constant(1, rest_volume());
    std::shared_lock<RestLock> frame(rest_lock_);
    return rest_volumes().parts;
  }

  /// Enclosed volume of the rest mesh, summed on its first use after a move
  /// (frame/rest_volume.h) and kept. @throws InvalidInputError if it is not
  /// closed, unless `allow_open` (then: the cone volume from origin()).
  double rest_volume(bool allow_open = false) const {
    if (!allow_open) require_closed(edges_, "rest_volume");
    std::shared_lock<RestLock> frame(rest_lock_);
    return rest_volumes().total;
  }

  /// Whether the rest volume is summed already (rest_volume() then costs nothing).
  bool rest_volume_known() const { return rest_volumes_.known(); }

  /// The rest volume a move to X would give, without moving: the same sum, faces
  /// and parts, so the same bits as rest_volume(true) after set_rest_vertices(X)
  /// (for a rest mesh this Deformer no longer holds). X is not embedded: its
  /// vertices may lie anywhere.
  /// @throws InvalidInputError for a wrong shape or a volume past double range
  double rest_volume_of(const Eigen::Ref<const RowMatrixX3d>& X, int threads = 0) const {
    VPFFD_CHECK(X.rows() == n_vertices(), "rest_volume_of: ", X.rows(), " vertices, the mesh has ", n_vertices());
    return measure_rest(X, threads, "rest_volume_of").total;
  }

  /// Memory the Deformer holds, in bytes per vertex: the embedding (36), the
  /// vertex and face orders (and a closed mesh's weight order, 4), the faces (as
  /// given, renumbered and, with parts, grouped by part), the vertex fans (closed
  /// mesh, ~28-36: rows of 6-7 and tails) or rings (open, ~52), the cell runs (with
  /// 24 K bytes of basis values for each vertex in a run shorter than kShortRun: 96
  /// for cubic lattices), the rest vertices and, once built, the vertex-face lists
  /// (about 190 bytes for a closed mesh, F = 2V, with the lists; 28 less without;
  /// ~100 more where all vertices are in short runs); 40 more once the rest
  /// mesh has moved (the next move's buffers: embedding 36, cells 4), and 4 while the
  /// adjacency waits to be relabelled after moves (the order it is in); 48 more after
  /// set_rest_offsets (the base positions and the buffer of the moved ones), and 4
  /// once it has moved only some parts (move_parts: each part's vertices).
  double bytes_per_vertex() const {
    std::shared_lock<RestLock> frame(rest_lock_);
    const double per_int = sizeof(std::int32_t);
    double bytes = double(V_.size() + base_.size() + spare_rest_.size()) * sizeof(double) +
                   double(F_.size() + Fp_.size()) * per_int;
    {
      std::lock_guard<std::mutex> lock(faces_mutex_);
      bytes += double(Fs_.size()) * per_int;
    }
    bytes += double(order_.size() + rank_.size() + face_order_.size() + weight_order_.size()) * per_int;
    {
      std::lock_guard<std::mutex> lock(adjacency_mutex_);
      if (adjacency_) bytes += double(adjacency_->indptr.size() + adjacency_->faces.size()) * per_int;
    }
    {
      std::lock_guard<std::mutex> lock(adjacency_sync_mutex_);
      bytes += double(rings_.indptr.size() + rings_.pairs.size() + adjacency_order_.size()) * per_int +
               double(fans_.bytes());
    }
    bytes += double(spare_cells_.size() + part_vertices_.size()) * per_int;
    bytes += double(n_vertices() + spare_embedding_.size()) * Embedding::bytes_per_point;
    bytes += double(runs_.bytes());
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
    check_control_points(P, "ffd");
    std::shared_lock<RestLock> frame(rest_lock_);
    eval_ffd(P, out, threads, order_.data());
  }

  /// Jacobians dD/dx at the vertices: #V x 9, row-major 3x3 per vertex.
  RowMatrixXd jacobians(const Eigen::Ref<const RowMatrixX3d>& P, int threads = 0) const {
    check_control_points(P, "jacobians");
    std::shared_lock<RestLock> frame(rest_lock_);
    const int twist = twist_axis(lattice_);
    RowMatrixXd J(n_vertices(), 9);
    for_each_jacobian(P, threads, [&](Index v, double* j) {
      unmirror_jacobian(lattice_, twist, V_.row(v).transpose(), j);
      std::copy(j, j + 9, J.row(v).data());
    });
    return J;
  }

  /// det dD/dx at the vertices (#V, caller order): the local volume ratio of the FFD
  /// (below 1 compressed, above 1 expanded, <= 0 folded). The same values as the
  /// determinants of jacobians(), without its #V x 9 arrays: blocks of Jacobians in a
  /// small buffer. (A twist seam's mirroring flips two columns: det is unchanged.)
  VectorXd jacobian_determinants(const Eigen::Ref<const RowMatrixX3d>& P, int threads = 0) const {
    check_control_points(P, "jacobian_determinants");
    std::shared_lock<RestLock> frame(rest_lock_);
    VectorXd det(n_vertices());
    for_each_jacobian(P, threads, [&](Index v, double* j) {
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
    check_control_points(P, "deformed_normals");
    VPFFD_CHECK(N0.rows() == n_vertices(), "deformed_normals: ", N0.rows(), " rest normals for ", n_vertices(),
                " vertices");
    VPFFD_CHECK(N0.allFinite(), "deformed_normals: the rest normals contain NaN or Inf");
    std::shared_lock<RestLock> frame(rest_lock_);
    const int twist = twist_axis(lattice_);
    for_each_jacobian(P, threads, [&](Index v, double* j) {
      unmirror_jacobian(lattice_, twist, V_.row(v).transpose(), j);
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
    std::shared_lock<RestLock> frame(rest_lock_);
    const Index nv = n_vertices();
    const Index N = Index(tables_.dims[0]) * tables_.dims[1] * tables_.dims[2];
    const int chunks = detail::scatter_chunks(nv, N);
    std::vector<double> buf(static_cast<size_t>(chunks) * N, 0.0);
    parallel_chunks(nv, chunks, threads, [&](int c, Index b, Index e) {
      detail::scatter(tables_, embedding_, &runs_, [&](Index i) { return w[order_[i]]; },
                      buf.data() + static_cast<size_t>(c) * N, b, e);
    });
    return fold(ties_, detail::sum_chunks(buf, chunks, N, threads));
  }

  /// #V x N vertex basis matrix: ffd(P) == B * P.
  CsrMatrix basis_matrix(int threads = 0) const {
    std::shared_lock<RestLock> frame(rest_lock_);
    return vertex_basis_matrix(tables_, permute_embedding(embedding_, rank_), threads);
  }

  /// Processing order of the faces: position -> face index (the columns of face_matrix()).
  const std::vector<std::int32_t>& face_processing_order() const { return face_order_; }

  /// The paper's N x F face matrix, built on first use and kept. Its column j
  /// is face face_processing_order()[j] (the identity without parts).
  const CsrMatrix& face_matrix(int threads = 0) const {
    std::lock_guard<std::mutex> lock(face_matrix_mutex_);
    if (!face_matrix_)
      face_matrix_ = std::make_unique<CsrMatrix>(face_basis_matrix(tables_, embedding_, processing_faces(), threads));
    return *face_matrix_;
  }

  /// Volume coefficients of `axis` (0, 1, 2) for the current vertices X (#V x 3)
  /// (for an open mesh: of the cone volume from origin()).
  AxisCoefficients volume_coefficients(const Eigen::Ref<const RowMatrixX3d>& X, int axis,
                                       CoefficientMethod method = CoefficientMethod::Traversal,
                                       int threads = 0) const {
    VPFFD_CHECK(X.rows() == n_vertices(), "volume_coefficients: X has ", X.rows(), " rows, expected ",
                n_vertices());
    VPFFD_CHECK(axis >= 0 && axis < 3, "volume_coefficients: axis ", axis, " not in 0..2");
    std::shared_lock<RestLock> frame(rest_lock_);
    RowMatrixX3d Xs(n_vertices(), 3);
    for (Index i = 0; i < n_vertices(); ++i) Xs.row(i) = X.row(order_[i]);
    return coefficients(Xs.data(), axis, method, threads);
  }

  /// One frame: plain FFD with control points P (N x 3), then the volume
  /// correction and point constraints of `opt`.
  /// @throws InvalidInputError for bad options, SolverError when no correction exists
  DeformResult deform(const Eigen::Ref<const RowMatrixX3d>& P, const CorrectionOptions& opt) const {
    return deform(P, opt, nullptr);
  }
  /// deform() with the vertices written into the caller's #V x 3 row-major array
  /// `out` (the same bits; the result's `vertices` is then empty). Null: into the result.
  DeformResult deform(const Eigen::Ref<const RowMatrixX3d>& P, const CorrectionOptions& opt, double* out) const;

  /// Checks P and `opt` and prepares what any backend needs for the frame.
  /// @throws InvalidInputError with the same messages as deform()
  FramePlan plan(const Eigen::Ref<const RowMatrixX3d>& P, const CorrectionOptions& opt) const {
    std::shared_lock<RestLock> frame(rest_lock_);
    return plan_locked(P, opt);
  }

 private:
  /// A volume-preserving frame of a closed mesh: refuses a rest volume below the
  /// normal doubles (a mesh of extent ~1e-150: its volume underflows, and "keeping"
  /// 0 would keep nothing), and targets that are zero or of the other sign than the
  /// rest volume (each part's with parts) unless `allow_inversion`, and targets more
  /// than 1e30 times larger or smaller than the rest volume. The same words on every
  /// backend (the Vulkan backend plans through this Deformer).
  static constexpr double kMaxVolumeRatio = 1e30;
  void check_targets(const FramePlan& pl, bool allow_inversion) const {
    const RestVolumes& rest = rest_volumes();
    const int K = has_parts_ ? parts_.count : 1;
    const Vector3d ext = lattice_.box_max - lattice_.box_min;
    for (int k = 0; k < K; ++k) {
      const double r = has_parts_ && K > 1 ? rest.parts[k] : rest.total;
      const double t = has_parts_ ? pl.part_targets[k] : pl.target;
      const std::string which = K > 1 ? detail::concat(" of part ", k) : std::string();
      VPFFD_CHECK(std::abs(r) >= std::numeric_limits<double>::min(), "deform: the rest volume", which, " (", r,
                  ") is below the smallest normal double (2.2e-308): it underflows at this scale (lattice box ",
                  ext.maxCoeff(), " wide), so no correction can keep it; scale the mesh and lattice up (by a power "
                  "of two) and the result back");
      if (!allow_inversion)
        VPFFD_CHECK(t != 0.0 && (t > 0) == (r > 0), "deform: the target volume", which, " (", t,
                    ") is zero or of the other sign than the rest volume (", r,
                    "): the surface would be flattened or turned inside out; pass allow_inversion=True if that "
                    "is meant");
      // A volume 1e30 times the rest volume moves vertices ~1e10 times the mesh's size:
      // past that the device's float32 positions (relative to the box, 3.4e38) run out
      // well before double's. Both backends refuse the same targets.
      // (A zero target, allowed with allow_inversion above, flattens: no bound below.)
      VPFFD_CHECK(std::abs(t) <= kMaxVolumeRatio * std::abs(r) &&
                      (t == 0.0 || std::abs(t) * kMaxVolumeRatio >= std::abs(r)),
                  "deform: the target volume", which, " (", t, ") is ", std::abs(t / r),
                  " times the rest volume (", r, "): more than 1e30 times larger or smaller, which would move "
                  "vertices far beyond the lattice (the Vulkan backend's float32 positions cannot hold them); give "
                  "a target within a factor of 1e30 of the rest volume");
    }
  }

  /// plan() with the rest lock held by the caller (deform()).
  FramePlan plan_locked(const Eigen::Ref<const RowMatrixX3d>& P, const CorrectionOptions& opt) const;

  /// The rest volumes of V (the rest vertices or any others in their place): with
  /// parts each part's over its faces, their sum the total; one face pass either way.
  RestVolumes measure_rest(const Eigen::Ref<const RowMatrixX3d>& V, int threads, const char* where) const {
    return measure_rest_volumes(V, F_, has_parts_ ? &Fp_ : nullptr, face_start_, origin_, threads, where);
  }
  /// Those of V_, summed on first use.
  const RestVolumes& rest_volumes() const {
    return rest_volumes_.get([&] { return measure_rest(volumes_of_base_ ? base_ : V_, 0, "rest_volume"); });
  }

  /// Everything that depends on the rest positions, from V: embedding, processing
  /// orders (by part, then by cell), cell runs, seam shifts. What only some frames
  /// read waits for them: the renumbered faces (processing_faces), the fans or rings
  /// in the new order (sync_adjacency) and the rest volumes (rest_volumes). Computed
  /// aside and then swapped in, so a throw leaves the Deformer as it was.
  /// `volume_base` (set_rest_offsets): V is this mesh translated part by part, whose
  /// rest volumes rest_volumes_ already holds (or sums on first use): they are kept.
  /// `adopt`: V is spare_rest_, swapped into V_ instead of copied.
  void embed_rest(const Eigen::Ref<const RowMatrixX3d>& V, int threads, const char* where,
                  const RowMatrixX3d* volume_base = nullptr, bool adopt = false) {
    const Index nv = V.rows();
    const bool moving = !order_.empty();
    // First only each vertex's cell, reading V in its own order (this pass checks V:
    // the Deformer is unchanged if it throws); the embedding is computed afterwards,
    // straight into the processing order sorted by these cells. (This replaced
    // embedding into the previous order, reading the cells back and permuting the six
    // arrays; with the vectorised embedding loops a move became 0.73-0.82x as costly,
    // bench/results/vm/move_ab_vm.md.)
    std::vector<std::int32_t>& cell = spare_cells_;
    try {
      embed_cells(lattice_, V, policy_, cell, threads, "vertex");
    } catch (const InvalidInputError& e) {
      throw InvalidInputError(std::string(where) + ": " + e.what() + parts_outside(V));
    }
    // The rest volumes wait for their first use (frame/rest_volume.h), unless they
    // might overflow: then they are summed, and refused, here.
    // (Kept volumes passed this when their mesh was set.)
    const bool eager = !volume_base && !rest_volume_stays_finite(lattice_, F_.rows(), V, threads);
    RestVolumes rest;
    if (eager) rest = measure_rest(V, threads, where);
    // Nothing below throws: the Deformer's state is replaced from here on.
    if (adopt) {
      V_.swap(spare_rest_);  // the storage V views is V_'s now
    } else {
      V_.resize(nv, 3);
      parallel_range(nv, threads, [&](Index b, Index e) { V_.middleRows(b, e - b) = V.middleRows(b, e - b); });
    }
    if (!volume_base) rest_volumes_.reset(std::move(rest), eager);
    volumes_of_base_ = volume_base != nullptr;
    forget_face_matrix();
    // Frames run in cell order (vertex_order.h); the faces are renumbered to match (below).
    std::vector<std::int32_t> order =
        counting_sort(cell, Index(tables_.dims[0]) * tables_.dims[1] * tables_.dims[2], threads);
    if (!moving) std::vector<std::int32_t>().swap(cell);  // kept only by a Deformer that moves
    const int K = parts_.count;
    std::vector<Index> part_start(K + 1, 0);
    if (has_parts_) {
      // Each part's vertices together (in cell order within it): a part's
      // coefficients are then the scatter of one range of vertices.
      std::vector<std::int32_t> key(nv);
      for (Index i = 0; i < nv; ++i) key[i] = parts_.vertex_part[order[i]];
      const std::vector<std::int32_t> by_part = counting_sort(key, K, threads);
      std::vector<std::int32_t> sorted(nv);
      for (Index i = 0; i < nv; ++i) sorted[i] = order[by_part[i]];
      order.swap(sorted);
      for (Index i = 0; i < nv; ++i) ++part_start[key[i] + 1];
      for (int k = 0; k < K; ++k) part_start[k + 1] += part_start[k];
    } else {
      part_start[1] = nv;
    }
    // V passed the same checks in embed_cells: this does not throw.
    Embedding& E = spare_embedding_;
    embed_into(lattice_, V, policy_, E, threads, "vertex", order.data());
    std::swap(embedding_, E);  // E keeps the old buffers, for the next move
    // A moved object often keeps its processing order (no vertex changed cell, or all
    // its vertices moved together): then the faces and fans are those it has.
    if (order == order_) {
      set_runs(threads);
      set_seam_shifts(V);
      return;
    }
    std::vector<std::int32_t> rank = inverse_order(order, threads);
    set_runs(threads);
    // The faces keep the mesh's order (each part's together, set in the constructor),
    // renumbered by processing position when first needed (processing_faces). Sorting
    // them by their lowest vertex's position made no face pass faster (measured, 1
    // thread, a face pass over cell-sorted vertices: 163k-vertex icosphere 1.35 ms
    // sorted against 1.25 unsorted, dragon 3.76 against 3.95), and a fixed order needs
    // no re-sort when the rest mesh moves.
    forget_processing_numbering();
    // A closed mesh's weights come from the fans (half the reads); an open one's
    // cone weights need the pairs (VertexFans' separators add zero only with b = p_v).
    // Both are built once, in the mesh's own numbering (from F_ in its face order, so
    // the terms of a weight come in an order no move changes), and relabelled into
    // each processing order. The fans' rows are stored in the first processing
    // order's runs, each run's vertices by valence (weight_order_), and keep their
    // vertices through every move: their entries are relabelled in place, on the
    // first use after a move (sync_adjacency: plain frames do not read them).
    if (!moving) {
      if (is_closed()) {
        const VertexRings rings = vertex_rings(F_, nv);
        std::vector<std::uint8_t> valence(nv);  // the ring's faces (63 for more)
        for (Index v = 0; v < nv; ++v)
          valence[v] = static_cast<std::uint8_t>(std::min(rings.indptr[v + 1] - rings.indptr[v], 63));
        weight_order_ = order_within_runs(runs_.start, order, valence, threads);
        std::vector<std::int32_t> row_vertex(nv);
        for (Index j = 0; j < nv; ++j) row_vertex[j] = order[weight_order_[j]];
        fans_ = pad_fans(permute_fans(vertex_fans(rings), row_vertex, rank, threads), 0, threads,
                         weight_order_.data());
      } else {
        rings_ = permute_rings(vertex_rings(F_, nv), order, rank, threads);
      }
    }
    order_.swap(order);
    rank_.swap(rank);
    if (moving) {
      // `order` now holds the previous order: the fans' and rings' labels are of it,
      // unless they were of an earlier one still (moves without a frame that read them).
      std::lock_guard<std::mutex> lock(adjacency_sync_mutex_);
      if (adjacency_order_.empty()) adjacency_order_.swap(order);
    }
    set_seam_shifts(V);
    part_start_.swap(part_start);
  }

  /// The CSR face matrix (method="csr") is built from the embedding: after a move it
  /// is built again when next needed.
  void forget_face_matrix() {
    std::lock_guard<std::mutex> lock(face_matrix_mutex_);
    face_matrix_.reset();
  }

  /// What is numbered by processing position and rebuilt when next needed, after a
  /// move changed the processing order: the renumbered faces (processing_faces) and
  /// their vertex-face lists. (The fans and rings are relabelled instead:
  /// adjacency_order_, sync_adjacency.)
  void forget_processing_numbering() {
    {
      std::lock_guard<std::mutex> lock(faces_mutex_);
      faces_stale_ = true;
    }
    std::lock_guard<std::mutex> lock(adjacency_mutex_);
    adjacency_.reset();
  }

  /// Each part's vertices in ascending order (a stable sort by part), made on first
  /// use: part k's are [part_start_[k], part_start_[k+1]), as in the processing order.
  void index_part_vertices(int threads) {
    if (part_vertices_.empty()) part_vertices_ = counting_sort(parts_.vertex_part, parts_.count, threads);
  }

  /// A move of some parts only (set_rest_offsets, set_rest_vertices): the parts in
  /// `moved` (n_moved vertices) go to position(k, v, a) (part k, vertex v, axis a); the
  /// others keep their rest positions, cells, places in the processing order and
  /// embedding. Only the moved ones are embedded again, each into its own range of
  /// the order (a part's vertices are together there, sorted by cell and then by
  /// vertex, which sorting a part alone reproduces), so the state is that of the
  /// whole move, bit for bit, but for what the caller sets: the offsets and the rest
  /// volumes. Costs the moved parts' vertices plus the cell runs of the whole mesh: a
  /// car driving over a terrain that other parts share, or one object dragged among
  /// many.
  /// @returns false, having changed nothing, where the whole move is as cheap (over
  ///          half of the vertices moved) or a moved part is refused (the whole move
  ///          then throws its error, which names every part outside)
  template <class Position>
  bool move_parts(const std::vector<int>& moved, Index n_moved, Position&& position, int threads) {
    if (2 * n_moved > n_vertices()) return false;
    // Each moved part: its positions (in ascending vertex order), their cells (the
    // check of the whole move), its new order within the part and its embedding.
    struct Part {
      RowMatrixX3d X;                         ///< in ascending vertex order
      std::vector<std::int32_t> cell, order;  ///< order: its vertices in processing order
      Embedding E;
    };
    std::vector<Part> parts(moved.size());
    const Index n_cells = Index(tables_.dims[0]) * tables_.dims[1] * tables_.dims[2];
    // The parts side by side, each on one thread (one part alone: on all of them).
    // Errors stay in their part (none may leave a parallel region).
    const int inner = moved.size() > 1 ? 1 : threads;
    std::vector<std::exception_ptr> error(moved.size());
    std::vector<char> refused(moved.size(), 0);
    parallel_items(Index(moved.size()), n_moved, threads, [&](Index q) {
      try {
        const int k = moved[q];
        const Index b = part_start_[k], m = part_start_[k + 1] - b;
        Part& P = parts[q];
        P.X.resize(m, 3);
        for (Index i = 0; i < m; ++i)
          for (int a = 0; a < 3; ++a) P.X(i, a) = position(k, Index(part_vertices_[b + i]), a);
        try {
          embed_cells(lattice_, P.X, policy_, P.cell, inner, "vertex");
        } catch (const InvalidInputError&) {
          refused[q] = 1;
          return;
        }
        P.order = counting_sort(P.cell, n_cells, inner);
        embed_into(lattice_, P.X, policy_, P.E, inner, "vertex", P.order.data());
        for (std::int32_t& i : P.order) i = part_vertices_[b + i];  // rows of X -> vertices
      } catch (...) {
        error[q] = std::current_exception();
      }
    });
    for (const std::exception_ptr& e : error)
      if (e) std::rethrow_exception(e);
    for (char r : refused)
      if (r) return false;
    bool reordered = false;
    for (size_t q = 0; q < moved.size() && !reordered; ++q)
      reordered = !std::equal(parts[q].order.begin(), parts[q].order.end(), order_.begin() + part_start_[moved[q]]);
    if (reordered) {
      // The fans' and rings' labels are of the order before this move, unless they
      // were of an earlier one still (embed_rest).
      std::lock_guard<std::mutex> lock(adjacency_sync_mutex_);
      if (adjacency_order_.empty()) adjacency_order_ = order_;
    }
    // Nothing below throws: the Deformer's state is replaced from here on.
    forget_face_matrix();
    for (size_t q = 0; q < moved.size(); ++q) {
      const Index s = part_start_[moved[q]];
      const Part& P = parts[q];
      for (Index i = 0; i < P.X.rows(); ++i) {
        const std::int32_t v = P.order[i];
        V_.row(part_vertices_[s + i]) = P.X.row(i);
        order_[s + i] = v;
        rank_[v] = static_cast<std::int32_t>(s + i);
      }
      for (int a = 0; a < 3; ++a) {
        std::copy(P.E.span[a].begin(), P.E.span[a].end(), embedding_.span[a].begin() + s);
        std::copy(P.E.tau[a].begin(), P.E.tau[a].end(), embedding_.tau[a].begin() + s);
      }
    }
    if (reordered) forget_processing_numbering();
    set_runs(threads);
    set_seam_shifts(V_);
    return true;
  }

  /// set_rest_offsets through move_parts where only some parts' offsets differ from
  /// those of the last offset move (bit for bit). False: not taken (as move_parts).
  bool offset_parts(const Eigen::Ref<const RowMatrixX3d>& offsets, int threads) {
    index_part_vertices(threads);
    std::vector<int> moved;
    Index n_moved = 0;
    for (int k = 0; k < parts_.count; ++k)
      for (int a = 0; a < 3; ++a) {
        const double o = offsets(k, a), was = offsets_(k, a);
        if (std::memcmp(&o, &was, sizeof o) != 0) {
          moved.push_back(k);
          n_moved += part_start_[k + 1] - part_start_[k];
          break;
        }
      }
    if (moved.empty()) return true;  // the whole move would compute the state there is
    if (!move_parts(moved, n_moved, [&](int k, Index v, int a) { return base_(v, a) + offsets(k, a); }, threads))
      return false;
    volumes_of_base_ = true;  // as the whole move: the parts' volumes are translations'
    offsets_ = offsets;
    return true;
  }

  /// set_rest_vertices through move_parts where only some parts' rows of X differ from
  /// the rest positions (bit for bit; each part is read until its first difference,
  /// so a move of every part costs a row per part here). The rest volumes are those
  /// of X, summed on first use, as after the whole move. False: not taken.
  bool reposition_parts(const Eigen::Ref<const RowMatrixX3d>& X, int threads) {
    index_part_vertices(threads);
    std::vector<int> moved;
    Index n_moved = 0;
    for (int k = 0; k < parts_.count; ++k) {
      const Index b = part_start_[k], e = part_start_[k + 1];
      for (Index i = b; i < e; ++i) {
        const Index v = part_vertices_[i];
        const double x[3] = {X(v, 0), X(v, 1), X(v, 2)}, was[3] = {V_(v, 0), V_(v, 1), V_(v, 2)};
        if (std::memcmp(x, was, sizeof x) != 0) {
          moved.push_back(k);
          n_moved += e - b;
          break;
        }
      }
      if (2 * n_moved > n_vertices()) return false;  // the whole move is as cheap
    }
    // Volumes that might overflow are summed, and refused, by the whole move.
    if (!rest_volume_stays_finite(lattice_, F_.rows(), X, threads)) return false;
    if (!moved.empty() && !move_parts(moved, n_moved, [&](int, Index v, int a) { return X(v, a); }, threads))
      return false;
    rest_volumes_.reset(RestVolumes{}, false);  // of X, on first use
    volumes_of_base_ = false;
    return true;
  }

  /// The cell runs of the embedding, with the basis values of their short runs' points
  /// (cache_short_run_basis: a mesh with few points per cell then evaluates them once
  /// per move, not in each of a frame's seven per-point passes).
  void set_runs(int threads) {
    runs_ = cell_runs(embedding_, threads);
    cache_short_run_basis(tables_, embedding_, runs_, threads);
  }

  /// The faces' processing order: the mesh's own, each part's faces together
  /// (a stable sort by part), so a part's face sums are one range of them.
  void set_face_order() {
    const Index nf = F_.rows();
    face_start_.assign(parts_.count + 1, 0);
    if (!has_parts_) {
      face_order_.resize(nf);
      for (Index f = 0; f < nf; ++f) face_order_[f] = static_cast<std::int32_t>(f);
      face_start_[1] = nf;
      return;
    }
    std::vector<std::int32_t> key(nf);
    for (Index f = 0; f < nf; ++f) key[f] = parts_.vertex_part[F_(f, 0)];
    face_order_ = counting_sort(key, parts_.count);
    for (Index f = 0; f < nf; ++f) ++face_start_[key[f] + 1];
    for (int k = 0; k < parts_.count; ++k) face_start_[k + 1] += face_start_[k];
    Fp_.resize(nf, 3);
    for (Index f = 0; f < nf; ++f) Fp_.row(f) = F_.row(face_order_[f]);
  }

  /// Along a "shift" seam a wrapped vertex maps to D(wrapped) + its translation
  /// (lattice/periodic.h), kept per vertex in processing order (order_).
  void set_seam_shifts(const Eigen::Ref<const RowMatrixX3d>& V) {
    seam_shift_.resize(0, 3);
    const RowMatrixX3d T = seam_translations(lattice_, V);
    if (T.rows() == 0) return;
    seam_shift_.resize(T.rows(), 3);
    for (Index i = 0; i < T.rows(); ++i) seam_shift_.row(i) = T.row(order_[i]);
  }


  void check_control_points(const Eigen::Ref<const RowMatrixX3d>& P, const char* where) const {
    VPFFD_CHECK(P.rows() == n_control_points(), where, ": ", P.rows(), " control points, the lattice has ",
                n_control_points());
    VPFFD_CHECK(P.allFinite(), where, ": control points contain NaN or Inf");
  }

  /// The FFD of the vertices into out: row i is processing position i, or vertex
  /// rows[i] when rows is given (order_: the caller's order, without a reordering pass).
  /// Coordinate `skip` (0-2; -1 none) is written as 0 (see first_step_sets).
  void eval_ffd(const Eigen::Ref<const RowMatrixX3d>& P, double* out, int threads,
                const std::int32_t* rows = nullptr, int skip = -1) const {
    const PointColumns Q(expand_points(ties_, P));
    parallel_range(n_vertices(), threads, [&](Index b, Index e) {
      detail::dispatch_order(tables_, [&](auto K) {
        constexpr int k = decltype(K)::value;
        if constexpr (k > 0)
          detail::ffd_runs<k>(tables_, embedding_, runs_, Q.x.data(), Q.y.data(), Q.z.data(), out, b, e, rows, skip);
        else
          detail::ffd_kernel<k>(tables_, embedding_, Q.x.data(), Q.y.data(), Q.z.data(), out, b, e, rows, skip);
      });
      if (seam_shift_.rows() > 0)
        for (Index i = b; i < e; ++i)
          for (int c = 0; c < 3; ++c) out[3 * (rows ? Index(rows[i]) : i) + c] += seam_shift_(i, c);
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
  bool volume_by_coefficients(const CorrectionOptions& opt) const {
    return seam_shift_.rows() == 0 && (parts_.count > 1 || opt.method == CoefficientMethod::Traversal);
  }

  /// The axis whose coordinate a volume-preserving frame's plain FFD leaves out, or -1.
  /// The first axis step's weights do not read that step's own coordinate (a vertex's
  /// weight for x is a sum of 2x2 determinants in y and z), so the FFD computes only
  /// the other two; the step's volume comes from its coefficients
  /// (volume_by_coefficients), and its gather sets the coordinate to B (P + delta) at
  /// once. That saves a third of the FFD. Not for a one-step frame, whose only volume
  /// is summed over the vertices.
  int first_step_sets(const FramePlan& pl, const CorrectionOptions& opt) const {
    if (!pl.correcting || !opt.preserve_volume || opt.axes.size() * opt.rounds < 2) return -1;
    return volume_by_coefficients(opt) ? opt.axes[0] : -1;
  }

  /// The field an axis step's gather adds along its axis: the offsets delta (distinct
  /// points), extended to the tied copies; where the FFD left that coordinate at 0
  /// (`sets`, first_step_sets), the corrected points themselves, Pa + delta (Pa the
  /// step's extended control point coordinates).
  VectorXd gather_field(const VectorXd& delta, const VectorXd& Pa, bool sets) const {
    VectorXd field = expand_offsets(ties_, delta);
    if (sets) field += Pa;
    return field;
  }

  /// Calls f(v, j) for every vertex v (caller index) with j its Jacobian dD/dx (9,
  /// row-major; at a twist seam's wrapped points that of the wrapped twin, see
  /// unmirror_jacobian), computed in blocks of the processing order in a small buffer
  /// (no #V x 9 array). f may change j; it runs on the frame's threads.
  template <class F>
  void for_each_jacobian(const Eigen::Ref<const RowMatrixX3d>& P, int threads, F&& f) const {
    const PointColumns Q(expand_points(ties_, P));
    const Vector3d s = parameter_scale(lattice_);
    parallel_range(n_vertices(), threads, [&](Index b, Index e) {
      constexpr Index kBlock = 256;
      std::vector<double> J(9 * kBlock);
      for (Index c = b; c < e; c += kBlock) {
        const Index ce = std::min(e, c + kBlock);
        detail::jacobian_kernel(tables_, embedding_, runs_, Q.x.data(), Q.y.data(), Q.z.data(), s, J.data(), c, ce, c);
        for (Index i = c; i < ce; ++i) f(Index(order_[i]), J.data() + 9 * (i - c));
      }
    });
  }

  /// Rows of X (processing order) back in the caller's vertex order. Each row read
  /// from where it is (rank_) and written in sequence: written where it goes instead,
  /// the scattered stores cost twice as much (dragon, 1 thread, fused into the last
  /// gather: 5.4-5.9 ms for that gather against 3.6-4.0 for the gather and this copy).
  void to_caller_order(const RowMatrixX3d& Xs, double* dst, int threads) const {
    const double* src = Xs.data();
    parallel_range(Xs.rows(), threads, [&](Index b, Index e) {
      for (Index v = b; v < e; ++v) {
        const double* p = src + 3 * Index(rank_[v]);
        dst[3 * v] = p[0];
        dst[3 * v + 1] = p[1];
        dst[3 * v + 2] = p[2];
      }
    });
  }

  void gather(const VectorXd& D, double* X, int axis, int threads) const {
    parallel_range(n_vertices(), threads, [&](Index b, Index e) {
      detail::dispatch_order(tables_, [&](auto K) {
        constexpr int k = decltype(K)::value;
        if constexpr (k > 0)
          detail::gather_runs<k>(tables_, embedding_, runs_, D.data(), X, axis, b, e);
        else
          detail::gather_kernel<k>(tables_, embedding_, D.data(), X, axis, b, e);
      });
    });
  }

  /// The last gather of a frame (gather_final_kernel): moves X along `axis` by the
  /// offset field D and returns each part's volume (one entry without parts), summed
  /// over the part's pieces (its vertices cut at the fixed chunk boundaries,
  /// detail::part_pieces) in order: the same bits for any thread count.
  VectorXd gather_final(const VectorXd& D, double* X, int axis, const double* w, int threads) const {
    const std::vector<detail::PartPiece> pieces = detail::part_pieces(part_start_, n_vertices());
    std::vector<double> sums(pieces.size(), 0.0);
    parallel_items(Index(pieces.size()), n_vertices(), threads, [&](Index q) {
      const Index b = pieces[q].b, e = pieces[q].e;
      detail::dispatch_order(tables_, [&](auto K) {
        constexpr int k = decltype(K)::value;
        if constexpr (k > 0)
          sums[q] = detail::gather_final_runs<k>(tables_, embedding_, runs_, D.data(), X, axis, w, origin_[axis], b, e);
        else
          sums[q] = detail::gather_final_kernel<k>(tables_, embedding_, D.data(), X, axis, w, origin_[axis], b, e);
      });
    });
    VectorXd out = VectorXd::Zero(Index(part_start_.size()) - 1);
    for (size_t q = 0; q < pieces.size(); ++q) out[pieces[q].part] += sums[q];
    return out;
  }

  // The paper's matrix holds the projection form, which on an open surface
  // differs from the cone volume that is measured and kept.
  void check_method(CoefficientMethod method) const {
    if (!is_closed())
      VPFFD_CHECK(method == CoefficientMethod::Traversal,
                  "deform: method='csr' needs a closed mesh; use method='traversal' with allow_open");
  }

  /// Brings the fans (closed mesh: their entries and weight_order_) or the rings (open
  /// mesh) to the current processing order, if a move left them in an older one
  /// (adjacency_order_): what the moves would each have done, at once (entries are
  /// only relabelled, so the labels are the same whichever moves lie between).
  void sync_adjacency(int threads) const {
    std::lock_guard<std::mutex> lock(adjacency_sync_mutex_);
    if (adjacency_order_.empty()) return;
    const Index nv = n_vertices();
    if (adjacency_order_ != order_) {
      // old position -> new position, and (rings) new position -> old position.
      std::vector<std::int32_t> old_to_new(nv);
      parallel_range(nv, threads, [&](Index b, Index e) {
        for (Index i = b; i < e; ++i) old_to_new[i] = rank_[adjacency_order_[i]];
      });
      if (is_closed()) {
        relabel_fans(fans_, old_to_new, threads);
        parallel_range(nv, threads, [&](Index b, Index e) {
          for (Index j = b; j < e; ++j) weight_order_[j] = old_to_new[weight_order_[j]];
        });
      } else {
        const std::vector<std::int32_t> old_rank = inverse_order(adjacency_order_, threads);
        std::vector<std::int32_t> new_to_old(nv);
        parallel_range(nv, threads, [&](Index b, Index e) {
          for (Index i = b; i < e; ++i) new_to_old[i] = old_rank[order_[i]];
        });
        rings_ = permute_rings(rings_, new_to_old, old_to_new, threads);
      }
    }
    adjacency_order_.clear();
  }

  /// `weights` (#V, may be null) receives the traversal's per-vertex weights;
  /// `measure` false: the traversal leaves the volume 0 (coefficients_fans).
  AxisCoefficients coefficients(const double* X, int axis, CoefficientMethod method, int threads,
                                double* weights = nullptr, bool measure = true) const {
    if (!is_closed()) check_method(method);
    if (method == CoefficientMethod::Csr)
      return coefficients_csr(face_matrix(threads), X, processing_faces(), axis, origin_, threads);
    sync_adjacency(threads);
    if (is_closed())
      return coefficients_fans(tables_, embedding_, fans_, X, axis, origin_, threads, weights, &runs_,
                               weight_order_.data(), measure);
    return coefficients_rings(tables_, embedding_, rings_, X, axis, origin_, threads, true, weights, &runs_, measure);
  }

  Lattice lattice_;
  mutable RestLock rest_lock_;  ///< frames shared, moves exclusive (see the class comment)
  RowMatrixX3d V_;
  RowMatrixX3i F_;
  OutsidePolicy policy_;
  Index nv_;  ///< vertices (fixed: moves keep the mesh)
  Ties ties_;
  RowMatrixX3d seam_shift_;  ///< processing order: what "shift" seams add to wrapped vertices (or empty)
  BasisTables tables_;
  std::vector<std::int32_t> order_;  ///< processing position -> vertex
  std::vector<std::int32_t> rank_;   ///< vertex -> processing position
  /// Closed mesh: fan row -> processing position. The weight passes go row by row:
  /// the rows were laid out in the first processing order's runs (cells), by valence
  /// within a run (order_within_runs), so a vertex's fan is as long as the one
  /// before it for long stretches; the loop's trip count is predicted and the rows
  /// need no padding for the longer fans (padded_fans.h). Scatter, gathers and
  /// volume keep the processing order; the weights are the same numbers in any row
  /// order, so the results do not depend on it. Dragon, xyz frame: 0.82x on a quiet
  /// VM, but up to ~1.1x on 1 thread under memory contention, where the separate
  /// weight pass's traffic costs: 8 % fewer instructions, 18 % more last-level
  /// misses, all sequential (cachegrind counts; bench/results/vm/frame_ab_vm.md).
  mutable std::vector<std::int32_t> weight_order_;
  std::vector<std::int32_t> face_order_;  ///< face processing position -> face (fixed: set_face_order)
  Embedding embedding_;              ///< in processing order
  Embedding spare_embedding_;        ///< set_rest_vertices' buffers for the next embedding
  std::vector<std::int32_t> spare_cells_;  ///< and for the vertices' cells
  CellRuns runs_;                    ///< embedding_'s cell runs
  mutable RowMatrixX3i Fs_;          ///< faces with processing-order indices (processing_faces)
  mutable bool faces_stale_ = true;  ///< Fs_ is of an older processing order
  mutable std::mutex faces_mutex_;
  RowMatrixX3i Fp_;                  ///< with parts: F_'s rows in face_order_ (the rest part volumes)
  EdgeReport edges_;
  mutable std::mutex adjacency_mutex_;
  mutable std::unique_ptr<VertexFaces> adjacency_;  ///< of Fs_, built on first use
  // The vertex adjacency the weights are summed from, in processing positions of
  // adjacency_order_ when that is not empty (a move's relabelling waits for the first
  // read: sync_adjacency), else of order_.
  mutable VertexRings rings_;  ///< of F_ relabelled, for an open mesh (empty for a closed one)
  mutable PaddedFans fans_;    ///< of F_ relabelled, for a closed mesh (empty for an open one)
  mutable std::vector<std::int32_t> adjacency_order_;
  mutable std::mutex adjacency_sync_mutex_;
  Vector3d origin_;
  LazyRestVolumes rest_volumes_;     ///< of V_, or of base_ when volumes_of_base_ (rest_volumes())
  RowMatrixX3d base_;                ///< set_rest_offsets' base positions (empty before its first move)
  RowMatrixX3d spare_rest_;          ///< set_rest_offsets' buffer for the moved positions
  RowMatrixX3d offsets_;             ///< the last set_rest_offsets' offsets (empty before it, and after set_rest_vertices)
  std::vector<std::int32_t> part_vertices_;  ///< move_parts: each part's vertices, ascending, in part_start_'s ranges
  bool volumes_of_base_ = false;     ///< the rest volumes are base_'s (a translation of V_)
  bool has_parts_ = false;
  MeshParts parts_;                  ///< count 1 and no labels without parts
  std::vector<Index> part_start_;    ///< K + 1: each part's vertices in processing order
  std::vector<Index> face_start_;    ///< K + 1: each part's faces in Fs_ (fixed: set_face_order)
  mutable std::mutex face_matrix_mutex_;
  mutable std::unique_ptr<CsrMatrix> face_matrix_;
};

inline FramePlan Deformer::plan_locked(const Eigen::Ref<const RowMatrixX3d>& P, const CorrectionOptions& opt) const {
  static const char axis_name[3] = {'x', 'y', 'z'};
  const Index N = n_control_points();
  check_control_points(P, "deform");
  FramePlan plan;
  if (!ties_.identity) plan.ties = &ties_;
  plan.correcting = opt.preserve_volume || !opt.constraints.empty();
  if (plan.correcting) VPFFD_CHECK(!opt.axes.empty(), "deform: axes is empty; name at least one of x, y, z");
  VPFFD_CHECK(opt.rounds >= 1 && opt.rounds <= kMaxRounds, "deform: rounds is ", opt.rounds, "; expected 1..",
              kMaxRounds);
  for (size_t i = 0; i < opt.axes.size(); ++i) {
    VPFFD_CHECK(opt.axes[i] >= 0 && opt.axes[i] < 3, "deform: axis ", opt.axes[i], " not in 0..2");
    for (size_t j = 0; j < i; ++j)
      VPFFD_CHECK(opt.axes[j] != opt.axes[i], "deform: axes repeats ", axis_name[opt.axes[i]],
                  "; name each axis once (rounds repeats them)");
  }
  plan.inv_weight = VectorXd::Ones(N);
  if (opt.weights.size() > 0) {
    VPFFD_CHECK(opt.weights.size() == N, "deform: ", opt.weights.size(), " weights, expected one per control point (",
                N, ")");
    for (Index c = 0; c < N; ++c)
      VPFFD_CHECK(std::isfinite(opt.weights[c]) && opt.weights[c] > 0 && std::isfinite(1.0 / opt.weights[c]),
                  "deform: weight ", c, " is ", opt.weights[c],
                  "; weights must be finite and positive, and not so small that 1/weight overflows "
                  "(use fixed= to pin control points)");
    plan.inv_weight = opt.weights.cwiseInverse();
  }
  if (!opt.fixed.empty()) {
    VPFFD_CHECK(Index(opt.fixed.size()) == N, "deform: fixed has ", opt.fixed.size(),
                " entries, expected one per control point (", N, ")");
    for (Index c = 0; c < N; ++c)
      if (opt.fixed[c]) plan.inv_weight[c] = 0.0;
  }
  if (opt.preserve_volume && !opt.allow_open) require_closed(edges_, "deform(preserve_volume=True)");
  plan.measure = is_closed() || opt.allow_open;
  // The rest volume is the default target of a volume-preserving frame only: other
  // frames do not sum it (frame/rest_volume.h).
  plan.target = !std::isnan(opt.target_volume) ? opt.target_volume
                : opt.preserve_volume && !has_parts_ ? rest_volumes().total
                                                     : 0.0;
  VPFFD_CHECK(std::isfinite(plan.target), "deform: target_volume is ", plan.target, "; expected a finite number");
  if (has_parts_) {
    const int K = parts_.count;
    if (!opt.part_targets.empty()) {
      VPFFD_CHECK(Index(opt.part_targets.size()) == K, "deform: ", opt.part_targets.size(),
                  " target volumes, expected one per part (", K, ")");
      VPFFD_CHECK(std::isnan(opt.target_volume), "deform: give either one target volume per part or target_volume");
      plan.part_targets = Eigen::Map<const VectorXd>(opt.part_targets.data(), K);
      for (int k = 0; k < K; ++k)
        VPFFD_CHECK(std::isfinite(plan.part_targets[k]), "deform: the target volume of part ", k, " is ",
                    plan.part_targets[k], "; expected a finite number");
    } else if (!std::isnan(opt.target_volume)) {
      VPFFD_CHECK(K == 1, "deform: one target_volume for ", K,
                  " parts; give one target volume per part (a sequence of ", K, " numbers)");
      plan.part_targets = VectorXd::Constant(1, opt.target_volume);
    } else if (opt.preserve_volume) {
      plan.part_targets = rest_volumes().parts;
    } else {
      plan.part_targets = VectorXd::Zero(K);  // read by no frame that does not preserve volume
    }
    plan.target = plan.part_targets.sum();
    VPFFD_CHECK(std::isfinite(plan.target), "deform: the target volumes' sum is ", plan.target,
                "; expected a finite number");
    if (opt.preserve_volume && K > 1)
      VPFFD_CHECK(opt.method == CoefficientMethod::Traversal,
                  "deform: method='csr' keeps one volume; with several parts use method='traversal'");
  } else {
    VPFFD_CHECK(opt.part_targets.empty(), "deform: ", opt.part_targets.size(),
                " target volumes per part, but this Deformer was built without parts");
  }

  if (opt.preserve_volume && !opt.allow_open) check_targets(plan, opt.allow_inversion);

  // Constraint sources: basis rows at their parameters.
  const size_t nc = opt.constraints.size();
  plan.rows.resize(nc);
  RowMatrixX3d pts(static_cast<Index>(nc), 3);
  for (size_t s = 0; s < nc; ++s) {
    const PointConstraint& pc = opt.constraints[s];
    VPFFD_CHECK(pc.target.allFinite(), "deform: constraint ", s, " has a non-finite target");
    if (pc.vertex >= 0) {
      VPFFD_CHECK(pc.vertex < n_vertices(), "deform: constraint ", s, " names vertex ", pc.vertex, ", but there are ",
                  n_vertices(), " vertices");
      pts.row(s) = V_.row(pc.vertex);
    } else {
      VPFFD_CHECK(pc.point.allFinite(), "deform: constraint ", s, " has a non-finite source point");
      pts.row(s) = pc.point.transpose();
    }
  }
  plan.sources = embed(lattice_, pts, policy_, 1, "constraint point");
  // The rows give the wrapped point's image; a "shift" seam would add a translation the
  // right-hand sides do not carry.
  if (seam_translations(lattice_, pts).rows() > 0)
    for (size_t s = 0; s < nc; ++s)
      VPFFD_CHECK(seam_translations(lattice_, pts.row(s)).rows() == 0, "deform: constraint ", s,
                  " has its source outside the box along a periodic axis with the 'shift' seam; give the source "
                  "inside the box (moved by whole extents) and its target moved by the same amount");
  const int per = tables_.order[0] * tables_.order[1] * tables_.order[2];
  for (size_t s = 0; s < nc; ++s) {
    plan.rows[s].index.resize(per);
    plan.rows[s].value.resize(per);
    point_basis_entries(tables_, plan.sources, static_cast<Index>(s), plan.rows[s].index.data(),
                        plan.rows[s].value.data());
  }

  // A constraint along an axis that is not corrected could only be met by luck.
  bool corrected[3] = {false, false, false};
  for (int a : opt.axes) corrected[a] = plan.correcting;
  const double diag = (lattice_.box_max - lattice_.box_min).norm();
  for (size_t s = 0; s < nc; ++s)
    for (int a = 0; a < 3; ++a)
      if (!corrected[a]) {
        const double S = row_dot(plan.rows[s], expand_column(ties_, P.col(a), a));
        VPFFD_CHECK(std::abs(S - opt.constraints[s].target[a]) <= 1e-9 * diag, "deform: constraint ", s,
                    " moves its point along ", axis_name[a], " (from ", S, " to ", opt.constraints[s].target[a],
                    "), but ", axis_name[a], " is not among the corrected axes");
      }

  // Checks that the first axis step would make: made here so that a frame that
  // cannot be corrected fails before any work, with the same message on every backend.
  plan.free_points = count_free_points(plan.inv_weight);
  if (opt.preserve_volume) check_method(opt.method);
  if (plan.correcting)
    check_free_points(opt.preserve_volume ? parts_.count : 0, nc, plan.free_points, axis_name[opt.axes[0]]);
  return plan;
}

inline DeformResult Deformer::deform(const Eigen::Ref<const RowMatrixX3d>& P, const CorrectionOptions& opt,
                                     double* out) const {
  static const char axis_name[3] = {'x', 'y', 'z'};
  using Clock = std::chrono::steady_clock;
  const Index N = n_control_points();
  const int threads = opt.threads;
  DeformResult res;
  FrameTimings& tm = res.timings;
  // A clock read per pass when timings are asked for, a branch otherwise.
  const bool timed = opt.record_timings;
  Clock::time_point t0{}, t = timed ? Clock::now() : Clock::time_point{};
  if (timed) t0 = t;
  auto lap = [&](double& slot) {
    if (!timed) return;
    const Clock::time_point now = Clock::now();
    slot += std::chrono::duration<double, std::milli>(now - t).count();
    t = now;
  };

  // One rest state for the whole frame: a move on another thread waits for it.
  std::shared_lock<RestLock> frame(rest_lock_);
  const FramePlan pl = plan_locked(P, opt);
  const std::vector<SparseVec>& rows = pl.rows;
  lap(tm.plan);

  // --- plain FFD -------------------------------------------------------------
  res.target_volume = opt.preserve_volume ? pl.target : std::numeric_limits<double>::quiet_NaN();
  const int K = parts_.count;
  // Nothing moves after the FFD of an uncorrected frame: it is written straight into
  // the caller's order, and its volume summed over the caller's faces, which (one part:
  // face_order_ is the identity) are processing_faces() face for face, the same terms
  // in the same order.
  const bool direct = !pl.correcting && K == 1;
  const int skip = first_step_sets(pl, opt);
  RowMatrixX3d Xs(direct ? 0 : n_vertices(), 3);  // processing order
  if (!out) {
    res.vertices.resize(n_vertices(), 3);
    out = res.vertices.data();
  }
  if (direct) {
    eval_ffd(P, out, threads, order_.data());
  } else {
    eval_ffd(P, Xs.data(), threads, nullptr, skip);
  }
  double* X = Xs.data();
  res.offsets = RowMatrixX3d::Zero(N, 3);
  lap(tm.ffd);

  // --- axis steps -------------------------------------------------------------
  if (K > 1 && !opt.preserve_volume)
    res.part_volumes_before = part_volumes(X, processing_faces(), face_start_, origin_, threads);
  if (K > 1 && opt.preserve_volume) {
    // One volume row per part in each step; the step's volume record is the whole mesh's.
    // The first step's coefficient pass measures the parts' volumes before any
    // correction (sum_v (x_v - o) w_v over each part's vertices): no face pass for them.
    const int naxes = static_cast<int>(opt.axes.size());
    const int k = naxes * opt.rounds;
    // Each step's weights; the last step's measure the volumes. Every entry is written
    // by a step's pass before it is read: not zeroed (3.5 MB a frame on the dragon).
    std::unique_ptr<double[]> w(new double[n_vertices()]);
    for (int step = 0; step < k; ++step) {
      const int a = opt.axes[step % naxes];
      AxisStep info;
      info.axis = a;
      const bool last = step == k - 1;
      if (step == 0) sync_adjacency(threads);
      const bool sets = step == 0 && skip >= 0;  // X's column a is 0 (first_step_sets)
      const bool by_coefficients = sets || (!last && volume_by_coefficients(opt));
      PartCoefficients co = part_coefficients_rings(tables_, embedding_, fans_, X, a, origin_, part_start_, threads,
                                                    &runs_, weight_order_.data(), w.get(), !by_coefficients);
      const VectorXd Pa = expand_column(ties_, P.col(a) + res.offsets.col(a), a);
      if (by_coefficients) co.volume = co.alpha * (Pa.array() - origin_[a]).matrix();
      lap(tm.coefficients);
      info.volume_before = co.volume.sum();
      if (step == 0) {
        res.part_volumes_before = co.volume;
        res.volume_before = info.volume_before;
      }
      // Equal shares of what each part still misses: after the last axis every part is at its target.
      const VectorXd shares = (pl.part_targets - co.volume) / double(k - step);
      info.share = shares.sum();
      const std::vector<double> rhs = constraint_rhs(rows, opt.constraints, a, Pa);
      const VectorXd delta = solve_tied_parts(pl.ties, co.alpha.data(), co.alpha.cols(), K, shares.data(), rows, rhs,
                                              pl.inv_weight, axis_name[a], &info.sum_squares);
      info.max_offset = delta.cwiseAbs().maxCoeff();
      res.offsets.col(a) += delta;
      res.steps.push_back(info);
      lap(tm.solves);
      const VectorXd field = gather_field(delta, Pa, sets);
      // The last gather measures each part's volume with that step's weights (as the
      // one-part frame below): no face pass after the correction either.
      if (last)
        res.part_volumes = gather_final(field, X, a, w.get(), threads);
      else
        gather(field, X, a, threads);
      lap(tm.gathers);
    }
    res.volume = res.part_volumes.sum();
  } else if (!pl.correcting) {
    // Nothing moves: one volume is both the before and the after.
    if (pl.measure)
      res.volume_before = res.volume =
          direct ? signed_volume(out, F_, origin_, threads)
                 : signed_volume(X, processing_faces(), origin_, threads);
    lap(tm.volume);
  } else if (!opt.preserve_volume) {
    // Constraints alone: the host steps, then each axis's total offsets at once.
    if (pl.measure) res.volume_before = signed_volume(X, processing_faces(), origin_, threads);
    lap(tm.volume);
    constraint_steps(pl, P, opt, res);
    lap(tm.solves);
    for (int a : opt.axes) gather(expand_offsets(ties_, res.offsets.col(a)), X, a, threads);
    lap(tm.gathers);
    if (pl.measure) res.volume = signed_volume(X, processing_faces(), origin_, threads);
    lap(tm.volume);
  } else {
    const int naxes = static_cast<int>(opt.axes.size());
    const int k = naxes * opt.rounds;
    // The last step's weights: with them the last gather measures the volume
    // (the volume is linear in that axis's coordinates, V = sum_v (x_v - o) w_v).
    const bool fused = opt.method == CoefficientMethod::Traversal;
    std::unique_ptr<double[]> w(fused ? new double[n_vertices()] : nullptr);  // written before read: not zeroed
    for (int step = 0; step < k; ++step) {
      const int a = opt.axes[step % naxes];
      const bool last = step == k - 1;
      AxisStep info;
      info.axis = a;
      // A closed mesh's passes write their weights somewhere in any case
      // (coefficients_fans): into w, one buffer for all steps.
      const bool sets = step == 0 && skip >= 0;  // X's column a is 0 (first_step_sets)
      const bool by_coefficients = sets || (!last && volume_by_coefficients(opt));
      AxisCoefficients co = coefficients(X, a, opt.method, threads,
                                         fused && (last || is_closed()) ? w.get() : nullptr, !by_coefficients);
      const VectorXd Pa = expand_column(ties_, P.col(a) + res.offsets.col(a), a);
      if (by_coefficients) co.volume = co.alpha.dot((Pa.array() - origin_[a]).matrix());
      lap(tm.coefficients);
      info.volume_before = co.volume;
      if (step == 0) res.volume_before = co.volume;
      // Equal shares of what is still missing: after the last axis the volume is the target.
      info.share = (pl.target - co.volume) / (k - step);
      const std::vector<double> rhs = constraint_rhs(rows, opt.constraints, a, Pa);
      const VectorXd delta =
          solve_tied(pl.ties, &co.alpha, info.share, rows, rhs, pl.inv_weight, axis_name[a], &info.sum_squares);
      const VectorXd field = gather_field(delta, Pa, sets);
      info.max_offset = delta.cwiseAbs().maxCoeff();
      res.offsets.col(a) += delta;
      res.steps.push_back(info);
      lap(tm.solves);
      if (last && fused) {
        res.volume = gather_final(field, X, a, w.get(), threads)[0];
      } else {
        gather(field, X, a, threads);
      }
      lap(tm.gathers);
    }
    if (!fused) res.volume = signed_volume(X, processing_faces(), origin_, threads);
    lap(tm.volume);
  }
  if (has_parts_) {
    if (K > 1) {
      if (res.part_volumes.size() == 0)
        res.part_volumes = part_volumes(X, processing_faces(), face_start_, origin_, threads);
    } else {
      res.part_volumes_before = VectorXd::Constant(1, res.volume_before);
      res.part_volumes = VectorXd::Constant(1, res.volume);
    }
    if (opt.preserve_volume) res.part_targets = pl.part_targets;
  }
  res.control_points = P + res.offsets;
  if (!direct) to_caller_order(Xs, out, threads);
  lap(tm.reorder);
  res.constraint_error = constraint_error(rows, expand_points(ties_, res.control_points), opt.constraints);
  if (timed) {
    tm.recorded = true;
    tm.total = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  }
  return res;
}

}  // namespace vpffd
