#pragma once
/// @file vertex_order.h
/// Processing order of the vertices: sorted by the lattice cell they lie in.
///
/// Vertices of one cell share their (d+1)^3 control points. Visiting them one
/// cell after the other lets the scatter (alpha = B^T w) add into a block kept in
/// registers instead of read-modify-writing the same control points vertex after
/// vertex, and keeps the gathers' control points in L1. Scanned meshes come in
/// scan order (runs of ~3 vertices per cell for the dragon); sorted, a cell's run
/// is thousands long.

#include <algorithm>
#include <vector>

#include "vpffd/core/parallel.h"
#include "vpffd/ffd/vertex_basis.h"

namespace vpffd {

/// Stable counting sort of items by small integer keys in [0, n_keys).
/// With threads, contiguous chunks of items count and place their own items (a stable
/// sort has one result, so it is the same for any thread count); the chunks' counts
/// take chunks x n_keys integers, so there are only as many as that stays below the
/// item count.
/// @returns order: position -> item
inline std::vector<std::int32_t> counting_sort(const std::vector<std::int32_t>& key, Index n_keys, int threads = 1) {
  const Index n = static_cast<Index>(key.size());
  const int chunks = n < kParallelMin ? 1
                                      : static_cast<int>(std::clamp<Index>(
                                            std::min<Index>(resolve_threads(threads), n / (n_keys + 1)), 1, 64));
  std::vector<std::int32_t> order(key.size());
  if (chunks == 1) {
    std::vector<Index> start(n_keys + 1, 0);
    for (std::int32_t k : key) ++start[k + 1];
    for (Index c = 0; c < n_keys; ++c) start[c + 1] += start[c];
    for (Index i = 0; i < n; ++i) order[start[key[i]]++] = static_cast<std::int32_t>(i);
    return order;
  }
  // next[c * n_keys + k]: where chunk c puts its next item of key k.
  std::vector<Index> next(static_cast<size_t>(chunks) * n_keys, 0);
  parallel_chunks(n, chunks, chunks, [&](int c, Index b, Index e) {
    Index* count = next.data() + static_cast<size_t>(c) * n_keys;
    for (Index i = b; i < e; ++i) ++count[key[i]];
  });
  Index at = 0;
  for (Index k = 0; k < n_keys; ++k)
    for (int c = 0; c < chunks; ++c) {
      Index& x = next[static_cast<size_t>(c) * n_keys + k];
      const Index count = x;
      x = at;
      at += count;
    }
  parallel_chunks(n, chunks, chunks, [&](int c, Index b, Index e) {
    Index* pos = next.data() + static_cast<size_t>(c) * n_keys;
    for (Index i = b; i < e; ++i) order[pos[key[i]]++] = static_cast<std::int32_t>(i);
  });
  return order;
}

/// Stable counting sort of the points by their cell (lattice/embed.h's embed_cells
/// gives the same cells straight from the points).
/// @returns order: processing position -> original index
inline std::vector<std::int32_t> cell_order(const BasisTables& T, const Embedding& E, int threads = 1) {
  const Index n = E.size();
  std::vector<std::int32_t> cell(n);
  parallel_range(n, threads, [&](Index b, Index e) {
    for (Index i = b; i < e; ++i) cell[i] = detail::cell_index(T, E, i);
  });
  return counting_sort(cell, Index(T.dims[0]) * T.dims[1] * T.dims[2], threads);
}

/// The inverse permutation: original index -> processing position.
inline std::vector<std::int32_t> inverse_order(const std::vector<std::int32_t>& order, int threads = 1) {
  std::vector<std::int32_t> rank(order.size());
  parallel_range(Index(order.size()), threads, [&](Index b, Index e) {
    for (Index i = b; i < e; ++i) rank[order[i]] = static_cast<std::int32_t>(i);
  });
  return rank;
}

/// out[i] = E[order[i]] (order: new position -> old index); out's buffers are
/// reused when they have the size already.
inline void permute_embedding_into(const Embedding& E, const std::vector<std::int32_t>& order, Embedding& out,
                                   int threads = 1) {
  for (int a = 0; a < 3; ++a) {
    out.span[a].resize(order.size());
    out.tau[a].resize(order.size());
  }
  parallel_range(Index(order.size()), threads, [&](Index b, Index e) {
    for (int a = 0; a < 3; ++a)
      for (Index i = b; i < e; ++i) {
        out.span[a][i] = E.span[a][order[i]];
        out.tau[a][i] = E.tau[a][order[i]];
      }
  });
}

/// permute_embedding_into a new Embedding.
inline Embedding permute_embedding(const Embedding& E, const std::vector<std::int32_t>& order, int threads = 1) {
  Embedding out;
  permute_embedding_into(E, order, out, threads);
  return out;
}

}  // namespace vpffd
