// STL is read by OpenMesh, but only after the checks in this file have gone
// through the whole file: OpenMesh's reader trusts its input (an ASCII value that
// does not parse becomes 0, a short binary file leaves garbage in the last
// records). What passes here is a file OpenMesh reads completely and as its
// header or keywords describe it. (PLY is read by vpffd: read_ply.cpp.)

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "io_util.h"
#include "readers.h"

namespace vpffd::io_detail {
namespace {

// ASCII STL: solid / facet normal a b c / outer loop / 3 x vertex x y z /
// endloop / endfacet ... endsolid, with numbers that parse completely and
// finite vertex coordinates. Returns "" or the problem, naming the line.
std::string check_ascii_stl(const std::string& file, const std::string& shown) {
  // A token stream over the lines (streamed: ASCII STL files can be large).
  Lines in(file, shown);
  std::string line;
  std::vector<std::string> t;
  size_t at = 0;
  bool more = true;
  auto peek = [&]() -> const std::string* {
    while (at >= t.size()) {
      if (!more || !in.next(line)) {
        more = false;
        return nullptr;
      }
      t = tokens_of(line, false);
      at = 0;
    }
    return &t[at];
  };
  auto word = [&]() {
    const std::string* w = peek();
    return w ? lower(*w) : std::string();
  };
  auto L = [&]() { return at_line(in.number()); };
  auto expect = [&](const char* w) -> std::string {
    const std::string* x = peek();
    if (!x) return "the file is truncated: it ends where '" + std::string(w) + "' was expected";
    if (lower(*x) != w) return L() + "expected '" + w + "', found " + quote(*x);
    ++at;
    return "";
  };
  auto numbers = [&](const std::string& what, bool finite) -> std::string {
    for (int c = 0; c < 3; ++c, ++at) {
      const std::string* x = peek();
      if (!x) return "the file is truncated: it ends inside a '" + what + "' line";
      double v = 0;
      if (!parse_double(*x, v)) return L() + what + ": " + quote(*x) + " is not a number";
      if (finite && !std::isfinite(v)) return L() + what + " has a non-finite coordinate " + quote(*x);
    }
    return "";
  };
  if (word() != "solid") return "";  // not ASCII; the reader decides
  // "solid" may be followed by a name of any number of words, up to the first facet.
  ++at;
  while (peek() && word() != "facet" && word() != "endsolid") ++at;
  std::string e;
  while (word() == "facet") {
    ++at;
    if (!(e = expect("normal")).empty() || !(e = numbers("facet normal", false)).empty() ||
        !(e = expect("outer")).empty() || !(e = expect("loop")).empty())
      return e;
    for (int c = 0; c < 3; ++c)
      if (!(e = expect("vertex")).empty() || !(e = numbers("vertex", true)).empty()) return e;
    if (!(e = expect("endloop")).empty() || !(e = expect("endfacet")).empty()) return e;
  }
  return expect("endsolid");  // a name may follow; anything after it is ignored
}
// STL has no vertex count to compare with, but binary STL has a face count and
// ASCII STL an "endsolid" line; a file cut short lacks one or the other.
std::string check_stl_complete(const std::string& file, std::uintmax_t size, const std::string& shown) {
  std::ifstream in(file, std::ios::binary);
  char head[84] = {};
  in.read(head, 84);
  const bool solid = size >= 5 && std::string(head, 5) == "solid";
  std::uint32_t n = 0;
  if (size >= 84) {
    const auto* b = reinterpret_cast<const unsigned char*>(head + 80);
    n = b[0] | (b[1] << 8) | (b[2] << 16) | (static_cast<std::uint32_t>(b[3]) << 24);
  }
  const std::uintmax_t want = 84 + 50 * static_cast<std::uintmax_t>(n);
  if (solid && !(size >= 84 && want == size)) {
    // ASCII: the last keyword must be "endsolid".
    const std::uintmax_t tail = std::min<std::uintmax_t>(size, 4096);
    std::string end(static_cast<size_t>(tail), '\0');
    in.clear();
    in.seekg(static_cast<std::streamoff>(size - tail));
    in.read(end.data(), static_cast<std::streamsize>(tail));
    if (end.find("endsolid") == std::string::npos) return "the file is truncated: no 'endsolid' line at its end";
    return check_ascii_stl(file, shown);
  }
  if (size < 84) return "the file is truncated: a binary STL needs an 84-byte header";
  if (size != want)
    return std::string(size < want ? "truncated or not an STL file" : "not a binary STL file (or data after its end)") +
           ": the binary header announces " + std::to_string(n) + " triangles (" + std::to_string(want) +
           " bytes), the file has " + std::to_string(size) + " bytes";
  return "";
}

}  // namespace

std::string check_stl(const std::string& file, const std::string& shown, std::uint64_t size) {
  return check_stl_complete(file, size, shown);
}

}  // namespace vpffd::io_detail
