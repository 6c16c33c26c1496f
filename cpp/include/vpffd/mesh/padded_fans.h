#pragma once
/// @file padded_fans.h
/// The vertex fans (VertexFans) laid out for the frame's weight loops: the first
/// `width` entries of every fan in one fixed-width row, the rest of the longer fans
/// in a CSR tail.
///
/// A fan's length is the vertex's valence + 1. Walked from a CSR list in a mesh's
/// own order, the loop over a vertex's fan ends at a different count every vertex,
/// and its exits are mispredicted on scanned meshes (valences 4-15 on the dragon,
/// where rows took the three coefficient passes to 0.91x). A row of `width` entries
/// is one loop of fixed length. Fans shorter than the row are padded with the
/// vertex itself: a padding entry q = p_v adds ((q_k - p_v) x (p_v - p_v)) = 0 and
/// then (0 x 0) = 0, exactly, so the weights are those of the CSR fans with the same
/// terms in the same order.
///
/// The Deformer's processing order sorts each cell's vertices by valence
/// (frame/deformer.h): there the tail loop runs the same count for long stretches,
/// its exit is predicted, and a padding term costs as much as a tail's loop; so the
/// rows are as wide as the common fans, not the long ones (dragon: 6, was 9).

#include <algorithm>
#include <vector>

#include "vpffd/core/parallel.h"
#include "vpffd/mesh/validate.h"

namespace vpffd {

struct PaddedFans {
  int width = 0;
  std::vector<std::int32_t> head;      ///< n x width: row v's first entries, padded with its vertex
  std::vector<std::int32_t> tail_ptr;  ///< n + 1: vertex v's entries past width are
  std::vector<std::int32_t> tail;      ///< tail[tail_ptr[v], tail_ptr[v+1])
  Index size() const { return tail_ptr.empty() ? 0 : static_cast<Index>(tail_ptr.size()) - 1; }
  size_t bytes() const { return (head.size() + tail_ptr.size() + tail.size()) * sizeof(std::int32_t); }
};

/// The row width that costs least for these fan lengths: a row entry costs one
/// term, a fan longer than the row its extra terms plus a loop of its own
/// (kTailCost terms: in an order sorted by valence the loop's exit is predicted;
/// one coefficient pass over the dragon, rows of 5, 6, 7, 9: 8.3, 8.5, 8.7, 9.8 ms).
inline int padded_fan_width(const VertexFans& f) {
  constexpr Index kTailCost = 1;
  constexpr int kMaxWidth = 16;
  const Index n = static_cast<Index>(f.indptr.size()) - 1;
  std::vector<Index> count(kMaxWidth + 2, 0);  // fans of each length, the longest together
  std::vector<Index> extra(kMaxWidth + 2, 0);  // their entries
  for (Index v = 0; v < n; ++v) {
    const Index len = f.indptr[v + 1] - f.indptr[v];
    const Index c = std::min<Index>(len, kMaxWidth + 1);
    ++count[c];
    extra[c] += len;
  }
  int best = 1;
  Index best_cost = -1;
  for (int w = 1; w <= kMaxWidth; ++w) {
    Index cost = n * w;
    for (int c = w + 1; c <= kMaxWidth + 1; ++c) cost += extra[c] - count[c] * w + count[c] * kTailCost;
    if (best_cost < 0 || cost < best_cost) {
      best = w;
      best_cost = cost;
    }
  }
  return best;
}

/// f in rows of `width` entries (0: padded_fan_width(f)).
/// @param self  if not null, row v's own vertex, the padding (rows stored in another
///              order than their vertices: the Deformer's weight order); else v
inline PaddedFans pad_fans(const VertexFans& f, int width = 0, int threads = 0, const std::int32_t* self = nullptr) {
  VPFFD_CHECK(width >= 0, "pad_fans: width ", width, " is negative");
  PaddedFans p;
  p.width = width > 0 ? width : padded_fan_width(f);
  const Index n = static_cast<Index>(f.indptr.size()) - 1;
  const Index w = p.width;
  p.tail_ptr.assign(n + 1, 0);
  for (Index v = 0; v < n; ++v)
    p.tail_ptr[v + 1] = p.tail_ptr[v] + std::max<std::int32_t>(0, f.indptr[v + 1] - f.indptr[v] - p.width);
  p.head.resize(static_cast<size_t>(n) * w);
  p.tail.resize(p.tail_ptr[n]);
  parallel_range(n, threads, [&](Index b, Index e) {
    for (Index v = b; v < e; ++v) {
      const Index first = f.indptr[v], len = f.indptr[v + 1] - first;
      const std::int32_t pad = self ? self[v] : static_cast<std::int32_t>(v);
      for (Index k = 0; k < w; ++k) p.head[v * w + k] = k < len ? f.fan[first + k] : pad;
      for (Index k = w; k < len; ++k) p.tail[p.tail_ptr[v] + (k - w)] = f.fan[first + k];
    }
  });
  return p;
}

}  // namespace vpffd
