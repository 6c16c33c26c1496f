// Wavefront OBJ, read by vpffd (not OpenMesh).

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <utility>

#include "io_util.h"
#include "readers.h"

namespace vpffd::io_detail {

// Wavefront OBJ, read here instead of by OpenMesh: its reader silently drops a
// face with a repeated corner ("f 1 1 1"), removes repeated corners from others
// ("f 1 2 2 3" becomes one triangle) and skips "v nan 0 0" lines, which shifts
// every later vertex index. Here every face is kept as stored, like the OFF and
// PLY paths do, so that check_mesh sees the file's own defects. Keywords other
// than v, vn and f (vt, g, o, s, usemtl, l, ...) are ignored. Vertex normals are
// those the face corners name ("f 1//3"); they are returned only when every
// vertex gets one. Throws MeshIOError naming the line.
void read_obj(const std::string& file, const std::string& shown, MeshData& out) {
  const char* what = "load_mesh";
  Lines in(file, shown);
  std::string line;
  std::vector<double> V, VN;
  std::vector<std::array<int, 3>> tris;
  // (vertex, normal) pairs from "f v//vn" corners; a vertex index may name a
  // vertex defined later, so they are applied once the vertex count is known.
  std::vector<std::pair<int, int>> corner_normals;
  struct Pending {             // positive indices may name vertices defined later
    long long line, index;
  };
  Pending worst{0, 0};
  std::vector<long long> idx, nidx;
  while (in.next(line)) {
    const auto t = tokens_of(line, true);
    if (t.empty()) continue;
    const std::string L = at_line(in.number());
    if (t[0] == "v" || t[0] == "vn") {
      const bool pos = t[0] == "v";
      // v x y z [w] or v x y z r g b (a colour extension); vn x y z
      if (t.size() < 4 || t.size() > (pos ? 8u : 4u))
        fail(what, shown,
             L + "'" + t[0] + "' has " + std::to_string(t.size() - 1) + " values, expected " +
                 (pos ? "3 (x y z, optionally w or r g b)" : "3"));
      for (size_t k = 1; k < t.size(); ++k) {
        double x = 0;
        if (!parse_double(t[k], x)) fail(what, shown, L + quote(t[k]) + " is not a number");
        if (pos && k <= 3 && !std::isfinite(x))
          fail(what, shown,
               L + "vertex " + std::to_string(V.size() / 3) + " has a non-finite coordinate " + quote(t[k]) +
                   " (NaN, Inf or out of double range)");
        if (k <= 3) (pos ? V : VN).push_back(x);
      }
      if (V.size() / 3 > static_cast<size_t>(std::numeric_limits<int>::max()))
        fail(what, shown, L + "too many vertices for this reader");
    } else if (t[0] == "f") {
      idx.clear();
      nidx.clear();
      const long long nv = static_cast<long long>(V.size() / 3), nn = static_cast<long long>(VN.size() / 3);
      for (size_t k = 1; k < t.size(); ++k) {
        // v, v/vt, v/vt/vn or v//vn; negative indices count back from the last
        // vertex (normal) defined so far.
        const std::string& c = t[k];
        const size_t s1 = c.find('/');
        const size_t s2 = s1 == std::string::npos ? std::string::npos : c.find('/', s1 + 1);
        long long v = 0, vt = 0, vn = 0;
        const std::string a = c.substr(0, s1);
        const std::string b = s1 == std::string::npos ? "" : c.substr(s1 + 1, s2 == std::string::npos ? std::string::npos : s2 - s1 - 1);
        const std::string d = s2 == std::string::npos ? "" : c.substr(s2 + 1);
        if (!parse_int(a, v) || v == 0 || (!b.empty() && !parse_int(b, vt)) || (!d.empty() && !parse_int(d, vn)) ||
            (s2 != std::string::npos && d.empty()) || (s1 != std::string::npos && s2 == std::string::npos && b.empty()) ||
            c.find('/', s2 == std::string::npos ? c.size() : s2 + 1) != std::string::npos)
          fail(what, shown, L + "face corner " + quote(c) + " is not 'v', 'v/vt', 'v/vt/vn' or 'v//vn' with v a non-zero integer");
        if (v < 0) {
          if (v < -nv)
            fail(what, shown,
                 L + "face corner " + quote(c) + " refers back further than the " + std::to_string(nv) +
                     " vertices defined before it");
          v = nv + v;
        } else {
          v -= 1;
          if (v >= worst.index) worst = {in.number(), v + 1};
        }
        if (v > std::numeric_limits<int>::max()) fail(what, shown, L + "vertex index " + quote(c) + " is too large");
        if (vn < 0) vn = nn + vn + 1;
        if (!d.empty() && (vn < 1 || vn > nn))
          fail(what, shown,
               L + "face corner " + quote(c) + " refers to normal " + d + ", but " + std::to_string(nn) +
                   " normals are defined before it");
        idx.push_back(v);
        nidx.push_back(d.empty() ? -1 : vn - 1);
      }
      ++out.polygons;
      if (idx.size() < 3) {
        ++out.skipped_faces;
        continue;
      }
      if (idx.size() > 3) ++out.triangulated_polygons;
      for (size_t k = 1; k + 1 < idx.size(); ++k)
        tris.push_back({static_cast<int>(idx[0]), static_cast<int>(idx[k]), static_cast<int>(idx[k + 1])});
      for (size_t k = 0; k < idx.size(); ++k)
        if (nidx[k] >= 0) {
          corner_normals.emplace_back(static_cast<int>(idx[k]), static_cast<int>(nidx[k]));
        }
    }
  }
  if (!in.ok()) fail(what, shown, "read error");
  const Index nV = static_cast<Index>(V.size() / 3);
  if (worst.index > nV)
    fail(what, shown,
         at_line(worst.line) + "a face refers to vertex " + std::to_string(worst.index) + " (1-based), but the file has " +
             std::to_string(nV) + " vertices");
  out.V.resize(nV, 3);
  for (Index v = 0; v < nV; ++v)
    for (int c = 0; c < 3; ++c) out.V(v, c) = V[static_cast<size_t>(3 * v + c)];
  std::vector<int> normal_of(static_cast<size_t>(nV), -1);  // per vertex: index into VN or -1
  for (const auto& [v, n] : corner_normals) normal_of[static_cast<size_t>(v)] = n;
  if (nV > 0 &&
      std::all_of(normal_of.begin(), normal_of.end(), [](int n) { return n >= 0; })) {
    out.N.resize(nV, 3);
    for (Index v = 0; v < nV; ++v)
      for (int c = 0; c < 3; ++c) out.N(v, c) = VN[static_cast<size_t>(3 * normal_of[static_cast<size_t>(v)] + c)];
    if (!out.N.allFinite()) out.N.resize(0, 3);  // unusable normals are dropped, as on the OpenMesh path
  }
  out.F.resize(static_cast<Index>(tris.size()), 3);
  for (size_t f = 0; f < tris.size(); ++f)
    for (int c = 0; c < 3; ++c) out.F(static_cast<Index>(f), c) = tris[f][c];
}


}  // namespace vpffd::io_detail
