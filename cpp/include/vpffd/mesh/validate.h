#pragma once
/// @file validate.h
/// Checks of a triangle mesh given as plain arrays: V (#V x 3 float64) and
/// F (#F x 3 int32), and the edge counts that decide whether it encloses a volume.

#include <algorithm>
#include <cmath>
#include <vector>

#include "vpffd/core/check.h"
#include "vpffd/core/types.h"

namespace vpffd {

/// @throws InvalidInputError naming the first row of V with a NaN or infinite coordinate.
inline void require_finite_rows(const Eigen::Ref<const RowMatrixX3d>& V, const char* where) {
  if (V.allFinite()) return;  // one vectorised pass; the loop only finds the culprit
  for (Index v = 0; v < V.rows(); ++v)
    VPFFD_CHECK(std::isfinite(V(v, 0)) && std::isfinite(V(v, 1)) && std::isfinite(V(v, 2)), where, ": vertex ", v,
                " has a non-finite coordinate (", V(v, 0), ", ", V(v, 1), ", ", V(v, 2), ")");
}

/// @throws InvalidInputError for an empty mesh, non-finite coordinates or face
///         indices out of [0, #V).
inline void validate_mesh(const Eigen::Ref<const RowMatrixX3d>& V, const Eigen::Ref<const RowMatrixX3i>& F,
                          const char* where = "mesh") {
  VPFFD_CHECK(V.rows() > 0, where, ": the mesh has no vertices");
  VPFFD_CHECK(F.rows() > 0, where, ": the mesh has no faces");
  VPFFD_CHECK(V.rows() < (Index(1) << 31), where, ": too many vertices (", V.rows(), ")");
  // Vertex-face lists hold 3 #F entries with 32-bit offsets.
  VPFFD_CHECK(3 * F.rows() < (Index(1) << 31), where, ": too many faces (", F.rows(), "; at most 715,827,882)");
  require_finite_rows(V, where);
  for (Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c)
      VPFFD_CHECK(F(f, c) >= 0 && F(f, c) < V.rows(), where, ": face ", f, " refers to vertex ", F(f, c),
                  ", but there are ", V.rows(), " vertices (valid: 0..", V.rows() - 1, ")");
}

/// Edge statistics of a face list.
struct EdgeReport {
  Index edges = 0;              ///< distinct undirected edges
  Index boundary_edges = 0;     ///< used by one face
  Index nonmanifold_edges = 0;  ///< used by more than two faces
  Index misoriented_edges = 0;  ///< used twice in the same direction (inconsistent winding)
  /// Every edge has exactly two faces, wound consistently: a closed surface, which
  /// bounds a volume (the meaning of "closed" everywhere in vpffd).
  bool closed() const { return boundary_edges == 0 && nonmanifold_edges == 0 && misoriented_edges == 0; }
};

inline EdgeReport edge_report(const Eigen::Ref<const RowMatrixX3i>& F) {
  // Each directed edge as a key: the undirected pair (lo, hi) in the upper bits,
  // its direction in bit 0. #V < 2^31 keeps the pair within 63 bits.
  std::vector<std::uint64_t> keys;
  keys.reserve(static_cast<size_t>(F.rows()) * 3);
  for (Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const std::uint64_t a = static_cast<std::uint32_t>(F(f, c)), b = static_cast<std::uint32_t>(F(f, (c + 1) % 3));
      const std::uint64_t lo = std::min(a, b), hi = std::max(a, b);
      keys.push_back(((lo << 31 | hi) << 1) | (a < b ? 0u : 1u));
    }
  std::sort(keys.begin(), keys.end());
  EdgeReport r;
  for (size_t i = 0; i < keys.size();) {
    size_t j = i, fwd = 0, bwd = 0;
    while (j < keys.size() && (keys[j] >> 1) == (keys[i] >> 1)) {
      (keys[j] & 1 ? bwd : fwd)++;
      ++j;
    }
    const size_t uses = j - i;
    ++r.edges;
    if (uses == 1) ++r.boundary_edges;
    else if (uses > 2) ++r.nonmanifold_edges;
    else if (fwd != 1) ++r.misoriented_edges;
    i = j;
  }
  return r;
}

/// @throws InvalidInputError when F does not bound a volume, saying why.
inline void require_closed(const EdgeReport& r, const char* where) {
  VPFFD_CHECK(r.boundary_edges == 0, where, ": the mesh is open (", r.boundary_edges,
              " boundary edges), so it encloses no volume");
  VPFFD_CHECK(r.nonmanifold_edges == 0, where, ": the mesh has ", r.nonmanifold_edges,
              " non-manifold edges (shared by more than two faces), so its enclosed volume is undefined");
  VPFFD_CHECK(r.misoriented_edges == 0, where, ": the faces are inconsistently oriented (", r.misoriented_edges,
              " edges used twice in the same direction), so the signed volume is meaningless");
}

/// Faces around each vertex, compressed: faces of v are faces[indptr[v] .. indptr[v+1]).
struct VertexFaces {
  std::vector<std::int32_t> indptr;
  std::vector<std::int32_t> faces;
};

namespace detail {

/// The face corners grouped by vertex (CSR): returns indptr (n_vertices + 1) and calls
/// emit(slot, f, c) for corner c of face f, slot in [indptr[v], indptr[v+1]) of its
/// vertex v = F(f, c); a vertex's corners come in face order.
template <class Emit>
std::vector<std::int32_t> corners_by_vertex(const Eigen::Ref<const RowMatrixX3i>& F, Index n_vertices, Emit&& emit) {
  std::vector<std::int32_t> indptr(n_vertices + 1, 0);
  for (Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) ++indptr[F(f, c) + 1];
  for (Index v = 0; v < n_vertices; ++v) indptr[v + 1] += indptr[v];
  std::vector<std::int32_t> fill(indptr.begin(), indptr.end() - 1);
  for (Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) emit(static_cast<size_t>(fill[F(f, c)]++), f, c);
  return indptr;
}

}  // namespace detail

inline VertexFaces vertex_faces(const Eigen::Ref<const RowMatrixX3i>& F, Index n_vertices) {
  VertexFaces a;
  a.faces.resize(3 * static_cast<size_t>(F.rows()));
  a.indptr = detail::corners_by_vertex(F, n_vertices,
                                       [&](size_t p, Index f, int) { a.faces[p] = static_cast<std::int32_t>(f); });
  return a;
}

/// Per vertex, the other two corners of each face around it in the face's
/// cyclic order: the face (v, m, n) gives the pair (m, n). Pairs of vertex v are
/// pairs[2 p], pairs[2 p + 1] for p in [indptr[v], indptr[v+1]), one per corner.
///
/// This is what a vertex needs to compute its volume weight alone, (1/6) sum of
/// ((p_m - p_v) x (p_n - p_v))_axis: no face pass, no per-face buffer, and the
/// reads are the vertex's own neighbours.
struct VertexRings {
  std::vector<std::int32_t> indptr;
  std::vector<std::int32_t> pairs;
};

/// A vertex's ring pairs chained into fans: neighbours fan[p] for p in
/// [indptr[v], indptr[v+1]) such that each pair (m, n) of vertex_rings is two
/// consecutive entries (fan[p], fan[p+1]), once. A closed manifold vertex with d
/// faces has one cycle, stored as its d neighbours and the first again (d + 1
/// entries where the pairs take 2 d). Where the pairs do not form one chain (a
/// vertex where two sheets touch, or a boundary vertex with several gaps) the
/// chains follow each other with v itself between them: the pairs (x, v) and (v, y)
/// this adds have p_m - p_v = 0 or p_n - p_v = 0, so they add exactly zero to the
/// weight (1/6) sum ((p_m - p_v) x (p_n - p_v))_axis.
///
/// Half the reads of the pairs for the same weights (each neighbour's coordinates
/// are read once per vertex, not twice), added in another order.
struct VertexFans {
  std::vector<std::int32_t> indptr;
  std::vector<std::int32_t> fan;
};

inline VertexRings vertex_rings(const Eigen::Ref<const RowMatrixX3i>& F, Index n_vertices) {
  VertexRings r;
  r.pairs.resize(6 * static_cast<size_t>(F.rows()));
  r.indptr = detail::corners_by_vertex(F, n_vertices, [&](size_t p, Index f, int c) {
    r.pairs[2 * p] = F(f, (c + 1) % 3);
    r.pairs[2 * p + 1] = F(f, (c + 2) % 3);
  });
  return r;
}

/// The fans of vertex_rings' pairs (see VertexFans).
inline VertexFans vertex_fans(const VertexRings& rings) {
  const Index nv = static_cast<Index>(rings.indptr.size()) - 1;
  VertexFans f;
  f.indptr.assign(nv + 1, 0);
  f.fan.reserve(rings.pairs.size() / 2 + nv);
  std::vector<char> used;
  for (Index v = 0; v < nv; ++v) {
    const std::int32_t b = rings.indptr[v], e = rings.indptr[v + 1];
    const std::int32_t* pr = rings.pairs.data();
    used.assign(e - b, 0);
    bool first_chain = true;
    for (;;) {
      // A chain starts at an unused pair whose first vertex no unused pair ends
      // in (the start of an open fan); failing that at any unused pair (a cycle).
      std::int32_t start = -1;
      for (std::int32_t p = b; p < e && start < 0; ++p) {
        if (used[p - b]) continue;
        bool continues = false;
        for (std::int32_t q = b; q < e && !continues; ++q)
          continues = !used[q - b] && q != p && pr[2 * q + 1] == pr[2 * p];
        if (!continues) start = p;
      }
      if (start < 0)
        for (std::int32_t p = b; p < e && start < 0; ++p)
          if (!used[p - b]) start = p;
      if (start < 0) break;
      if (!first_chain) f.fan.push_back(static_cast<std::int32_t>(v));
      first_chain = false;
      f.fan.push_back(pr[2 * start]);
      for (std::int32_t p = start; p >= 0;) {
        used[p - b] = 1;
        const std::int32_t n = pr[2 * p + 1];
        f.fan.push_back(n);
        p = -1;
        for (std::int32_t q = b; q < e && p < 0; ++q)
          if (!used[q - b] && pr[2 * q] == n) p = q;
      }
    }
    f.indptr[v + 1] = static_cast<std::int32_t>(f.fan.size());
  }
  f.fan.shrink_to_fit();
  return f;
}

}  // namespace vpffd
