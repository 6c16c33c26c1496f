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
/// list v) moved to a new numbering: new list i is old list from[i] with every item
/// j replaced by to[j]. The order inside a list is kept.
/// @param from  new list -> old list (a permutation)
/// @param to    old item -> new item (a vertex numbering: the inverse of `from` where
///              lists and items are numbered alike)
/// Chunks of lists find their offsets in parallel (their lengths summed per chunk,
/// then the chunks' starts).
inline void permute_lists(const std::vector<std::int32_t>& indptr, const std::vector<std::int32_t>& items, int stride,
                          const std::vector<std::int32_t>& from, const std::vector<std::int32_t>& to,
                          std::vector<std::int32_t>& out_indptr, std::vector<std::int32_t>& out_items,
                          int threads = 0) {
  const Index n = static_cast<Index>(from.size());
  out_indptr.resize(n + 1);
  out_items.resize(items.size());
  const int chunks = chunk_count(n);
  std::vector<std::int32_t> chunk_start(chunks + 1, 0);
  parallel_chunks(n, chunks, threads, [&](int c, Index b, Index e) {
    std::int32_t len = 0;
    for (Index i = b; i < e; ++i) len += indptr[from[i] + 1] - indptr[from[i]];
    chunk_start[c + 1] = len;
  });
  for (int c = 0; c < chunks; ++c) chunk_start[c + 1] += chunk_start[c];
  parallel_chunks(n, chunks, threads, [&](int c, Index b, Index e) {
    std::int32_t at = chunk_start[c];
    for (Index i = b; i < e; ++i) {
      out_indptr[i] = at;
      const Index src = Index(stride) * indptr[from[i]];
      const std::int32_t len = indptr[from[i] + 1] - indptr[from[i]];
      std::int32_t* dst = out_items.data() + Index(stride) * at;
      for (Index k = 0; k < Index(stride) * len; ++k) dst[k] = to[items[src + k]];
      at += len;
    }
  });
  out_indptr[n] = chunk_start[chunks];
}

inline VertexFans permute_fans(const VertexFans& f, const std::vector<std::int32_t>& from,
                               const std::vector<std::int32_t>& to, int threads = 0) {
  VertexFans out;
  permute_lists(f.indptr, f.fan, 1, from, to, out.indptr, out.fan, threads);
  return out;
}

/// permute_fans for the padded layout, into `out` (its buffers reused when they have
/// the size already): rows and tails relabelled (a row's padding, the vertex itself,
/// becomes its new index, as padding it afresh would give). A Deformer's move
/// relabels instead (relabel_fans_into): its rows keep their vertices.
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

/// The padded fans' entries relabelled in place, rows where they are: entry j ->
/// to[j] (a move's old -> new processing position; a row's padding, its vertex,
/// becomes that vertex's new position as padding it afresh would give).
inline void relabel_fans(PaddedFans& f, const std::vector<std::int32_t>& to, int threads = 0) {
  const Index n = f.size(), w = f.width;
  parallel_range(n, threads, [&](Index b, Index e) {
    for (Index k = b * w; k < e * w; ++k) f.head[k] = to[f.head[k]];
    for (Index k = f.tail_ptr[b]; k < f.tail_ptr[e]; ++k) f.tail[k] = to[f.tail[k]];
  });
}

/// relabel_fans into `out` (its buffers reused): the source stays as it is (a
/// deformer's older rest state may still be read by frames in flight).
inline void relabel_fans_into(const PaddedFans& f, const std::vector<std::int32_t>& to, PaddedFans& out,
                              int threads = 0) {
  out.width = f.width;
  out.head.resize(f.head.size());
  out.tail_ptr = f.tail_ptr;
  out.tail.resize(f.tail.size());
  const Index n = f.size(), w = f.width;
  parallel_range(n, threads, [&](Index b, Index e) {
    for (Index k = b * w; k < e * w; ++k) out.head[k] = to[f.head[k]];
    for (Index k = f.tail_ptr[b]; k < f.tail_ptr[e]; ++k) out.tail[k] = to[f.tail[k]];
  });
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
