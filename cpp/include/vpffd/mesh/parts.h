#pragma once
/// @file parts.h
/// A mesh split into parts (objects), each enclosing its own volume: from a label
/// per vertex, or from the connected components of the faces.
///
/// A part is a set of faces whose vertices all carry its label, so every edge and
/// every vertex ring lies in one part: a vertex's volume weight (coefficients.h)
/// then belongs to one part's volume only, and a part's volume is a sum over its
/// own faces.

#include <algorithm>
#include <numeric>
#include <vector>

#include "vpffd/core/check.h"
#include "vpffd/core/types.h"
#include "vpffd/mesh/validate.h"

namespace vpffd {

/// Parts of a mesh: `vertex_part[v]` in 0..count-1 for each vertex.
struct MeshParts {
  int count = 1;
  std::vector<std::int32_t> vertex_part;  ///< #V part indices
  std::vector<std::int64_t> labels;       ///< count: the caller's label of each part (ascending), or 0..count-1
};

/// The most parts a Deformer takes: each axis step solves a dense system of one row
/// per part, and each part holds N coefficients per step.
inline constexpr int kMaxParts = 4096;

/// Parts from one integer label per vertex: part k holds the k-th smallest label.
/// @throws InvalidInputError for a label count other than #V, more than kMaxParts
///         labels, a face whose vertices carry different labels, or a label that no
///         face carries (it would be a part with no volume).
inline MeshParts parts_from_labels(const Eigen::Ref<const RowMatrixX3i>& F, const std::vector<std::int64_t>& labels,
                                   Index n_vertices) {
  VPFFD_CHECK(Index(labels.size()) == n_vertices, "parts: ", labels.size(), " labels, expected one per vertex (",
              n_vertices, ")");
  MeshParts p;
  p.labels = labels;
  std::sort(p.labels.begin(), p.labels.end());
  p.labels.erase(std::unique(p.labels.begin(), p.labels.end()), p.labels.end());
  VPFFD_CHECK(p.labels.size() <= size_t(kMaxParts), "parts: ", p.labels.size(), " distinct labels; at most ",
              kMaxParts, " parts");
  p.count = static_cast<int>(p.labels.size());
  p.vertex_part.resize(n_vertices);
  for (Index v = 0; v < n_vertices; ++v)
    p.vertex_part[v] = static_cast<std::int32_t>(
        std::lower_bound(p.labels.begin(), p.labels.end(), labels[v]) - p.labels.begin());
  std::vector<char> has_face(p.count, 0);
  for (Index f = 0; f < F.rows(); ++f) {
    const std::int64_t l0 = labels[F(f, 0)], l1 = labels[F(f, 1)], l2 = labels[F(f, 2)];
    VPFFD_CHECK(l0 == l1 && l1 == l2, "parts: face ", f, " joins vertices of different parts (vertex ", F(f, 0),
                " has label ", l0, ", vertex ", F(f, 1), " label ", l1, ", vertex ", F(f, 2), " label ", l2,
                "); a part must be a set of whole faces");
    has_face[p.vertex_part[F(f, 0)]] = 1;
  }
  for (int k = 0; k < p.count; ++k)
    VPFFD_CHECK(has_face[k], "parts: label ", p.labels[k], " is carried only by vertices that no face uses, so that "
                "part encloses no volume");
  return p;
}

/// Parts as the connected components of the faces (two faces are connected when
/// they share a vertex), numbered in the order of their lowest vertex. Vertices
/// that no face uses join part 0: they carry no volume weight.
inline MeshParts parts_from_components(const Eigen::Ref<const RowMatrixX3i>& F, Index n_vertices) {
  std::vector<std::int32_t> parent(n_vertices);
  std::iota(parent.begin(), parent.end(), 0);
  auto root = [&](std::int32_t v) {
    while (parent[v] != v) v = parent[v] = parent[parent[v]];
    return v;
  };
  for (Index f = 0; f < F.rows(); ++f)
    for (int c = 1; c < 3; ++c) {
      const std::int32_t a = root(F(f, 0)), b = root(F(f, c));
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  std::vector<char> used(n_vertices, 0);
  for (Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) used[F(f, c)] = 1;
  MeshParts p;
  p.count = 0;
  std::vector<std::int32_t> part_of_root(n_vertices, -1);
  p.vertex_part.assign(n_vertices, 0);
  for (Index v = 0; v < n_vertices; ++v) {
    if (!used[v]) continue;
    const std::int32_t r = root(static_cast<std::int32_t>(v));
    if (part_of_root[r] < 0) part_of_root[r] = p.count++;
    p.vertex_part[v] = part_of_root[r];
  }
  VPFFD_CHECK(p.count <= kMaxParts, "parts='components': the mesh has ", p.count, " connected components; at most ",
              kMaxParts, " parts");
  p.labels.resize(p.count);
  std::iota(p.labels.begin(), p.labels.end(), 0);
  return p;
}

/// @throws InvalidInputError when a part does not bound a volume by itself: names
/// the first such part and its boundary edge count.
inline void require_closed_parts(const Eigen::Ref<const RowMatrixX3i>& F, const MeshParts& parts) {
  // Faces of each part, checked as a mesh of their own: the counts then say which part is at fault.
  std::vector<Index> n_faces(parts.count, 0);
  for (Index f = 0; f < F.rows(); ++f) ++n_faces[parts.vertex_part[F(f, 0)]];
  std::vector<RowMatrixX3i> part_faces(parts.count);
  for (int k = 0; k < parts.count; ++k) part_faces[k].resize(n_faces[k], 3);
  std::vector<Index> fill(parts.count, 0);
  for (Index f = 0; f < F.rows(); ++f) {
    const int k = parts.vertex_part[F(f, 0)];
    part_faces[k].row(fill[k]++) = F.row(f);
  }
  for (int k = 0; k < parts.count; ++k) {
    const EdgeReport r = edge_report(part_faces[k]);
    VPFFD_CHECK(r.boundary_edges == 0, "parts: part ", k, " (label ", parts.labels[k], ") is open (",
                r.boundary_edges, " boundary edges), so it cannot keep a volume of its own");
    VPFFD_CHECK(r.closed(), "parts: part ", k, " (label ", parts.labels[k], ") does not bound a volume (",
                r.nonmanifold_edges, " non-manifold edges, ", r.misoriented_edges, " misoriented edges)");
  }
}

}  // namespace vpffd
