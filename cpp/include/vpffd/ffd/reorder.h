#pragma once
/// @file reorder.h
/// Carrying the per-vertex structures of a mesh from one processing order to the
/// next when its rest positions move (Deformer::set_rest_vertices).
///
/// A moved rest mesh has new cells, hence a new processing order (vertex_order.h);
/// its connectivity is the same. Rebuilding the vertex fans from the renumbered faces
/// (vertex_rings + vertex_fans: a serial face pass, then a search per vertex) costs
/// half a frame on a 160k-vertex mesh; relabelling the old fans costs a gather. The
/// lists here are defined in the mesh's own numbering and then relabelled, so a list
/// carried through any number of moves is exactly the one built afresh: integers, no
/// rounding.

#include <algorithm>
#include <vector>

#include "vpffd/core/parallel.h"
#include "vpffd/mesh/validate.h"

namespace vpffd {

/// Per-vertex lists (CSR: items [stride * indptr[v], stride * indptr[v+1]) belong to
/// vertex v) moved to a new numbering: new vertex i gets the list of old vertex
/// from[i] with every item j replaced by to[j]. The order inside a list is kept.
/// @param from  new index -> old index (a permutation)
/// @param to    old index -> new index (its inverse)
inline void permute_lists(const std::vector<std::int32_t>& indptr, const std::vector<std::int32_t>& items, int stride,
                          const std::vector<std::int32_t>& from, const std::vector<std::int32_t>& to,
                          std::vector<std::int32_t>& out_indptr, std::vector<std::int32_t>& out_items,
                          int threads = 0) {
  const Index n = static_cast<Index>(from.size());
  out_indptr.resize(n + 1);
  out_indptr[0] = 0;
  for (Index i = 0; i < n; ++i) out_indptr[i + 1] = out_indptr[i] + (indptr[from[i] + 1] - indptr[from[i]]);
  out_items.resize(items.size());
  parallel_range(n, threads, [&](Index b, Index e) {
    for (Index i = b; i < e; ++i) {
      const Index src = Index(stride) * indptr[from[i]], len = Index(stride) * (indptr[from[i] + 1] - indptr[from[i]]);
      std::int32_t* dst = out_items.data() + Index(stride) * out_indptr[i];
      for (Index k = 0; k < len; ++k) dst[k] = to[items[src + k]];
    }
  });
}

inline VertexFans permute_fans(const VertexFans& f, const std::vector<std::int32_t>& from,
                               const std::vector<std::int32_t>& to, int threads = 0) {
  VertexFans out;
  permute_lists(f.indptr, f.fan, 1, from, to, out.indptr, out.fan, threads);
  return out;
}

inline VertexRings permute_rings(const VertexRings& r, const std::vector<std::int32_t>& from,
                                 const std::vector<std::int32_t>& to, int threads = 0) {
  VertexRings out;
  permute_lists(r.indptr, r.pairs, 2, from, to, out.indptr, out.pairs, threads);
  return out;
}

/// face_order(F, rank) and the renumbered faces of a new processing order, from those
/// of the previous one: exactly what face_order and renumbering give (faces by their
/// lowest vertex position, ties by face index), computed on the old face sequence.
/// A moved mesh keeps most of its order, so the old sequence is nearly sorted already:
/// the key pass, the counting sort and the gathers read memory nearly in order, where
/// face_order on the mesh's own faces jumps through rank at random.
/// @param Fs_old, forder_old  the faces of the previous order (face processing
///                            position -> face, and the faces numbered by old position)
/// @param to                  old vertex position -> new vertex position
/// @param[out] forder, Fs     the same for the new order
inline void reorder_faces(const RowMatrixX3i& Fs_old, const std::vector<std::int32_t>& forder_old,
                          const std::vector<std::int32_t>& to, std::vector<std::int32_t>& forder, RowMatrixX3i& Fs,
                          int threads = 0) {
  const Index nf = Fs_old.rows(), nv = static_cast<Index>(to.size());
  std::vector<std::int32_t> key(nf);
  parallel_range(nf, threads, [&](Index b, Index e) {
    for (Index j = b; j < e; ++j) key[j] = std::min({to[Fs_old(j, 0)], to[Fs_old(j, 1)], to[Fs_old(j, 2)]});
  });
  // Counting sort by key in old sequence order; then within each key (a vertex's few
  // faces) by face index, the tie order of face_order's stable sort on F.
  std::vector<std::int32_t> start(nv + 1, 0);
  for (Index j = 0; j < nf; ++j) ++start[key[j] + 1];
  for (Index i = 0; i < nv; ++i) start[i + 1] += start[i];
  std::vector<std::int32_t> src(nf);
  {
    std::vector<std::int32_t> fill(start.begin(), start.end() - 1);
    for (Index j = 0; j < nf; ++j) src[fill[key[j]]++] = static_cast<std::int32_t>(j);
  }
  forder.resize(nf);
  Fs.resize(nf, 3);
  parallel_range(nv, threads, [&](Index b, Index e) {
    for (Index i = b; i < e; ++i) {
      std::int32_t* g = src.data() + start[i];
      const Index n = start[i + 1] - start[i];
      for (Index x = 1; x < n; ++x)  // insertion sort: a handful of faces
        for (Index y = x; y > 0 && forder_old[g[y]] < forder_old[g[y - 1]]; --y) std::swap(g[y], g[y - 1]);
      for (Index x = 0; x < n; ++x) {
        const Index p = start[i] + x, j = g[x];
        forder[p] = forder_old[j];
        for (int c = 0; c < 3; ++c) Fs(p, c) = to[Fs_old(j, c)];
      }
    }
  });
}

}  // namespace vpffd
