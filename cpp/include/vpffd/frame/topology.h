#pragma once
/// @file topology.h
/// What a deformer's frames read that no move of the rest mesh changes: the lattice
/// and its tables, the faces (as given and grouped by part), the parts, the edge
/// report. Built once, by make_topology, and shared (immutable) by every rest state
/// (frame/rest_state.h) the deformer ever holds.

#include <memory>
#include <string>
#include <vector>

#include "vpffd/core/check.h"
#include "vpffd/ffd/vertex_order.h"
#include "vpffd/lattice/embed.h"
#include "vpffd/lattice/periodic.h"
#include "vpffd/mesh/parts.h"
#include "vpffd/mesh/validate.h"

namespace vpffd {

struct FrameTopology {
  Lattice lattice;
  BasisTables tables;
  Ties ties;                ///< the periodic tie map (identity without periodic axes)
  OutsidePolicy policy = OutsidePolicy::Error;
  Vector3d origin;          ///< reference point of the volume sums (the lattice box centre)
  Index n_vertices = 0;     ///< moves keep the mesh: the count is fixed
  RowMatrixX3i faces;       ///< as given
  EdgeReport edges;
  bool has_parts = false;
  MeshParts parts;          ///< count 1 and no labels without parts
  /// Face processing position -> face: the mesh's own order, each part's faces
  /// together (a stable sort by part), so a part's face sums are one range.
  std::vector<std::int32_t> face_order;
  std::vector<Index> face_start;  ///< K + 1: each part's faces in face_order
  RowMatrixX3i part_faces;        ///< with parts: faces in face_order (the part volumes); else empty
  /// K + 1: each part's vertices in any processing order (frames put a part's
  /// vertices together; how many each part has does not change with a move).
  std::vector<Index> part_start;
  /// With parts: each part's vertices, ascending, in part_start's ranges (the moves
  /// of some parts only, frame/rest_moves.h); empty without parts.
  std::vector<std::int32_t> part_vertices;

  Index n_cells() const { return Index(tables.dims[0]) * tables.dims[1] * tables.dims[2]; }
  bool closed() const { return edges.closed(); }
};

/// The topology of mesh (V, F) in lattice L: checks the mesh, the lattice and the
/// parts (each must bound a volume).
/// @throws InvalidInputError naming the problem
inline std::shared_ptr<const FrameTopology> make_topology(const Eigen::Ref<const RowMatrixX3d>& V,
                                                          const Eigen::Ref<const RowMatrixX3i>& F, Lattice L,
                                                          OutsidePolicy policy, const MeshParts* parts) {
  auto t = std::make_shared<FrameTopology>();
  t->faces = F;
  validate_mesh(V, t->faces, "Deformer");
  validate_lattice(L);
  t->lattice = std::move(L);
  t->policy = policy;
  t->n_vertices = V.rows();
  t->ties = make_ties(t->lattice);
  if (parts) {
    VPFFD_CHECK(Index(parts->vertex_part.size()) == V.rows() && parts->count >= 1 &&
                    Index(parts->labels.size()) == parts->count,
                "Deformer: the parts are for another mesh (", parts->vertex_part.size(), " vertex labels, ", V.rows(),
                " vertices)");
    require_closed_parts(t->faces, *parts);
    t->parts = *parts;
    t->has_parts = true;
  }
  t->tables = basis_tables(t->lattice);
  t->edges = edge_report(t->faces);
  t->origin = 0.5 * (t->lattice.box_min + t->lattice.box_max);

  const Index nf = t->faces.rows(), nv = V.rows();
  const int K = t->parts.count;
  t->face_start.assign(K + 1, 0);
  t->part_start.assign(K + 1, 0);
  if (!t->has_parts) {
    t->face_order.resize(nf);
    for (Index f = 0; f < nf; ++f) t->face_order[f] = static_cast<std::int32_t>(f);
    t->face_start[1] = nf;
    t->part_start[1] = nv;
    return t;
  }
  std::vector<std::int32_t> key(nf);
  for (Index f = 0; f < nf; ++f) key[f] = t->parts.vertex_part[t->faces(f, 0)];
  t->face_order = counting_sort(key, K);
  for (Index f = 0; f < nf; ++f) ++t->face_start[key[f] + 1];
  for (int k = 0; k < K; ++k) t->face_start[k + 1] += t->face_start[k];
  t->part_faces.resize(nf, 3);
  for (Index f = 0; f < nf; ++f) t->part_faces.row(f) = t->faces.row(t->face_order[f]);
  for (Index v = 0; v < nv; ++v) ++t->part_start[t->parts.vertex_part[v] + 1];
  for (int k = 0; k < K; ++k) t->part_start[k + 1] += t->part_start[k];
  t->part_vertices = counting_sort(t->parts.vertex_part, K);
  return t;
}

}  // namespace vpffd
