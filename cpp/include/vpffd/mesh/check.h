#pragma once
/// @file check.h
/// Defect report of a triangle mesh given as plain arrays, and orientation repair.
///
/// Everything is counted on the faces exactly as stored, without merging vertices:
/// a scan whose vertices were duplicated along seams shows up as boundary edges,
/// extra components and duplicate vertices, which is what a volume computation
/// sees. Definitions follow the usual ones (trimesh, MeshLab), so that the counts
/// of ../shared/data/meshes/MANIFEST.md are reproduced exactly.

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <vector>

#include <Eigen/Geometry>  // cross products (Core alone declares them without a definition)

#include "vpffd/core/types.h"
#include "vpffd/mesh/validate.h"
#include "vpffd/mesh/volume.h"

namespace vpffd {

/// Counts of everything that keeps a mesh from bounding a volume.
struct MeshCheckReport {
  Index vertices = 0;               ///< #V (including unreferenced ones)
  Index faces = 0;                  ///< #F
  Index edges = 0;                  ///< distinct undirected edges
  Index boundary_edges = 0;         ///< edges with one face
  Index boundary_loops = 0;         ///< connected pieces of the boundary-edge graph (holes)
  Index nonmanifold_edges = 0;      ///< edges with more than two faces
  Index nonmanifold_vertices = 0;   ///< vertices whose faces form more than one fan (pinch points)
  Index misoriented_edges = 0;      ///< edges whose two faces run along it in the same direction
  Index degenerate_faces = 0;       ///< zero area: a repeated index, or coincident/collinear corners
  Index duplicate_vertices = 0;     ///< vertices at exactly the position of an earlier vertex
  Index duplicate_faces = 0;        ///< faces with the same three vertices as an earlier face
  Index unreferenced_vertices = 0;  ///< vertices no face uses
  Index components = 0;             ///< face components, joined across edges with exactly two faces
  Index euler_characteristic = 0;   ///< referenced vertices - edges + faces
  /// Signed volume when the mesh is closed and consistently oriented, else NaN.
  double signed_volume = std::numeric_limits<double>::quiet_NaN();

  /// Every edge has exactly two faces (no boundary, nothing non-manifold): topology only.
  bool watertight() const { return boundary_edges == 0 && nonmanifold_edges == 0; }
  bool consistently_oriented() const { return misoriented_edges == 0; }
  /// Watertight and consistently wound: a closed surface, which bounds a volume. The
  /// same meaning as EdgeReport::closed(), Deformer::is_closed() and Python's is_closed.
  bool closed() const { return watertight() && consistently_oriented(); }
  /// Closed, consistent, but the faces point inside (negative volume).
  bool inward() const { return signed_volume < 0; }
  /// Bounds a volume that vpffd can preserve: closed, consistently oriented, outward.
  bool is_volume() const { return closed() && consistently_oriented() && signed_volume > 0; }
};

namespace detail {

/// Union-find with path halving.
struct DisjointSets {
  std::vector<std::int32_t> parent;
  explicit DisjointSets(Index n) : parent(static_cast<size_t>(n)) { std::iota(parent.begin(), parent.end(), 0); }
  std::int32_t find(std::int32_t a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  }
  void unite(std::int32_t a, std::int32_t b) {
    a = find(a);
    b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
};

/// One undirected edge use: (lo, hi) vertex pair, the face, and whether the face
/// runs lo -> hi.
struct EdgeUse {
  std::int32_t lo, hi, face;
  bool forward;
  bool same_edge(const EdgeUse& o) const { return lo == o.lo && hi == o.hi; }
};

inline std::vector<EdgeUse> sorted_edge_uses(const Eigen::Ref<const RowMatrixX3i>& F) {
  std::vector<EdgeUse> uses;
  uses.reserve(static_cast<size_t>(F.rows()) * 3);
  for (Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const std::int32_t a = F(f, c), b = F(f, (c + 1) % 3);
      uses.push_back({std::min(a, b), std::max(a, b), static_cast<std::int32_t>(f), a < b});
    }
  std::sort(uses.begin(), uses.end(), [](const EdgeUse& x, const EdgeUse& y) {
    return x.lo != y.lo ? x.lo < y.lo : x.hi != y.hi ? x.hi < y.hi : x.face < y.face;
  });
  return uses;
}

}  // namespace detail

/// Counts the defects of the mesh (V, F).
/// @param[in] V  #V x 3 vertex positions
/// @param[in] F  #F x 3 triangles
/// @throws InvalidInputError for an empty mesh, non-finite values or bad indices
inline MeshCheckReport check_mesh(const Eigen::Ref<const RowMatrixX3d>& V, const Eigen::Ref<const RowMatrixX3i>& F) {
  validate_mesh(V, F, "check_mesh");
  MeshCheckReport r;
  const Index nV = V.rows(), nF = F.rows();
  r.vertices = nV;
  r.faces = nF;

  // --- edges: boundary, non-manifold, misoriented; face components ---------------
  const std::vector<detail::EdgeUse> uses = detail::sorted_edge_uses(F);
  detail::DisjointSets face_sets(nF), boundary_sets(nV);
  std::vector<char> on_boundary(static_cast<size_t>(nV), 0);
  for (size_t i = 0; i < uses.size();) {
    size_t j = i;
    while (j < uses.size() && uses[j].same_edge(uses[i])) ++j;
    const size_t n = j - i;
    ++r.edges;
    if (n == 1) {
      ++r.boundary_edges;
      boundary_sets.unite(uses[i].lo, uses[i].hi);
      on_boundary[uses[i].lo] = on_boundary[uses[i].hi] = 1;
    } else if (n > 2) {
      ++r.nonmanifold_edges;
    } else {
      if (uses[i].forward == uses[i + 1].forward) ++r.misoriented_edges;
      // Components are joined only across manifold edges: a fin glued onto a
      // surface along a non-manifold edge is a piece of its own.
      face_sets.unite(uses[i].face, uses[i + 1].face);
    }
    i = j;
  }
  for (Index f = 0; f < nF; ++f)
    if (face_sets.find(static_cast<std::int32_t>(f)) == f) ++r.components;
  for (Index v = 0; v < nV; ++v)
    if (on_boundary[v] && boundary_sets.find(static_cast<std::int32_t>(v)) == v) ++r.boundary_loops;

  // --- vertices: unreferenced, duplicated positions, pinch points -----------------
  const VertexFaces vf = vertex_faces(F, nV);
  for (Index v = 0; v < nV; ++v)
    if (vf.indptr[v + 1] == vf.indptr[v]) ++r.unreferenced_vertices;
  r.euler_characteristic = (nV - r.unreferenced_vertices) - r.edges + nF;
  {
    std::vector<std::int32_t> order(static_cast<size_t>(nV));
    std::iota(order.begin(), order.end(), 0);
    auto less = [&](std::int32_t a, std::int32_t b) {
      for (int c = 0; c < 3; ++c)
        if (V(a, c) != V(b, c)) return V(a, c) < V(b, c);
      return false;
    };
    std::sort(order.begin(), order.end(), less);
    for (size_t k = 1; k < order.size(); ++k)
      if (!less(order[k - 1], order[k])) ++r.duplicate_vertices;
  }
  {
    // The faces around v form fans joined across the edges (v, u); more than one
    // fan makes v a pinch point even when all its edges are manifold.
    std::vector<std::array<std::int32_t, 2>> spokes;  // (other vertex u, local face index)
    std::vector<std::int32_t> local;
    for (Index v = 0; v < nV; ++v) {
      const std::int32_t b = vf.indptr[v], e = vf.indptr[v + 1];
      if (e - b < 2) continue;
      spokes.clear();
      for (std::int32_t k = b; k < e; ++k) {
        const std::int32_t f = vf.faces[k];
        for (int c = 0; c < 3; ++c)
          if (F(f, c) != v) spokes.push_back({F(f, c), k - b});
      }
      std::sort(spokes.begin(), spokes.end());
      local.resize(static_cast<size_t>(e - b));
      std::iota(local.begin(), local.end(), 0);
      auto find = [&](std::int32_t a) {
        while (local[a] != a) a = local[a] = local[local[a]];
        return a;
      };
      for (size_t k = 1; k < spokes.size(); ++k)
        if (spokes[k][0] == spokes[k - 1][0]) {
          const std::int32_t x = find(spokes[k][1]), y = find(spokes[k - 1][1]);
          if (x != y) local[std::max(x, y)] = std::min(x, y);
        }
      Index fans = 0;
      for (std::int32_t k = 0; k < e - b; ++k)
        if (find(k) == k) ++fans;
      if (fans > 1) ++r.nonmanifold_vertices;
    }
  }

  // --- faces: degenerate and duplicated -------------------------------------------
  {
    std::vector<std::array<std::int32_t, 3>> keys(static_cast<size_t>(nF));
    for (Index f = 0; f < nF; ++f) {
      const std::int32_t a = F(f, 0), b = F(f, 1), c = F(f, 2);
      keys[f] = {a, b, c};
      std::sort(keys[f].begin(), keys[f].end());
      if (a == b || b == c || a == c) {
        ++r.degenerate_faces;
        continue;
      }
      const Vector3d p0 = V.row(a), e1 = V.row(b).transpose() - p0, e2 = V.row(c).transpose() - p0;
      // Zero area up to rounding: |e1 x e2| against the product of the edge lengths
      // (the sine of the corner angle), so the test does not depend on the scale.
      const double scale = e1.norm() * e2.norm();
      if (!(e1.cross(e2).norm() > 1e-14 * scale)) ++r.degenerate_faces;
    }
    std::sort(keys.begin(), keys.end());
    for (size_t k = 1; k < keys.size(); ++k)
      if (keys[k] == keys[k - 1]) ++r.duplicate_faces;
  }

  if (r.closed() && r.consistently_oriented()) {
    const Vector3d centre = 0.5 * (V.colwise().minCoeff() + V.colwise().maxCoeff()).transpose();
    r.signed_volume = signed_volume(V, F, centre);
  }
  return r;
}

/// Result of orient_faces.
struct OrientResult {
  RowMatrixX3i F;            ///< #F x 3 faces, some with two corners swapped
  Index flipped_faces = 0;   ///< faces whose winding was reversed
  Index conflicts = 0;       ///< manifold edges still misoriented (non-orientable pieces)
  Index inward_components = 0;  ///< closed components turned outward
};

/// Makes the winding consistent across every manifold edge and turns each closed
/// component outward (positive volume). An open component keeps the orientation
/// of the majority of its faces, since inside and outside are undefined for it.
/// @param[in] V  #V x 3 vertex positions
/// @param[in] F  #F x 3 triangles (not modified)
/// @throws InvalidInputError for a bad mesh
inline OrientResult orient_faces(const Eigen::Ref<const RowMatrixX3d>& V, const Eigen::Ref<const RowMatrixX3i>& F) {
  validate_mesh(V, F, "orient_faces");
  const Index nF = F.rows();
  const std::vector<detail::EdgeUse> uses = detail::sorted_edge_uses(F);
  // Manifold neighbours: (neighbour, same direction along the shared edge?)
  std::vector<std::array<std::int32_t, 3>> nbr(static_cast<size_t>(nF), {-1, -1, -1});
  std::vector<std::array<char, 3>> same(static_cast<size_t>(nF), {0, 0, 0});
  std::vector<char> closed_face(static_cast<size_t>(nF), 1);
  auto slot = [&](std::int32_t f) {
    for (int k = 0; k < 3; ++k)
      if (nbr[f][k] < 0) return k;
    return 2;
  };
  for (size_t i = 0; i < uses.size();) {
    size_t j = i;
    while (j < uses.size() && uses[j].same_edge(uses[i])) ++j;
    if (j - i == 2) {
      const auto &x = uses[i], &y = uses[i + 1];
      const char s = x.forward == y.forward;
      int kx = slot(x.face), ky = slot(y.face);
      nbr[x.face][kx] = y.face;
      same[x.face][kx] = s;
      nbr[y.face][ky] = x.face;
      same[y.face][ky] = s;
    } else {
      for (size_t k = i; k < j; ++k) closed_face[uses[k].face] = 0;
    }
    i = j;
  }
  OrientResult out;
  out.F = F;
  std::vector<signed char> flip(static_cast<size_t>(nF), -1);
  std::vector<std::int32_t> stack, comp;
  for (Index seed = 0; seed < nF; ++seed) {
    if (flip[seed] >= 0) continue;
    comp.clear();
    flip[seed] = 0;
    stack.push_back(static_cast<std::int32_t>(seed));
    bool closed = true;
    while (!stack.empty()) {
      const std::int32_t f = stack.back();
      stack.pop_back();
      comp.push_back(f);
      closed = closed && closed_face[f];
      for (int k = 0; k < 3; ++k) {
        const std::int32_t g = nbr[f][k];
        if (g < 0) continue;
        // Same direction along the shared edge means opposite windings.
        const signed char want = static_cast<signed char>(flip[f] ^ same[f][k]);
        if (flip[g] < 0) {
          flip[g] = want;
          stack.push_back(g);
        }
      }
    }
    Index n_flip = 0;
    for (auto f : comp) n_flip += flip[f];
    bool invert = 2 * n_flip > static_cast<Index>(comp.size());
    if (closed) {
      // Volume of the component as it would be wound, from a point of its box.
      RowMatrixX3i C(static_cast<Index>(comp.size()), 3);
      for (size_t k = 0; k < comp.size(); ++k) {
        const std::int32_t f = comp[k];
        C.row(static_cast<Index>(k)) = F.row(f);
        if (flip[f]) std::swap(C(static_cast<Index>(k), 1), C(static_cast<Index>(k), 2));
      }
      const double vol = signed_volume(V, C, V.row(F(comp[0], 0)).transpose());
      invert = vol < 0;
      if (invert) ++out.inward_components;
    }
    for (auto f : comp) {
      if (invert) flip[f] = static_cast<signed char>(!flip[f]);
      if (flip[f]) {
        std::swap(out.F(f, 1), out.F(f, 2));
        ++out.flipped_faces;
      }
    }
  }
  out.conflicts = edge_report(out.F).misoriented_edges;
  return out;
}

}  // namespace vpffd
