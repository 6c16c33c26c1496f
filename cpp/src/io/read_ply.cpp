// PLY, ASCII and binary of both byte orders, read by vpffd: every scalar type the
// format names (char/int8 ... double/float64) for any property, list counts and list
// values of any integer type (any type for lists other than the faces'), vertex
// coordinates of any scalar type (converted to float64; integer coordinates are
// noted in MeshData::notes), normals nx/ny/nz, and any other element or property,
// list properties of the vertex element included, skipped by its layout. OpenMesh's
// reader took a few count and index types only and printed to stderr; this one
// takes what the format allows and says in the exception what it does not.
//
// Memory: each element's records are checked against the bytes left before
// anything is allocated for them (a binary record takes at least the sum of its
// properties' sizes, lists counted by their count only; an ASCII record at least
// two bytes a value), so a file of a few hundred bytes cannot make the reader
// allocate more than a small multiple of its size.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "io_util.h"
#include "readers.h"

namespace vpffd::io_detail {
namespace {

enum class Kind { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64, None };

Kind kind_of(const std::string& t) {
  if (t == "char" || t == "int8") return Kind::Int8;
  if (t == "uchar" || t == "uint8") return Kind::UInt8;
  if (t == "short" || t == "int16") return Kind::Int16;
  if (t == "ushort" || t == "uint16") return Kind::UInt16;
  if (t == "int" || t == "int32") return Kind::Int32;
  if (t == "uint" || t == "uint32") return Kind::UInt32;
  if (t == "float" || t == "float32") return Kind::Float32;
  if (t == "double" || t == "float64") return Kind::Float64;
  return Kind::None;
}
int size_of(Kind k) {
  switch (k) {
    case Kind::Int8: case Kind::UInt8: return 1;
    case Kind::Int16: case Kind::UInt16: return 2;
    case Kind::Int32: case Kind::UInt32: case Kind::Float32: return 4;
    case Kind::Float64: return 8;
    default: return 0;
  }
}
bool is_integer(Kind k) { return k != Kind::Float32 && k != Kind::Float64 && k != Kind::None; }

struct Prop {
  std::string name;
  Kind type = Kind::None, count = Kind::None;  // count: None unless a list
  bool list() const { return count != Kind::None; }
};
struct Element {
  std::string name;
  std::uint64_t count = 0;
  std::vector<Prop> props;
};
struct Header {
  std::string format;  // ascii, binary_little_endian, binary_big_endian
  std::vector<Element> elements;
  std::uint64_t bytes = 0;  // header length including end_header's newline
};

// The header, parsed strictly: "ply", one "format <ascii|binary_little_endian|
// binary_big_endian> 1.0", elements with counts and known property types,
// comments, "end_header". Returns "" or the problem naming the line.
std::string parse_header(const std::string& file, Header& h) {
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
      if (line.compare(0, 3, "\xEF\xBB\xBF") == 0) line.erase(0, 3);  // a UTF-8 byte-order mark
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
          (t[2] != "1.0" && t[2] != "1"))
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
      Prop p;
      if (t.size() == 5 && t[1] == "list" && is_integer(kind_of(t[2])) && kind_of(t[3]) != Kind::None)
        p = {t[4], kind_of(t[3]), kind_of(t[2])};
      else if (t.size() == 3 && kind_of(t[1]) != Kind::None)
        p = {t[2], kind_of(t[1]), Kind::None};
      else
        return L + "expected 'property <type> <name>' or 'property list <integer type> <type> <name>' (types: " +
               "char uchar short ushort int uint float double, or int8 ... float64), found " + quote(line);
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
  const Element* vertex = nullptr;
  for (const auto& e : h.elements) {
    if (e.props.empty() && e.count > 0) return "element '" + printable(e.name) + "' has records but no properties";
    if (e.name == "vertex") vertex = &e;
    for (const auto& p : e.props) {
      if (e.name == "vertex" && (p.name == "x" || p.name == "y" || p.name == "z") && p.list())
        return "vertex property '" + p.name + "' is a list, not a number";
      if (e.name == "face" && (p.name == "vertex_indices" || p.name == "vertex_index") &&
          (!p.list() || !is_integer(p.type)))
        return "face property '" + p.name + "' must be a list of integers";
    }
  }
  if (!vertex) return "the PLY header has no vertex element";
  for (const char* axis : {"x", "y", "z"})
    if (std::none_of(vertex->props.begin(), vertex->props.end(), [&](const Prop& p) { return p.name == axis; }))
      return std::string("the vertex element has no property '") + axis + "'";
  return "";
}

// What the mesh takes from each record: a vertex's coordinate or normal component
// (slot 0-5), a face's index list (slot 6), or nothing (-1).
int slot_of(const Element& e, const Prop& p) {
  if (e.name == "vertex" && !p.list()) {
    static const char* names[6] = {"x", "y", "z", "nx", "ny", "nz"};
    for (int s = 0; s < 6; ++s)
      if (p.name == names[s]) return s;
  }
  if (e.name == "face" && p.list() && (p.name == "vertex_indices" || p.name == "vertex_index")) return 6;
  return -1;
}

/// Where records' values go: vertex coordinates and normals, face fans.
struct Sink {
  std::vector<double> V, N;
  std::vector<int> tris;
  std::vector<long long> polygon;
  bool normals = false;
  MeshData* out = nullptr;
  void face(const std::string& shown, const std::string& where) {
    ++out->polygons;
    const std::size_t k = polygon.size();
    if (k < 3) {
      ++out->skipped_faces;
      return;
    }
    if (k > 3) ++out->triangulated_polygons;
    for (std::size_t c = 1; c + 1 < k; ++c)
      for (long long i : {polygon[0], polygon[c], polygon[c + 1]}) {
        // Out of int range cannot be a vertex (finish_mesh checks the rest).
        if (i < 0 || i > std::numeric_limits<int>::max())
          fail("load_mesh", shown, where + " refers to vertex " + std::to_string(i) + ", which cannot exist");
        tris.push_back(static_cast<int>(i));
      }
  }
};

// One binary value of type k as a double (integers exactly: at most 32 bits).
bool read_value(Bytes& b, Kind k, double& v) {
  std::uint64_t u = 0;
  switch (k) {
    case Kind::Float32: return b.f32(v);
    case Kind::Float64: return b.f64(v);
    case Kind::Int8: if (!b.uint(1, u)) return false; v = static_cast<std::int8_t>(u); return true;
    case Kind::Int16: if (!b.uint(2, u)) return false; v = static_cast<std::int16_t>(u); return true;
    case Kind::Int32: if (!b.uint(4, u)) return false; v = static_cast<std::int32_t>(u); return true;
    default: if (!b.uint(size_of(k), u)) return false; v = static_cast<double>(u); return true;
  }
}

void read_binary(const std::string& file, const std::string& shown, std::uint64_t size, const Header& h, Sink& s) {
  const char* what = "load_mesh";
  if (size < h.bytes) fail(what, shown, "the file is truncated inside its header");
  std::ifstream in(file, std::ios::binary);
  in.seekg(static_cast<std::streamoff>(h.bytes));
  std::vector<unsigned char> body(static_cast<std::size_t>(size - h.bytes));
  if (!body.empty() && !in.read(reinterpret_cast<char*>(body.data()), static_cast<std::streamsize>(body.size())))
    fail(what, shown, "read error");
  Bytes b(body.data(), body.size(), h.format == "binary_big_endian");
  for (const Element& e : h.elements) {
    std::uint64_t least = 0;  // the least bytes one record takes (lists by their count only)
    for (const Prop& p : e.props) least += static_cast<std::uint64_t>(size_of(p.list() ? p.count : p.type));
    if (times(e.count, least) > b.left())
      fail(what, shown, "the file is truncated: the header announces " + std::to_string(e.count) + " '" +
                            printable(e.name) + "' records of at least " + std::to_string(least) + " bytes, " +
                            std::to_string(b.left()) + " bytes are left");
    std::vector<int> slot;
    for (const Prop& p : e.props) slot.push_back(slot_of(e, p));
    const bool vertex = e.name == "vertex";
    if (vertex) {
      s.V.assign(3 * static_cast<std::size_t>(e.count), 0.0);
      if (s.normals) s.N.assign(3 * static_cast<std::size_t>(e.count), 0.0);
    }
    for (std::uint64_t r = 0; r < e.count; ++r) {
      for (std::size_t j = 0; j < e.props.size(); ++j) {
        const Prop& p = e.props[j];
        if (!p.list()) {
          double v = 0;
          if (slot[j] < 0) {
            b.skip(static_cast<std::uint64_t>(size_of(p.type)));  // fits: checked above
            continue;
          }
          read_value(b, p.type, v);
          if (slot[j] < 3) {
            if (!std::isfinite(v))
              fail(what, shown, "vertex " + std::to_string(r) + " has a non-finite coordinate " + p.name);
            s.V[3 * r + static_cast<std::size_t>(slot[j])] = v;
          } else if (s.normals) {
            s.N[3 * r + static_cast<std::size_t>(slot[j] - 3)] = v;
          }
          continue;
        }
        double n = 0;
        if (!read_value(b, p.count, n))
          fail(what, shown, "the file is truncated inside " + printable(e.name) + " " + std::to_string(r));
        if (n < 0) fail(what, shown, printable(e.name) + " " + std::to_string(r) + ": negative list length");
        const auto k = static_cast<std::uint64_t>(n);
        if (times(k, static_cast<std::uint64_t>(size_of(p.type))) > b.left())
          fail(what, shown, "the file is truncated or corrupt: " + printable(e.name) + " " + std::to_string(r) +
                                " has a list of " + std::to_string(k) + " values, " + std::to_string(b.left()) +
                                " bytes are left");
        if (slot[j] != 6) {
          b.skip(times(k, static_cast<std::uint64_t>(size_of(p.type))));
          continue;
        }
        s.polygon.clear();
        for (std::uint64_t c = 0; c < k; ++c) {
          double i = 0;
          read_value(b, p.type, i);
          s.polygon.push_back(static_cast<long long>(i));
        }
        s.face(shown, "face " + std::to_string(r));
      }
    }
  }
  if (b.left() != 0) fail(what, shown, std::to_string(b.left()) + " bytes of unexpected data after the last record");
}

// ASCII PLY: one record a line, exactly the values its properties ask for, integers
// where the type is an integer, finite coordinates. Errors name the line.
void read_ascii(const std::string& file, const std::string& shown, std::uint64_t size, const Header& h, Sink& s) {
  const char* what = "load_mesh";
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
  const std::uint64_t body = size > h.bytes ? size - h.bytes : 0;
  for (const Element& e : h.elements) {
    // Every value takes at least two bytes (a digit and a separator).
    if (times(e.count, 2 * e.props.size()) > body)
      fail(what, shown, "the file is truncated: the header announces " + std::to_string(e.count) + " " +
                            printable(e.name) + " records, more than its " + std::to_string(body) +
                            " bytes after the header can hold");
    std::vector<int> slot;
    for (const Prop& p : e.props) slot.push_back(slot_of(e, p));
    if (e.name == "vertex") {
      s.V.assign(3 * static_cast<std::size_t>(e.count), 0.0);
      if (s.normals) s.N.assign(3 * static_cast<std::size_t>(e.count), 0.0);
    }
    for (std::uint64_t r = 0; r < e.count; ++r) {
      const std::string rec = printable(e.name) + " " + std::to_string(r);
      if (!next_tokens())
        fail(what, shown, "the file is truncated: the header announces " + std::to_string(e.count) + " " +
                              printable(e.name) + " records, the file ends after " + std::to_string(r));
      const std::string L = at_line(in.number());
      std::size_t k = 0;
      auto value = [&](Kind type, const Prop& p, double& v) {
        if (k >= t.size()) fail(what, shown, L + rec + " has too few values (property '" + printable(p.name) + "')");
        long long i = 0;
        if (is_integer(type)) {
          if (!parse_int(t[k], i))
            fail(what, shown, L + rec + ": " + quote(t[k]) + " is not an integer (property '" + printable(p.name) + "')");
          v = static_cast<double>(i);
        } else if (!parse_double(t[k], v)) {
          fail(what, shown, L + rec + ": " + quote(t[k]) + " is not a number (property '" + printable(p.name) + "')");
        }
        ++k;
      };
      for (std::size_t j = 0; j < e.props.size(); ++j) {
        const Prop& p = e.props[j];
        double v = 0;
        if (!p.list()) {
          value(p.type, p, v);
          if (slot[j] >= 0 && slot[j] < 3) {
            if (!std::isfinite(v))
              fail(what, shown, L + rec + " has a non-finite coordinate " + p.name + " = " + quote(t[k - 1]));
            s.V[3 * r + static_cast<std::size_t>(slot[j])] = v;
          } else if (slot[j] >= 3 && s.normals) {
            s.N[3 * r + static_cast<std::size_t>(slot[j] - 3)] = v;
          }
          continue;
        }
        double n = 0;
        value(p.count, p, n);
        if (n < 0) fail(what, shown, L + rec + ": negative list length of '" + printable(p.name) + "'");
        if (n > static_cast<double>(t.size() - k))
          fail(what, shown, L + rec + " has too few values (list '" + printable(p.name) + "' announces " +
                                quote(t[k - 1]) + ")");
        s.polygon.clear();
        for (long long c = 0; c < static_cast<long long>(n); ++c) {
          value(p.type, p, v);
          if (slot[j] == 6) s.polygon.push_back(static_cast<long long>(v));
        }
        if (slot[j] == 6) s.face(shown, L + rec);
      }
      if (k != t.size())
        fail(what, shown,
             L + rec + " has " + std::to_string(t.size()) + " values, its properties need " + std::to_string(k));
    }
  }
  if (next_tokens())
    fail(what, shown, at_line(in.number()) + "unexpected data after the last record the header announces: " +
                          quote(line));
}

}  // namespace

void read_ply(const std::string& file, const std::string& shown, std::uint64_t size, MeshData& out) {
  Header h;
  const std::string problem = parse_header(file, h);
  if (!problem.empty()) fail("load_mesh", shown, problem);
  Sink s;
  s.out = &out;
  for (const Element& e : h.elements)
    if (e.name == "vertex") {
      int normal = 0;
      for (const Prop& p : e.props) {
        const int k = slot_of(e, p);
        normal += k >= 3 && k < 6;
        if (k >= 0 && k < 3 && is_integer(p.type))
          out.notes.push_back("coordinate '" + p.name + "' is stored as integers (" + std::to_string(size_of(p.type)) +
                              "-byte); read as float64");
      }
      s.normals = normal == 3;
    }
  if (h.format == "ascii")
    read_ascii(file, shown, size, h, s);
  else
    read_binary(file, shown, size, h, s);
  finish_mesh(shown, s.V, s.tris, out);
  if (s.normals) {
    out.N = Eigen::Map<const RowMatrixX3d>(s.N.data(), out.V.rows(), 3);
    if (!out.N.allFinite()) out.N.resize(0, 3);  // unusable normals are dropped, not fatal
  }
}

}  // namespace vpffd::io_detail
