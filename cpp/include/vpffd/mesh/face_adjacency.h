#pragma once
/// @file face_adjacency.h
/// The face across each edge of a triangle mesh, for walks over a surface (foot-point
/// searches step from a triangle into its neighbour across the edge they leave by).

#include <algorithm>
#include <cstdint>
#include <vector>

#include "vpffd/core/types.h"

namespace vpffd {

/// #F x 3: entry (f, c) is the face across the edge opposite corner c of face f,
/// i.e. the edge (F(f, c+1), F(f, c+2)), and -1 where that edge is a boundary or is
/// shared by more than two faces (a walk must stop there: "across" is not defined).
/// The barycentric coordinate of corner c turns negative exactly when a point leaves
/// f through that edge, which is why the columns are indexed by the opposite corner.
inline RowMatrixX3i face_neighbours(const Eigen::Ref<const RowMatrixX3i>& F) {
  struct Use {
    std::uint64_t key;  // undirected edge (lo << 32 | hi)
    std::int32_t face;
    std::int8_t corner;
  };
  std::vector<Use> uses;
  uses.reserve(static_cast<size_t>(F.rows()) * 3);
  for (Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const std::uint64_t a = static_cast<std::uint32_t>(F(f, (c + 1) % 3));
      const std::uint64_t b = static_cast<std::uint32_t>(F(f, (c + 2) % 3));
      uses.push_back({std::min(a, b) << 32 | std::max(a, b), static_cast<std::int32_t>(f), static_cast<std::int8_t>(c)});
    }
  std::sort(uses.begin(), uses.end(), [](const Use& x, const Use& y) {
    return x.key != y.key ? x.key < y.key : x.face < y.face;
  });
  RowMatrixX3i N = RowMatrixX3i::Constant(F.rows(), 3, -1);
  for (size_t i = 0; i < uses.size();) {
    size_t j = i;
    while (j < uses.size() && uses[j].key == uses[i].key) ++j;
    if (j - i == 2) {
      N(uses[i].face, uses[i].corner) = uses[i + 1].face;
      N(uses[i + 1].face, uses[i + 1].corner) = uses[i].face;
    }
    i = j;
  }
  return N;
}

}  // namespace vpffd
