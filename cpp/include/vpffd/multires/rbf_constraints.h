#pragma once
/// @file rbf_constraints.h
/// Which vertices constrain the RBF map of a painted region (rbf_regions.h): the
/// fixed vertices within a few edge rings of the region, and a greedy thinning of a
/// group of points to a least spacing (the triharmonic system's condition grows
/// fast as its centres crowd together).

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "vpffd/core/types.h"

namespace vpffd::detail {

/// The vertices not in `inside` within `rings` edges of it (ascending), by a
/// breadth-first search over the edges of F.
inline std::vector<Index> ring_vertices(const RowMatrixX3i& F, Index nv, const std::vector<std::uint8_t>& inside,
                                        int rings) {
  std::vector<Index> start(nv + 1, 0);
  for (Index f = 0; f < F.rows(); ++f)
    for (int a = 0; a < 3; ++a) start[F(f, a) + 1] += 2;
  for (Index i = 0; i < nv; ++i) start[i + 1] += start[i];
  std::vector<Index> adj(start[nv]), fill(start.begin(), start.end() - 1);
  for (Index f = 0; f < F.rows(); ++f)
    for (int a = 0; a < 3; ++a) {
      const Index v = F(f, a);
      adj[fill[v]++] = F(f, (a + 1) % 3);
      adj[fill[v]++] = F(f, (a + 2) % 3);
    }
  std::vector<int> dist(nv, -1);
  std::vector<Index> front;
  for (Index i = 0; i < nv; ++i)
    if (inside[i]) {
      dist[i] = 0;
      front.push_back(i);
    }
  std::vector<Index> out;
  for (int r = 1; r <= rings && !front.empty(); ++r) {
    std::vector<Index> next;
    for (Index v : front)
      for (Index k = start[v]; k < start[v + 1]; ++k)
        if (dist[adj[k]] < 0) {
          dist[adj[k]] = r;
          next.push_back(adj[k]);
          out.push_back(adj[k]);
        }
    front.swap(next);
  }
  std::sort(out.begin(), out.end());
  return out;
}

/// The ids (in their order) that greedy thinning keeps: an id is kept when no id
/// kept before it lies closer than `spacing` (world units; 0 keeps every id), found
/// through a hash grid of cells of that size.
inline std::vector<Index> thin_points(const RowMatrixX3d& P, const std::vector<Index>& ids, double spacing) {
  if (!(spacing > 0) || ids.size() < 2) return ids;
  auto cell = [&](Index id) {
    Eigen::Array<std::int64_t, 3, 1> c;
    for (int a = 0; a < 3; ++a) c[a] = static_cast<std::int64_t>(std::floor(P(id, a) / spacing));
    return c;
  };
  auto key = [](std::int64_t x, std::int64_t y, std::int64_t z) {  // collisions only cost distance checks
    return (std::uint64_t(x) & 0x1FFFFF) << 42 | (std::uint64_t(y) & 0x1FFFFF) << 21 | (std::uint64_t(z) & 0x1FFFFF);
  };
  std::unordered_map<std::uint64_t, std::vector<Index>> grid;
  std::vector<Index> out;
  for (Index id : ids) {
    const auto c = cell(id);
    bool keep = true;
    for (int dx = -1; dx <= 1 && keep; ++dx)
      for (int dy = -1; dy <= 1 && keep; ++dy)
        for (int dz = -1; dz <= 1 && keep; ++dz) {
          const auto it = grid.find(key(c[0] + dx, c[1] + dy, c[2] + dz));
          if (it == grid.end()) continue;
          for (Index q : it->second)
            if ((P.row(q) - P.row(id)).norm() < spacing) {
              keep = false;
              break;
            }
        }
    if (keep) {
      grid[key(c[0], c[1], c[2])].push_back(id);
      out.push_back(id);
    }
  }
  return out;
}

}  // namespace vpffd::detail
