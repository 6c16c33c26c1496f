// OFF, ASCII and binary, read by vpffd (not OpenMesh): OpenMesh's OFF reader
// turns unparsable numbers into zeros, and its binary path trusts the counts of
// the header (a 59-byte file asking for 2^32 vertices made it allocate 4 GiB).

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "io_util.h"
#include "readers.h"

namespace vpffd::io_detail {
namespace {

// True when an OFF file's first line says "OFF BINARY".
bool off_is_binary(const std::string& file, const std::string& shown) {
  Lines in(file, shown);
  std::string line;
  while (in.next(line)) {
    const auto t = tokens_of(line, true);
    if (t.empty()) continue;
    return t.size() >= 2 && t[1] == "BINARY";
  }
  return false;
}

// Geomview ASCII OFF: a keyword [ST][C][N]OFF, the counts "V F [E]", V vertex
// lines "x y z [nx ny nz] [colour] [s t]", F face lines "k i1 .. ik [colour]".
// '#' starts a comment; blank lines are ignored. Faces are triangulated as fans
// like the OpenMesh path does; faces with fewer than 3 corners are counted as
// skipped. Throws MeshIOError naming the line.
void read_ascii_off(const std::string& file, const std::string& shown, std::uint64_t size, MeshData& out) {
  const char* what = "load_mesh";
  Lines in(file, shown);
  std::string line;
  std::vector<std::string> t;
  auto next_tokens = [&]() {
    while (in.next(line)) {
      t = tokens_of(line, true);
      if (!t.empty()) return true;
    }
    return false;
  };
  if (!next_tokens()) fail(what, shown, "no OFF header (the file has no data)");
  std::string kw = t[0];
  const long long header_line = in.number();
  bool st = false, col = false, nor = false;
  {
    std::string k = kw;
    if (k.size() > 3 && k.compare(0, 3, "OFF") == 0 &&
        std::all_of(k.begin() + 3, k.end(), [](unsigned char c) { return std::isdigit(c); }))
      k = "OFF";
    if (k.rfind("ST", 0) == 0) st = true, k = k.substr(2);
    if (k.rfind("C", 0) == 0) col = true, k = k.substr(1);
    if (k.rfind("N", 0) == 0) nor = true, k = k.substr(1);
    if (k == "4OFF" || k == "nOFF")
      fail(what, shown, at_line(header_line) + "'" + kw + "' (4D or n-dimensional OFF) is not supported");
    if (k != "OFF") fail(what, shown, at_line(header_line) + "expected an OFF header, found " + quote(kw));
  }
  // The counts may follow the keyword on the same line.
  std::vector<std::string> counts(t.begin() + 1, t.end());
  // Some published data sets (ModelNet) glue the vertex count to the keyword:
  // "OFF490 518 0".
  if (kw.size() > 3 && kw.compare(0, 3, "OFF") == 0 &&
      std::all_of(kw.begin() + 3, kw.end(), [](unsigned char c) { return std::isdigit(c); })) {
    counts.insert(counts.begin(), kw.substr(3));
    kw = "OFF";
  }
  long long counts_line = header_line;
  if (counts.empty()) {
    if (!next_tokens()) fail(what, shown, "the file is truncated: no vertex/face counts after the OFF header");
    counts = t;
    counts_line = in.number();
  }
  long long nV = -1, nF = -1, nE = 0;
  if (counts.size() < 2 || counts.size() > 3 || !parse_int(counts[0], nV) || !parse_int(counts[1], nF) ||
      (counts.size() == 3 && !parse_int(counts[2], nE)) || nV < 0 || nF < 0 || nE < 0)
    fail(what, shown,
         at_line(counts_line) + "expected the counts 'vertices faces [edges]' (non-negative integers), found " +
             quote(line));
  if (nV > std::numeric_limits<int>::max() || nF > std::numeric_limits<int>::max())
    fail(what, shown, at_line(counts_line) + "the counts are too large for this reader");
  // The shortest vertex line is "0 0 0\n" (6 bytes), the shortest face line
  // "0\n" (2 bytes): counts that need more bytes than the file has are refused
  // before anything is allocated for them.
  {
    const std::uint64_t least = times(static_cast<std::uint64_t>(nV), 6) + times(static_cast<std::uint64_t>(nF), 2);
    if (least > size)
      fail(what, shown,
           at_line(counts_line) + "the header announces " + std::to_string(nV) + " vertices and " +
               std::to_string(nF) + " faces, which take at least " + std::to_string(least) +
               " bytes; the file has " + std::to_string(size));
  }

  const size_t need = 3 + (nor ? 3 : 0);
  // After the required numbers a vertex line may carry a colour (1 index, RGB
  // or RGBA) and, for STOFF, 2 texture coordinates; those are not kept.
  const size_t extra_max = (col ? 4 : 0) + (st ? 2 : 0);
  std::vector<double> V, N;
  // Reserve by the header only up to a modest size: a corrupt header must not
  // allocate gigabytes before the first line is read.
  V.reserve(static_cast<size_t>(std::min<long long>(nV, 1 << 20)) * 3);
  for (long long v = 0; v < nV; ++v) {
    if (!next_tokens())
      fail(what, shown,
           "the file is truncated: the header announces " + std::to_string(nV) + " vertices, the file ends after " +
               std::to_string(v));
    const std::string L = at_line(in.number());
    if (t.size() < need)
      fail(what, shown,
           L + "vertex " + std::to_string(v) + " has " + std::to_string(t.size()) + " numbers, expected " +
               std::to_string(need) + (nor ? " (x y z nx ny nz)" : " (x y z)"));
    if (t.size() > need + extra_max)
      fail(what, shown,
           L + "vertex " + std::to_string(v) + " has " + std::to_string(t.size()) + " values, at most " +
               std::to_string(need + extra_max) + " expected for '" + kw +
               "' (a face line where a vertex was expected? the header announces " + std::to_string(nV) +
               " vertices)");
    for (size_t k = 0; k < t.size(); ++k) {
      double x = 0;
      if (!parse_double(t[k], x)) fail(what, shown, L + "vertex " + std::to_string(v) + ": " + quote(t[k]) + " is not a number");
      if (k < need && !std::isfinite(x))
        fail(what, shown,
             L + "vertex " + std::to_string(v) + " has a non-finite " + (k < 3 ? "coordinate " : "normal ") +
                 quote(t[k]) + " (NaN, Inf or out of double range)");
      if (k < 3)
        V.push_back(x);
      else if (k < need)
        N.push_back(x);
    }
  }
  std::vector<std::array<int, 3>> tris;
  tris.reserve(static_cast<size_t>(std::min<long long>(nF, 1 << 20)));
  std::vector<int> idx;
  for (long long f = 0; f < nF; ++f) {
    if (!next_tokens())
      fail(what, shown,
           "the file is truncated: the header announces " + std::to_string(nF) + " faces, the file ends after " +
               std::to_string(f));
    const std::string L = at_line(in.number());
    long long k = -1;
    if (!parse_int(t[0], k) || k < 0)
      fail(what, shown, L + "face " + std::to_string(f) + ": expected the number of corners, found " + quote(t[0]));
    // A face may end with a colour: nothing, a colour-map index, RGB or RGBA.
    if (static_cast<long long>(t.size()) < 1 + k || static_cast<long long>(t.size()) > 1 + k + 4)
      fail(what, shown,
           L + "face " + std::to_string(f) + " announces " + std::to_string(k) + " corners but the line has " +
               std::to_string(t.size() - 1) + " values after the count");
    idx.clear();
    for (long long c = 0; c < k; ++c) {
      long long i = -1;
      const std::string& tok = t[static_cast<size_t>(1 + c)];
      if (!parse_int(tok, i)) fail(what, shown, L + "face " + std::to_string(f) + ": " + quote(tok) + " is not a vertex index");
      if (i < 0 || i >= nV)
        fail(what, shown,
             L + "face " + std::to_string(f) + " refers to vertex " + tok + ", but the file has " +
                 std::to_string(nV) + " vertices");
      idx.push_back(static_cast<int>(i));
    }
    for (size_t c = static_cast<size_t>(1 + k); c < t.size(); ++c) {
      double x = 0;
      if (!parse_double(t[c], x))
        fail(what, shown, L + "face " + std::to_string(f) + ": colour value " + quote(t[c]) + " is not a number");
    }
    ++out.polygons;
    if (k < 3) {
      ++out.skipped_faces;
      continue;
    }
    if (k > 3) ++out.triangulated_polygons;
    for (size_t c = 1; c + 1 < idx.size(); ++c) tris.push_back({idx[0], idx[c], idx[c + 1]});
  }
  // Anything after the last face means the counts do not describe the file.
  if (next_tokens())
    fail(what, shown,
         at_line(in.number()) + "unexpected data after the last of the " + std::to_string(nF) +
             " faces the header announces: " + quote(line));
  if (!in.ok()) fail(what, shown, "read error");

  out.V.resize(static_cast<Index>(nV), 3);
  for (Index v = 0; v < nV; ++v)
    for (int c = 0; c < 3; ++c) out.V(v, c) = V[static_cast<size_t>(3 * v + c)];
  if (nor) {
    out.N.resize(static_cast<Index>(nV), 3);
    for (Index v = 0; v < nV; ++v)
      for (int c = 0; c < 3; ++c) out.N(v, c) = N[static_cast<size_t>(3 * v + c)];
  }
  out.F.resize(static_cast<Index>(tris.size()), 3);
  for (size_t f = 0; f < tris.size(); ++f)
    for (int c = 0; c < 3; ++c) out.F(static_cast<Index>(f), c) = tris[f][c];
}

// OpenMesh's binary OFF (what its writer produces): the line "[ST][C][N]OFF
// BINARY", then little-endian uint32 counts #V #F #E, #V records of float32
// x y z [nx ny nz] [s t], and #F records "uint32 k, k uint32 indices". (Geomview's
// binary OFF is big-endian; OpenMesh reads and writes little-endian, and so do we.)
// Every count is checked against the bytes left before it is used.
void read_binary_off(const std::string& file, const std::string& shown, MeshData& out) {
  const char* what = "load_mesh";
  const std::vector<unsigned char> data = read_all(file, shown);
  const auto nl = std::find(data.begin(), data.end(), static_cast<unsigned char>('\n'));
  if (nl == data.end()) fail(what, shown, "binary OFF: no end of the header line");
  const std::string head(data.begin(), nl);
  const auto t = tokens_of(head, false);
  std::string kw = t.empty() ? std::string() : t[0];
  bool st = false, nor = false;
  if (kw.rfind("ST", 0) == 0) st = true, kw = kw.substr(2);
  if (kw.rfind("C", 0) == 0)
    fail(what, shown, "binary OFF with colours ('" + t[0] + "') is not supported: its colour layout is ambiguous");
  if (kw.rfind("N", 0) == 0) nor = true, kw = kw.substr(1);
  if (kw != "OFF" || t.size() != 2) fail(what, shown, "binary OFF: expected the header '[ST][N]OFF BINARY', found " + quote(head));
  Bytes in(data.data() + (nl - data.begin()) + 1, static_cast<std::size_t>(data.end() - nl - 1));
  std::uint64_t nV = 0, nF = 0, nE = 0;
  if (!in.uint(4, nV) || !in.uint(4, nF) || !in.uint(4, nE))
    fail(what, shown, "the file is truncated: binary OFF needs 12 bytes of counts after its header line");
  const std::uint64_t per_vertex = 4 * (3 + (nor ? 3 : 0) + (st ? 2 : 0));
  const std::uint64_t least = times(nV, per_vertex) + times(nF, 4);
  if (nV > static_cast<std::uint64_t>(std::numeric_limits<int>::max()) || least > in.left())
    fail(what, shown,
         "binary OFF: the header announces " + std::to_string(nV) + " vertices and " + std::to_string(nF) +
             " faces, which take at least " + std::to_string(least) + " bytes; the file has " +
             std::to_string(in.left()) + " after its header");
  std::vector<double> V(static_cast<std::size_t>(3 * nV)), N;
  if (nor) N.resize(static_cast<std::size_t>(3 * nV));
  for (std::uint64_t v = 0; v < nV; ++v) {
    for (int c = 0; c < 3; ++c) {
      in.f32(V[static_cast<std::size_t>(3 * v + c)]);
      if (!std::isfinite(V[static_cast<std::size_t>(3 * v + c)]))
        fail(what, shown, "vertex " + std::to_string(v) + " has a non-finite coordinate");
    }
    for (int c = 0; nor && c < 3; ++c) in.f32(N[static_cast<std::size_t>(3 * v + c)]);
    if (st) in.skip(8);
  }
  std::vector<int> tris;
  for (std::uint64_t f = 0; f < nF; ++f) {
    std::uint64_t k = 0;
    if (!in.uint(4, k) || times(k, 4) > in.left())
      fail(what, shown,
           "the file is truncated or corrupt: face " + std::to_string(f) + " of " + std::to_string(nF) +
               (k ? " announces " + std::to_string(k) + " corners, " : std::string(" is missing, ")) +
               std::to_string(in.left()) + " bytes are left");
    ++out.polygons;
    std::uint64_t first = 0, prev = 0;
    for (std::uint64_t c = 0; c < k; ++c) {
      std::uint64_t i = 0;
      in.uint(4, i);
      if (i >= nV)
        fail(what, shown,
             "face " + std::to_string(f) + " refers to vertex " + std::to_string(i) + ", but the file has " +
                 std::to_string(nV) + " vertices");
      if (c == 0) first = i;
      if (c >= 2) tris.insert(tris.end(), {static_cast<int>(first), static_cast<int>(prev), static_cast<int>(i)});
      prev = i;
    }
    if (k < 3) ++out.skipped_faces;
    if (k > 3) ++out.triangulated_polygons;
  }
  if (in.left() != 0)
    fail(what, shown,
         std::to_string(in.left()) + " bytes of unexpected data after the last of the " + std::to_string(nF) +
             " faces the header announces");
  finish_mesh(shown, V, tris, out);
  if (nor) {
    out.N.resize(static_cast<Index>(nV), 3);
    for (Index v = 0; v < static_cast<Index>(nV); ++v)
      for (int c = 0; c < 3; ++c) out.N(v, c) = N[static_cast<std::size_t>(3 * v + c)];
    if (!out.N.allFinite()) out.N.resize(0, 3);  // unusable normals are dropped, not fatal
  }
}

}  // namespace

void read_off(const std::string& file, const std::string& shown, std::uint64_t size, MeshData& out) {
  if (off_is_binary(file, shown))
    read_binary_off(file, shown, out);
  else
    read_ascii_off(file, shown, size, out);
}

}  // namespace vpffd::io_detail
