#pragma once
/// @file shapes.h
/// Closed test meshes generated in code (outward-oriented): the icosphere of the
/// paper's Sphere row and the subdivided cube of its twisting-cube example.

#include <array>
#include <cmath>
#include <map>
#include <utility>
#include <vector>

#include "vpffd/core/check.h"
#include "vpffd/core/types.h"

namespace vpffd {

struct TriMesh {
  RowMatrixX3d V;
  RowMatrixX3i F;
};

/// Icosahedron subdivided `subdivisions` times, vertices on the sphere of `radius`:
/// 10 * 4^s + 2 vertices, 20 * 4^s faces (s = 4: 2,562 and 5,120).
inline TriMesh icosphere(int subdivisions, double radius = 1.0) {
  VPFFD_CHECK(subdivisions >= 0 && subdivisions <= 9, "icosphere: subdivisions ", subdivisions, " not in 0..9");
  VPFFD_CHECK(std::isfinite(radius) && radius > 0, "icosphere: radius must be positive and finite");
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Vector3d> v = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                             {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  std::vector<std::array<int, 3>> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                       {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                       {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                       {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (auto& p : v) p.normalize();
  for (int s = 0; s < subdivisions; ++s) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      v.push_back((v[a] + v[b]).normalized());
      return mid[key] = static_cast<int>(v.size()) - 1;
    };
    std::vector<std::array<int, 3>> g;
    g.reserve(f.size() * 4);
    for (const auto& tri : f) {
      const int a = midpoint(tri[0], tri[1]), b = midpoint(tri[1], tri[2]), c = midpoint(tri[2], tri[0]);
      g.push_back({tri[0], a, c});
      g.push_back({tri[1], b, a});
      g.push_back({tri[2], c, b});
      g.push_back({a, b, c});
    }
    f.swap(g);
  }
  TriMesh m;
  m.V.resize(static_cast<Index>(v.size()), 3);
  for (size_t i = 0; i < v.size(); ++i) m.V.row(i) = radius * v[i].transpose();
  m.F.resize(static_cast<Index>(f.size()), 3);
  for (size_t i = 0; i < f.size(); ++i) m.F.row(i) << f[i][0], f[i][1], f[i][2];
  return m;
}

/// Surface of the axis-aligned box [-size/2, size/2]^3 with each face split into
/// n x n squares (two triangles each): 6 n^2 + 2 vertices (n = 32: 6,146).
inline TriMesh box_mesh(int n, double size = 1.0) {
  VPFFD_CHECK(n >= 1 && n <= 2000, "box_mesh: n ", n, " not in 1..2000");
  VPFFD_CHECK(std::isfinite(size) && size > 0, "box_mesh: size must be positive and finite");
  std::map<std::array<int, 3>, int> id;  // integer grid coordinates -> vertex
  std::vector<Vector3d> v;
  std::vector<std::array<int, 3>> f;
  auto vert = [&](std::array<int, 3> g) {
    auto it = id.find(g);
    if (it != id.end()) return it->second;
    v.emplace_back(size * (double(g[0]) / n - 0.5), size * (double(g[1]) / n - 0.5), size * (double(g[2]) / n - 0.5));
    return id[g] = static_cast<int>(v.size()) - 1;
  };
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
          auto g = [&](int di, int dj) {
            std::array<int, 3> p{};
            p[axis] = side * n;
            p[a1] = i + di;
            p[a2] = j + dj;
            return vert(p);
          };
          const int q00 = g(0, 0), q10 = g(1, 0), q11 = g(1, 1), q01 = g(0, 1);
          // (a1, a2, axis) is right-handed: counter-clockwise in (a1, a2) faces +axis.
          if (side == 1) {
            f.push_back({q00, q10, q11});
            f.push_back({q00, q11, q01});
          } else {
            f.push_back({q00, q11, q10});
            f.push_back({q00, q01, q11});
          }
        }
    }
  TriMesh m;
  m.V.resize(static_cast<Index>(v.size()), 3);
  for (size_t i = 0; i < v.size(); ++i) m.V.row(i) = v[i].transpose();
  m.F.resize(static_cast<Index>(f.size()), 3);
  for (size_t i = 0; i < f.size(); ++i) m.F.row(i) << f[i][0], f[i][1], f[i][2];
  return m;
}

}  // namespace vpffd
