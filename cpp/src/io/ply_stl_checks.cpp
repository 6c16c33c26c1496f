// PLY and STL are read by OpenMesh, but only after the checks in this file have
// gone through the whole file: OpenMesh's readers trust their input (an ASCII
// value that does not parse becomes 0, a short binary file leaves garbage in
// the last records, a PLY header "format ascii" without a version sends its
// can_u_read into an endless loop). What passes here is a file OpenMesh reads
// completely and as the header describes it.

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

// Size in bytes of a PLY scalar type name (0 if unknown).
int ply_type_size(const std::string& t) {
  if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
  if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
  if (t == "int" || t == "uint" || t == "float" || t == "int32" || t == "uint32" || t == "float32") return 4;
  if (t == "double" || t == "float64") return 8;
  return 0;
}

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

// ---- PLY ------------------------------------------------------------------------

struct PlyProp {
  std::string name, type, count_type;  // count_type: "" unless a list
  bool list() const { return !count_type.empty(); }
};
struct PlyElement {
  std::string name;
  std::uint64_t count = 0;
  std::vector<PlyProp> props;
};
struct PlyHeader {
  std::string format;  // ascii, binary_little_endian, binary_big_endian
  std::vector<PlyElement> elements;
  std::uint64_t bytes = 0;  // header length including end_header's newline
};

bool is_int_type(const std::string& t) { return ply_type_size(t) > 0 && t.find("float") == std::string::npos && t != "double"; }

// The header, parsed strictly: "ply", one "format <ascii|binary_little_endian|
// binary_big_endian> 1.0", elements with non-negative counts and known property
// types, comments, "end_header". Returns "" or the problem naming the line.
std::string parse_ply_header(const std::string& file, PlyHeader& h) {
  std::ifstream in(file, std::ios::binary);
  std::string line;
  long long n = 0;
  // A header is a few hundred bytes; 64 KiB of lines without end_header is not one.
  constexpr std::uint64_t kMaxHeader = 1 << 16;
  bool ended = false;
  while (!ended) {
    line.clear();
    int c = 0;
    while ((c = in.get()) != EOF && c != '\n') {
      line.push_back(static_cast<char>(c));
      if (h.bytes + line.size() > kMaxHeader) return "the PLY header is longer than 64 KiB without an end_header line";
    }
    if (c == EOF && line.empty()) break;
    h.bytes += line.size() + (c == '\n' ? 1 : 0);
    ++n;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const std::string L = at_line(n);
    if (n == 1) {
      if (line != "ply") return L + "not a PLY file (the first line is " + quote(line) + ", not 'ply')";
      continue;
    }
    const auto t = tokens_of(line, false);
    if (t.empty()) return L + "an empty line in the PLY header";
    const std::string& kw = t[0];
    if (kw == "comment" || kw == "obj_info") continue;
    if (kw == "format") {
      if (!h.format.empty()) return L + "a second format line";
      if (t.size() != 3 || (t[1] != "ascii" && t[1] != "binary_little_endian" && t[1] != "binary_big_endian") ||
          t[2] != "1.0")
        return L + "expected 'format ascii|binary_little_endian|binary_big_endian 1.0', found " + quote(line);
      h.format = t[1];
    } else if (kw == "element") {
      long long count = -1;
      if (h.format.empty()) return L + "an element before the format line";
      if (t.size() != 3 || !parse_int(t[2], count) || count < 0 || count > std::numeric_limits<int>::max())
        return L + "expected 'element <name> <count>' with a count in [0, 2^31), found " + quote(line);
      h.elements.push_back({t[1], static_cast<std::uint64_t>(count), {}});
    } else if (kw == "property") {
      if (h.elements.empty()) return L + "a property before any element";
      PlyProp p;
      if (t.size() == 5 && t[1] == "list" && is_int_type(t[2]) && ply_type_size(t[3]) > 0)
        p = {t[4], t[3], t[2]};
      else if (t.size() == 3 && ply_type_size(t[1]) > 0)
        p = {t[2], t[1], ""};
      else
        return L + "expected 'property <type> <name>' or 'property list <integer type> <type> <name>', found " +
               quote(line);
      h.elements.back().props.push_back(p);
    } else if (kw == "end_header") {
      if (t.size() != 1) return L + "unexpected text after end_header: " + quote(line);
      ended = true;
    } else {
      return L + "unknown PLY header keyword " + quote(kw);
    }
  }
  if (!ended) return "the PLY header has no end_header line";
  if (h.format.empty()) return "the PLY header has no format line";
  const PlyElement* vertex = nullptr;
  for (const auto& e : h.elements) {
    if (e.props.empty() && e.count > 0) return "element '" + printable(e.name) + "' has records but no properties";
    if (e.name == "vertex") vertex = &e;
    for (const auto& p : e.props) {
      if (e.name == "vertex" && (p.name == "x" || p.name == "y" || p.name == "z") && p.list())
        return "vertex property '" + p.name + "' is a list, not a number";
      if (e.name == "face" && (p.name == "vertex_indices" || p.name == "vertex_index") &&
          (!p.list() || !is_int_type(p.type)))
        return "face property '" + p.name + "' must be a list of integers";
    }
  }
  if (!vertex) return "the PLY header has no vertex element";
  for (const char* axis : {"x", "y", "z"})
    if (std::none_of(vertex->props.begin(), vertex->props.end(), [&](const PlyProp& p) { return p.name == axis; }))
      return std::string("the vertex element has no property '") + axis + "'";
  return "";
}

// Binary PLY: walks every record, reading only the list counts, so that a file
// shorter than its header says or a list count past the end of the file is
// found before OpenMesh reads (it would fill the records with garbage).
std::string check_binary_ply(const std::string& file, const PlyHeader& h, std::uint64_t size) {
  if (size < h.bytes) return "the file is truncated inside its header";
  std::ifstream in(file, std::ios::binary);
  in.seekg(static_cast<std::streamoff>(h.bytes));
  std::vector<unsigned char> body(static_cast<std::size_t>(size - h.bytes));
  if (!body.empty() && !in.read(reinterpret_cast<char*>(body.data()), static_cast<std::streamsize>(body.size())))
    return "read error";
  Bytes b(body.data(), body.size(), h.format == "binary_big_endian");
  for (const auto& e : h.elements) {
    // The least bytes one record takes (lists with their count only).
    std::uint64_t least = 0;
    for (const auto& p : e.props) least += static_cast<std::uint64_t>(ply_type_size(p.list() ? p.count_type : p.type));
    if (times(e.count, least) > b.left())
      return "the file is truncated: the header announces " + std::to_string(e.count) + " '" + printable(e.name) +
             "' records of at least " + std::to_string(least) + " bytes, " + std::to_string(b.left()) +
             " bytes are left";
    // Per property: value bytes, list-count bytes (0: a scalar), count signed.
    struct Layout {
      std::uint64_t size;
      int count_size;
      bool count_signed;
    };
    std::vector<Layout> layout;
    for (const auto& p : e.props)
      layout.push_back({static_cast<std::uint64_t>(ply_type_size(p.type)), p.list() ? ply_type_size(p.count_type) : 0,
                        p.list() && p.count_type.find('u') == std::string::npos});
    for (std::uint64_t r = 0; r < e.count; ++r)
      for (std::size_t j = 0; j < layout.size(); ++j) {
        const Layout& p = layout[j];
        if (p.count_size == 0) {
          b.skip(p.size);
          continue;
        }
        std::uint64_t k = 0;
        if (!b.uint(p.count_size, k))
          return "the file is truncated inside " + printable(e.name) + " " + std::to_string(r);
        // A signed count with its top bit set is negative.
        if (p.count_signed && (k >> (8 * p.count_size - 1)) & 1)
          return printable(e.name) + " " + std::to_string(r) + ": negative list length";
        if (!b.skip(times(k, p.size)))
          return "the file is truncated or corrupt: " + printable(e.name) + " " + std::to_string(r) + " has a list of " +
                 std::to_string(k) + " values, " + std::to_string(b.left()) + " bytes are left";
      }
  }
  if (b.left() != 0) return std::to_string(b.left()) + " bytes of unexpected data after the last record";
  return "";
}

// ASCII PLY: every record of every element must have exactly the values its
// properties ask for, integers where the type is an integer, and finite x, y, z
// for vertices. Returns "" or the problem, naming the line.
std::string check_ascii_ply(const std::string& file, const std::string& shown, const PlyHeader& h) {
  Lines in(file, shown);
  std::string line;
  while (in.next(line))
    if (line == "end_header") break;
  std::vector<std::string> t;
  auto next_tokens = [&]() {
    while (in.next(line)) {
      t = tokens_of(line, false);
      if (!t.empty()) return true;
    }
    return false;
  };
  for (const PlyElement& e : h.elements) {
    const bool vertex = e.name == "vertex";
    for (std::uint64_t r = 0; r < e.count; ++r) {
      const std::string what = printable(e.name) + " " + std::to_string(r);
      if (!next_tokens())
        return "the file is truncated: the header announces " + std::to_string(e.count) + " " + printable(e.name) +
               " records, the file ends after " + std::to_string(r);
      const std::string L = at_line(in.number());
      size_t k = 0;
      for (const PlyProp& pr : e.props) {
        long long n = 1;
        if (pr.list()) {
          if (k >= t.size()) return L + what + " has too few values (property '" + printable(pr.name) + "' is missing)";
          if (!parse_int(t[k], n) || n < 0)
            return L + what + ": list length " + quote(t[k]) + " of '" + printable(pr.name) +
                   "' is not a non-negative integer";
          ++k;
          if (static_cast<unsigned long long>(n) > t.size() - k)
            return L + what + " has too few values (list '" + printable(pr.name) + "' announces " + std::to_string(n) + ")";
        }
        const bool int_value = is_int_type(pr.type);
        for (long long c = 0; c < n; ++c, ++k) {
          if (k >= t.size()) return L + what + " has too few values (property '" + printable(pr.name) + "' is missing)";
          double x = 0;
          long long i = 0;
          if (int_value ? !parse_int(t[k], i) : !parse_double(t[k], x))
            return L + what + ": " + quote(t[k]) + " is not " + (int_value ? "an integer" : "a number") +
                   " (property '" + printable(pr.name) + "')";
          if (vertex && !pr.list() && (pr.name == "x" || pr.name == "y" || pr.name == "z") && !int_value &&
              !std::isfinite(x))
            return L + what + " has a non-finite coordinate " + pr.name + " = " + quote(t[k]);
        }
      }
      if (k != t.size())
        return L + what + " has " + std::to_string(t.size()) + " values, its properties need " + std::to_string(k);
    }
  }
  if (next_tokens())
    return at_line(in.number()) + "unexpected data after the last record the header announces: " + quote(line);
  return "";
}

}  // namespace

std::string check_ply(const std::string& file, const std::string& shown, std::uint64_t size) {
  PlyHeader h;
  std::string problem = parse_ply_header(file, h);
  if (!problem.empty()) return problem;
  return h.format == "ascii" ? check_ascii_ply(file, shown, h) : check_binary_ply(file, h, size);
}

std::string check_stl(const std::string& file, const std::string& shown, std::uint64_t size) {
  return check_stl_complete(file, size, shown);
}

}  // namespace vpffd::io_detail
