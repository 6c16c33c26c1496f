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
#include "vpffd/mesh/padded_fans.h"
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

/// permute_fans for the padded layout, into `out` (its buffers reused when they have
/// the size already, as a moving mesh's spare does): rows and tails relabelled (a
/// row's padding, the vertex itself, becomes its new index, as padding it afresh
/// would give).
inline void permute_fans_into(const PaddedFans& f, const std::vector<std::int32_t>& from,
                              const std::vector<std::int32_t>& to, PaddedFans& out, int threads = 0) {
  out.width = f.width;
  const Index n = static_cast<Index>(from.size()), w = f.width;
  out.head.resize(f.head.size());
  parallel_range(n, threads, [&](Index b, Index e) {
    for (Index i = b; i < e; ++i) {
      const std::int32_t* src = f.head.data() + Index(from[i]) * w;
      std::int32_t* dst = out.head.data() + i * w;
      for (Index k = 0; k < w; ++k) dst[k] = to[src[k]];
    }
  });
  permute_lists(f.tail_ptr, f.tail, 1, from, to, out.tail_ptr, out.tail, threads);
}

inline PaddedFans permute_fans(const PaddedFans& f, const std::vector<std::int32_t>& from,
                               const std::vector<std::int32_t>& to, int threads = 0) {
  PaddedFans out;
  permute_fans_into(f, from, to, out, threads);
  return out;
}

inline VertexRings permute_rings(const VertexRings& r, const std::vector<std::int32_t>& from,
                                 const std::vector<std::int32_t>& to, int threads = 0) {
  VertexRings out;
  permute_lists(r.indptr, r.pairs, 2, from, to, out.indptr, out.pairs, threads);
  return out;
}

}  // namespace vpffd
