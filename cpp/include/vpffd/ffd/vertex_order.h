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
#include <cstdint>
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

/// The positions of each run [start[r], start[r+1]) stably sorted by a small key of
/// the item at that position, key[order[i]] (0..255): run by run, position ->
/// position. The Deformer's weight order: each cell's vertices by valence.
/// The keys are read once, in position order; a run's keys are counted over their
/// own range (a run of a few items does not clear 256 counters), and a short run is
/// sorted by insertion. Chunks of positions take the runs that start in them.
inline std::vector<std::int32_t> order_within_runs(const std::vector<Index>& start,
                                                   const std::vector<std::int32_t>& order,
                                                   const std::vector<std::uint8_t>& key, int threads = 1) {
  const Index n = static_cast<Index>(order.size());
  std::vector<std::int32_t> out(n);
  std::vector<std::uint8_t> k(n);
  parallel_range(n, threads, [&](Index b, Index e) {
    for (Index i = b; i < e; ++i) k[i] = key[order[i]];
  });
  const Index runs = static_cast<Index>(start.size()) - 1;
  parallel_range(n, threads, [&](Index b, Index e) {
    Index count[257];
    Index r = std::lower_bound(start.begin(), start.end() - 1, b) - start.begin();
    for (; r < runs && start[r] < e; ++r) {
      const Index s = start[r], t = start[r + 1];
      std::int32_t* o = out.data() + s;
      if (t - s <= 32) {
        for (Index i = s; i < t; ++i) {
          Index j = i - s;
          for (; j > 0 && k[o[j - 1]] > k[i]; --j) o[j] = o[j - 1];
          o[j] = static_cast<std::int32_t>(i);
        }
        continue;
      }
      int lo = 255, hi = 0;
      for (Index i = s; i < t; ++i) {
        lo = std::min<int>(lo, k[i]);
        hi = std::max<int>(hi, k[i]);
      }
      std::fill(count + lo, count + hi + 2, Index(0));
      for (Index i = s; i < t; ++i) ++count[k[i] + 1];
      for (int q = lo; q <= hi; ++q) count[q + 1] += count[q];
      for (Index i = s; i < t; ++i) o[count[k[i]]++] = static_cast<std::int32_t>(i);
    }
  });
  return out;
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
