// STL, ASCII and binary, read by vpffd. STL stores every facet's three corners
// on their own; read_stl merges corners at exactly equal positions (== on the
// coordinates, so -0 and +0 are one position) into one vertex, numbered in the
// order the positions first appear, so that a closed surface comes back closed.
//
// Which encoding: a file whose size is 84 + 50 n for the triangle count n at
// bytes 80..83 is binary, even if its header starts with "solid" (many binary
// writers put that word there); any other file starting with "solid" (in any
// case, perhaps after a UTF-8 byte-order mark) is ASCII;
// anything else is refused, saying what its size should have been.
//
// The whole file is checked: ASCII line by line (one keyword and its arity per
// line, numbers parsed completely, finite vertex coordinates, the line number
// in every message), binary by its exact size and finite coordinates. Memory:
// the binary count is the file's size over 50, and the ASCII reader only grows
// with the lines it has read, so no header can make it allocate beyond the file.

#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <string>
#include <unordered_map>
#include <vector>

#include "io_util.h"
#include "readers.h"

namespace vpffd::io_detail {
namespace {

constexpr const char* kWhat = "load_mesh";

// One vertex per distinct position, in the order of first appearance.
class Welder {
 public:
  explicit Welder(const std::string& shown) : shown_(shown) {}
  int add(double x, double y, double z) {
    // Adding +0.0 turns -0.0 into +0.0, so that the bit patterns hashed and
    // compared agree with ==.
    const Key k{{x + 0.0, y + 0.0, z + 0.0}};
    const auto [it, fresh] = index_.try_emplace(k, static_cast<int>(V_.size() / 3));
    if (fresh) {
      if (V_.size() / 3 >= static_cast<std::size_t>(std::numeric_limits<int>::max()))
        fail(kWhat, shown_, "more distinct vertices than this reader can index");
      V_.insert(V_.end(), {x, y, z});
    }
    return it->second;
  }
  const std::vector<double>& vertices() const { return V_; }

 private:
  struct Key {
    std::array<double, 3> p;
    bool operator==(const Key& o) const { return p == o.p; }
  };
  struct Hash {
    std::size_t operator()(const Key& k) const {
      std::uint64_t h = 1469598103934665603ull;
      for (double d : k.p) {
        std::uint64_t b = 0;
        std::memcpy(&b, &d, sizeof b);
        h = (h ^ b) * 1099511628211ull;
        h ^= h >> 29;
      }
      return static_cast<std::size_t>(h);
    }
  };
  std::string shown_;
  std::vector<double> V_;
  std::unordered_map<Key, int, Hash> index_;
};

std::uint32_t u32_le(const unsigned char* b) {
  return static_cast<std::uint32_t>(b[0]) | (static_cast<std::uint32_t>(b[1]) << 8) |
         (static_cast<std::uint32_t>(b[2]) << 16) | (static_cast<std::uint32_t>(b[3]) << 24);
}

// Binary STL: an 80-byte header, uint32 n, then n records of 50 bytes: float32
// normal, 3 x float32 x y z, uint16 attribute (ignored), all little-endian.
void read_binary_stl(const std::string& file, const std::string& shown, std::uint64_t n, MeshData& out) {
  if (n > static_cast<std::uint64_t>(std::numeric_limits<int>::max() / 3))
    fail(kWhat, shown, "the binary header announces " + std::to_string(n) + " triangles, more than this reader can index");
  const std::vector<unsigned char> data = read_all(file, shown);
  if (data.size() != 84 + 50 * n)
    fail(kWhat, shown, "the file changed while it was read (" + std::to_string(data.size()) + " bytes)");
  Bytes in(data.data() + 84, data.size() - 84);
  Welder weld(shown);
  std::vector<int> tris;
  tris.reserve(static_cast<std::size_t>(3 * n));
  for (std::uint64_t t = 0; t < n; ++t) {
    in.skip(12);  // the stored normal: derived data, often zero or stale
    for (int c = 0; c < 3; ++c) {
      double p[3];
      for (double& x : p) in.f32(x);
      if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
        fail(kWhat, shown,
             "triangle " + std::to_string(t) + " (byte " + std::to_string(84 + 50 * t) + ") has a non-finite coordinate");
      tris.push_back(weld.add(p[0], p[1], p[2]));
    }
    in.skip(2);
  }
  out.polygons = static_cast<Index>(n);
  finish_mesh(shown, weld.vertices(), tris, out);
}

// ASCII STL, one statement per line:
//   solid [name]
//     facet normal nx ny nz
//       outer loop
//         vertex x y z     (three times)
//       endloop
//     endfacet
//   endsolid [name]
// Keywords in any case, blank lines anywhere; several solids may follow each
// other (their facets form one mesh). Nothing but blank lines may follow the
// last endsolid.
void read_ascii_stl(const std::string& file, const std::string& shown, MeshData& out) {
  Lines in(file, shown);
  std::string line;
  std::vector<std::string> t;
  std::string key;
  auto next = [&]() {
    while (in.next(line)) {
      t = tokens_of(line, false);
      if (!t.empty()) {
        key = lower(t[0]);
        return true;
      }
    }
    if (!in.ok()) fail(kWhat, shown, "read error");
    key.clear();
    return false;
  };
  auto L = [&]() { return at_line(in.number()); };
  // The current line must be `kw` followed by exactly `args` values.
  auto expect = [&](const char* kw, std::size_t args, const char* form) {
    if (t.empty())
      fail(kWhat, shown, std::string("the file is truncated: it ends where '") + kw + "' was expected");
    if (key != kw) fail(kWhat, shown, L() + "expected '" + form + "', found " + quote(line));
    if (t.size() != 1 + args)
      fail(kWhat, shown,
           L() + "'" + kw + "' takes " + std::to_string(args) + " values ('" + form + "'), the line has " +
               std::to_string(t.size() - 1) + ": " + quote(line));
  };
  auto three = [&](const char* what, bool finite, double p[3]) {
    for (int c = 0; c < 3; ++c) {
      const std::string& tok = t[static_cast<std::size_t>(t.size() - 3 + c)];
      if (!parse_double(tok, p[c])) fail(kWhat, shown, L() + what + ": " + quote(tok) + " is not a number");
      if (finite && !std::isfinite(p[c]))
        fail(kWhat, shown, L() + what + " has a non-finite coordinate " + quote(tok) + " (NaN, Inf or out of double range)");
    }
  };
  auto step = [&]() {
    t.clear();
    next();
  };

  Welder weld(shown);
  std::vector<int> tris;
  Index facets = 0;
  next();
  if (key != "solid") fail(kWhat, shown, L() + "expected 'solid' at the start of an ASCII STL file, found " + quote(line));
  while (key == "solid") {
    step();
    while (key == "facet") {
      if (t.size() < 2 || lower(t[1]) != "normal" || t.size() != 5)
        fail(kWhat, shown, L() + "expected 'facet normal nx ny nz', found " + quote(line));
      double n[3];
      // Parsed so that a malformed number is refused, then not kept: stored facet
      // normals are often zero or stale, and a vertex mesh has no use for them.
      three("facet normal", false, n);
      step();
      if (key != "outer" || t.size() != 2 || lower(t[1]) != "loop") {
        if (t.empty()) fail(kWhat, shown, "the file is truncated: it ends where 'outer loop' was expected");
        fail(kWhat, shown, L() + "expected 'outer loop', found " + quote(line));
      }
      for (int c = 0; c < 3; ++c) {
        step();
        expect("vertex", 3, "vertex x y z");
        double p[3];
        three("vertex", true, p);
        tris.push_back(weld.add(p[0], p[1], p[2]));
      }
      step();
      expect("endloop", 0, "endloop");
      step();
      expect("endfacet", 0, "endfacet");
      if (++facets > std::numeric_limits<int>::max() / 3) fail(kWhat, shown, L() + "more facets than this reader can index");
      step();
    }
    if (t.empty()) fail(kWhat, shown, "the file is truncated: it ends where 'endsolid' was expected");
    if (key != "endsolid") fail(kWhat, shown, L() + "expected 'facet normal' or 'endsolid', found " + quote(line));
    step();  // the rest of the endsolid line is the solid's name
  }
  if (!t.empty()) fail(kWhat, shown, L() + "unexpected data after 'endsolid': " + quote(line));
  out.polygons = facets;
  finish_mesh(shown, weld.vertices(), tris, out);
}

}  // namespace

void read_stl(const std::string& file, const std::string& shown, std::uint64_t size, MeshData& out) {
  unsigned char head[84] = {};
  {
    std::ifstream in(file, std::ios::binary);
    in.read(reinterpret_cast<char*>(head), 84);
    if (in.bad()) fail(kWhat, shown, "read error");
  }
  const std::uint64_t n = size >= 84 ? u32_le(head + 80) : 0;
  const std::uint64_t want = 84 + 50 * n;
  if (size >= 84 && size == want) return read_binary_stl(file, shown, n, out);
  // A UTF-8 byte-order mark may precede an ASCII file's "solid" (Lines drops it).
  const std::size_t bom = size >= 3 && std::memcmp(head, "\xEF\xBB\xBF", 3) == 0 ? 3 : 0;
  if (size >= bom + 5 && lower(std::string(reinterpret_cast<const char*>(head) + bom, 5)) == "solid")
    return read_ascii_stl(file, shown, out);
  if (size < 84) fail(kWhat, shown, "the file is truncated: a binary STL needs an 84-byte header, the file has " + std::to_string(size) + " bytes");
  fail(kWhat, shown,
       std::string(size < want ? "the file is truncated or not an STL file"
                               : "not a binary STL file (or data after its end)") +
           ": the binary header announces " + std::to_string(n) + " triangles (" + std::to_string(want) +
           " bytes), the file has " + std::to_string(size) + " bytes");
}

}  // namespace vpffd::io_detail
