// Mesh files through OpenMesh. OpenMesh reports failures as a bool plus text on
// its omerr() stream; both are turned into MeshIOError here, with the file name.

#include "vpffd/io/mesh_io.h"

#include <zlib.h>

#include <OpenMesh/Core/IO/IOManager.hh>
#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/IO/importer/ImporterT.hh>
#include <OpenMesh/Core/Mesh/PolyMesh_ArrayKernelT.hh>
#include <OpenMesh/Core/System/omstream.hh>
#include <algorithm>
#include <array>
#include <iostream>
#include <memory>
#include <atomic>
#include <cctype>
#include <chrono>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>

#include "vpffd/core/check.h"
#include "vpffd/core/exceptions.h"
#include "vpffd/mesh/validate.h"

namespace fs = std::filesystem;

namespace vpffd {
namespace {

// Double-precision points and normals so that ASCII files and OM files keep
// every digit they have.
struct DoubleTraits : OpenMesh::DefaultTraits {
  typedef OpenMesh::Vec3d Point;
  typedef OpenMesh::Vec3d Normal;
};
using OMesh = OpenMesh::PolyMesh_ArrayKernelT<DoubleTraits>;

const std::vector<std::string> kFormats = {"obj", "off", "ply", "stl", "om"};

// OpenMesh's IOManager and its omerr() stream are process-wide singletons.
std::mutex& io_mutex() {
  static std::mutex m;
  return m;
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

[[noreturn]] void fail(const std::string& what, const std::string& path, const std::string& why) {
  throw MeshIOError(what + ": '" + path + "': " + why);
}

// Collects what OpenMesh writes to omerr() during one call instead of letting it
// reach the terminal (a non-manifold scan prints one line per face), so that the
// text can go into the exception message. omlog() and omout() (progress chatter
// such as "[OBJWriter] : write file") are muted for the same time.
class OmerrCapture {
 public:
  OmerrCapture() {
    for (int k = 0; k < 3; ++k) {
      mostream(k).flush();
      for (int t = 0; t < 3; ++t) detached_[k][t] = mostream(k).disconnect(std_stream(t));
    }
    ::omerr().connect(text_);
  }
  ~OmerrCapture() {
    ::omerr().flush();
    ::omerr().disconnect(text_);
    for (int k = 0; k < 3; ++k) {
      mostream(k).flush();
      for (int t = 0; t < 3; ++t)
        if (detached_[k][t]) mostream(k).connect(std_stream(t));
    }
  }
  OmerrCapture(const OmerrCapture&) = delete;
  OmerrCapture& operator=(const OmerrCapture&) = delete;
  // The first few distinct lines: enough to say what went wrong.
  std::string summary(size_t max_lines = 3) {
    ::omerr().flush();
    std::istringstream in(text_.str());
    std::vector<std::string> lines;
    size_t total = 0;
    for (std::string line; std::getline(in, line);) {
      while (!line.empty() && std::isspace(static_cast<unsigned char>(line.back()))) line.pop_back();
      if (line.empty()) continue;
      ++total;
      if (std::find(lines.begin(), lines.end(), line) == lines.end() && lines.size() < max_lines)
        lines.push_back(line);
    }
    std::string s;
    for (const auto& l : lines) s += (s.empty() ? "" : "; ") + l;
    if (total > lines.size()) s += " (" + std::to_string(total) + " messages)";
    return s;
  }

 private:
  static OpenMesh::mostream& mostream(int k) { return k == 0 ? ::omerr() : k == 1 ? ::omlog() : ::omout(); }
  static std::ostream& std_stream(int t) { return t == 0 ? std::cerr : t == 1 ? std::clog : std::cout; }
  std::ostringstream text_;
  bool detached_[3][3] = {};
};

// An importer that records every face exactly as the reader delivers it, before
// OpenMesh's halfedge mesh gets a chance to reject or split it, and that ignores
// the reader's size hints (they come from file headers, which may be garbage).
class RecordingImporter : public OpenMesh::IO::ImporterT<OMesh> {
 public:
  using Base = OpenMesh::IO::ImporterT<OMesh>;
  explicit RecordingImporter(OMesh& m) : Base(m) {}

  OpenMesh::VertexHandle add_vertex(const OpenMesh::Vec3f& p) override {
    ++vertices_added;
    return Base::add_vertex(p);
  }
  OpenMesh::VertexHandle add_vertex(const OpenMesh::Vec3d& p) override {
    ++vertices_added;
    return Base::add_vertex(p);
  }
  OpenMesh::VertexHandle add_vertex() override {
    ++vertices_added;
    return Base::add_vertex();
  }
  using Base::add_face;
  OpenMesh::FaceHandle add_face(const VHandles& idx) override {
    ++polygons;
    if (idx.size() < 3) {
      ++skipped;
      return OpenMesh::FaceHandle();
    }
    if (idx.size() > 3) ++triangulated;
    for (size_t k = 1; k + 1 < idx.size(); ++k) tris.push_back({idx[0].idx(), idx[k].idx(), idx[k + 1].idx()});
    return Base::add_face(idx);
  }
  void reserve(unsigned int nV, unsigned int, unsigned int nF) override {
    header_vertices = nV;
    header_faces = nF;
  }

  std::vector<std::array<int, 3>> tris;
  Index vertices_added = 0, polygons = 0, triangulated = 0, skipped = 0;
  Index header_vertices = -1, header_faces = -1;
};

// Decompresses a gzip file into a temporary file with the inner extension (the
// readers choose themselves by extension); removed on destruction.
class GunzipTemp {
 public:
  GunzipTemp(const std::string& path, const std::string& inner_ext) {
    gzFile in = gzopen(path.c_str(), "rb");
    if (!in) fail("load_mesh", path, "cannot open the gzip file");
    static std::atomic<unsigned> counter{0};
    const auto stamp = std::chrono::steady_clock::now().time_since_epoch().count();
    tmp_ = fs::temp_directory_path() /
           ("vpffd-" + std::to_string(stamp) + "-" + std::to_string(counter++) + "." + inner_ext);
    std::ofstream out(tmp_, std::ios::binary);
    if (!out) {
      gzclose(in);
      fail("load_mesh", path, "cannot create a temporary file to decompress into");
    }
    std::vector<char> buf(1 << 20);
    for (;;) {
      const int n = gzread(in, buf.data(), static_cast<unsigned>(buf.size()));
      if (n < 0) {
        int err = 0;
        const std::string msg = gzerror(in, &err);
        gzclose(in);
        out.close();
        std::error_code ec;
        fs::remove(tmp_, ec);
        fail("load_mesh", path, "gzip data is corrupt or truncated (" + msg + ")");
      }
      if (n == 0) break;
      out.write(buf.data(), n);
      bytes_ += n;
    }
    // gzread stops silently at a truncated stream; gzclose_r reports it.
    const int rc = gzclose(in);
    out.close();
    if (rc != Z_OK || !out) {
      std::error_code ec;
      fs::remove(tmp_, ec);
      fail("load_mesh", path, rc != Z_OK ? "gzip data is corrupt or truncated" : "cannot write the temporary file");
    }
  }
  ~GunzipTemp() {
    std::error_code ec;
    fs::remove(tmp_, ec);
  }
  std::string path() const { return tmp_.string(); }
  std::uintmax_t bytes() const { return bytes_; }

 private:
  fs::path tmp_;
  std::uintmax_t bytes_ = 0;
};

std::string quote(const std::string& tok);

// Size in bytes of a PLY scalar type name (0 if unknown).
int ply_type_size(const std::string& t) {
  if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
  if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
  if (t == "int" || t == "uint" || t == "float" || t == "int32" || t == "uint32" || t == "float32") return 4;
  if (t == "double" || t == "float64") return 8;
  return 0;
}

// OpenMesh's binary PLY reader does not notice a file that ends early: it fills
// the missing records with whatever the failed reads leave behind. The header
// says how many bytes the body needs at the least (lists with their count only),
// so a short file is caught before reading. Returns "" or the problem.
std::string check_binary_ply_size(const std::string& file, std::uintmax_t size) {
  std::ifstream in(file, std::ios::binary);
  std::string line, magic;
  if (!std::getline(in, magic) || magic.rfind("ply", 0) != 0) return "";  // the reader will complain
  bool binary = false;
  std::uintmax_t need = 0;
  std::uintmax_t count = 0;
  bool ok = false;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream ls(line);
    std::string kw;
    ls >> kw;
    if (kw == "format") {
      std::string f;
      ls >> f;
      binary = f.rfind("binary", 0) == 0;
    } else if (kw == "element") {
      std::string name;
      long long n = -1;
      ls >> name >> n;
      if (n < 0) return "the header has an element with a bad count: " + quote(line);
      count = static_cast<std::uintmax_t>(n);
    } else if (kw == "property") {
      std::string t;
      ls >> t;
      if (t == "list") {
        std::string ct, it;
        ls >> ct >> it;
        need += count * static_cast<std::uintmax_t>(ply_type_size(ct));
      } else {
        need += count * static_cast<std::uintmax_t>(ply_type_size(t));
      }
    } else if (kw == "end_header") {
      ok = true;
      break;
    }
  }
  if (!ok) return "the PLY header has no end_header line";
  if (!binary) return "";
  const std::uintmax_t body = size - static_cast<std::uintmax_t>(in.tellg());
  if (body < need)
    return "the file is truncated: the header announces at least " + std::to_string(need) +
           " bytes of data, the file has " + std::to_string(body);
  return "";
}

std::string check_ascii_stl(const std::string& file);

// STL has no vertex count to compare with, but binary STL has a face count and
// ASCII STL an "endsolid" line; a file cut short lacks one or the other.
std::string check_stl_complete(const std::string& file, std::uintmax_t size) {
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
    return check_ascii_stl(file);
  }
  if (size < 84) return "the file is truncated: a binary STL needs an 84-byte header";
  if (size < want)
    return "truncated or not an STL file: the binary header announces " + std::to_string(n) + " triangles (" + std::to_string(want) +
           " bytes), the file has " + std::to_string(size) + " bytes";
  return "";
}

// --- strict ASCII checks ---------------------------------------------------------
// OpenMesh's ASCII readers read with `stream >> value` and keep going after the
// stream has failed: "nan", "1 x 0", or a file that stops before the header's
// counts are reached come back as vertices at 0 and faces [0, 0, 0], without any
// error. The ASCII formats are therefore parsed (OFF) or checked before OpenMesh
// sees them (PLY, STL) by the code below, which names the line of the problem.

// Splits a line into whitespace-separated tokens, dropping a '#' comment.
std::vector<std::string> tokens_of(const std::string& line, bool comments) {
  std::vector<std::string> t;
  size_t i = 0;
  const size_t n = comments ? std::min(line.find('#'), line.size()) : line.size();
  while (i < n) {
    while (i < n && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    size_t j = i;
    while (j < n && !std::isspace(static_cast<unsigned char>(line[j]))) ++j;
    if (j > i) t.push_back(line.substr(i, j - i));
    i = j;
  }
  return t;
}

// The whole token must be a number (strtod/strtoll leave the end pointer short
// of the token's end for "1x" or "x").
bool parse_double(const std::string& tok, double& v) {
  const char* b = tok.c_str();
  char* e = nullptr;
  v = std::strtod(b, &e);
  return e != b && *e == '\0';
}
bool parse_int(const std::string& tok, long long& v) {
  const char* b = tok.c_str();
  char* e = nullptr;
  errno = 0;
  v = std::strtoll(b, &e, 10);
  return e != b && *e == '\0' && errno != ERANGE;
}

// Reads a text file line by line with 1-based line numbers.
class Lines {
 public:
  explicit Lines(const std::string& file) : in_(file, std::ios::binary) {}
  bool next(std::string& line) {
    if (!std::getline(in_, line)) return false;
    ++number_;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    return true;
  }
  long long number() const { return number_; }
  bool ok() const { return static_cast<bool>(in_) || in_.eof(); }

 private:
  std::ifstream in_;
  long long number_ = 0;
};

std::string at_line(long long n) { return "line " + std::to_string(n) + ": "; }

// A token or line for an error message, quoted and cut short; bytes outside
// printable ASCII are written as \xNN, so that a binary or mis-encoded file
// still gives a valid (UTF-8) message.
std::string quote(const std::string& tok) {
  std::string s = "'";
  for (size_t i = 0; i < tok.size() && i < 60; ++i) {
    const unsigned char c = static_cast<unsigned char>(tok[i]);
    if (c >= 32 && c < 127) {
      s += static_cast<char>(c);
    } else {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", c);
      s += buf;
    }
  }
  return s + (tok.size() > 60 ? "...'" : "'");
}

// True when an OFF file is "OFF BINARY" (left to OpenMesh's binary reader).
bool off_is_binary(const std::string& file) {
  Lines in(file);
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
void read_ascii_off(const std::string& file, const std::string& path, MeshData& out) {
  const char* what = "load_mesh";
  Lines in(file);
  std::string line;
  std::vector<std::string> t;
  auto next_tokens = [&]() {
    while (in.next(line)) {
      t = tokens_of(line, true);
      if (!t.empty()) return true;
    }
    return false;
  };
  if (!next_tokens()) fail(what, path, "no OFF header (the file has no data)");
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
      fail(what, path, at_line(header_line) + "'" + kw + "' (4D or n-dimensional OFF) is not supported");
    if (k != "OFF") fail(what, path, at_line(header_line) + "expected an OFF header, found " + quote(kw));
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
    if (!next_tokens()) fail(what, path, "the file is truncated: no vertex/face counts after the OFF header");
    counts = t;
    counts_line = in.number();
  }
  long long nV = -1, nF = -1, nE = 0;
  if (counts.size() < 2 || counts.size() > 3 || !parse_int(counts[0], nV) || !parse_int(counts[1], nF) ||
      (counts.size() == 3 && !parse_int(counts[2], nE)) || nV < 0 || nF < 0 || nE < 0)
    fail(what, path,
         at_line(counts_line) + "expected the counts 'vertices faces [edges]' (non-negative integers), found " +
             quote(line));
  if (nV > std::numeric_limits<int>::max() || nF > std::numeric_limits<int>::max())
    fail(what, path, at_line(counts_line) + "the counts are too large for this reader");

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
      fail(what, path,
           "the file is truncated: the header announces " + std::to_string(nV) + " vertices, the file ends after " +
               std::to_string(v));
    const std::string L = at_line(in.number());
    if (t.size() < need)
      fail(what, path,
           L + "vertex " + std::to_string(v) + " has " + std::to_string(t.size()) + " numbers, expected " +
               std::to_string(need) + (nor ? " (x y z nx ny nz)" : " (x y z)"));
    if (t.size() > need + extra_max)
      fail(what, path,
           L + "vertex " + std::to_string(v) + " has " + std::to_string(t.size()) + " values, at most " +
               std::to_string(need + extra_max) + " expected for '" + kw +
               "' (a face line where a vertex was expected? the header announces " + std::to_string(nV) +
               " vertices)");
    for (size_t k = 0; k < t.size(); ++k) {
      double x = 0;
      if (!parse_double(t[k], x)) fail(what, path, L + "vertex " + std::to_string(v) + ": " + quote(t[k]) + " is not a number");
      if (k < need && !std::isfinite(x))
        fail(what, path,
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
      fail(what, path,
           "the file is truncated: the header announces " + std::to_string(nF) + " faces, the file ends after " +
               std::to_string(f));
    const std::string L = at_line(in.number());
    long long k = -1;
    if (!parse_int(t[0], k) || k < 0)
      fail(what, path, L + "face " + std::to_string(f) + ": expected the number of corners, found " + quote(t[0]));
    // A face may end with a colour: nothing, a colour-map index, RGB or RGBA.
    if (static_cast<long long>(t.size()) < 1 + k || static_cast<long long>(t.size()) > 1 + k + 4)
      fail(what, path,
           L + "face " + std::to_string(f) + " announces " + std::to_string(k) + " corners but the line has " +
               std::to_string(t.size() - 1) + " values after the count");
    idx.clear();
    for (long long c = 0; c < k; ++c) {
      long long i = -1;
      const std::string& tok = t[static_cast<size_t>(1 + c)];
      if (!parse_int(tok, i)) fail(what, path, L + "face " + std::to_string(f) + ": " + quote(tok) + " is not a vertex index");
      if (i < 0 || i >= nV)
        fail(what, path,
             L + "face " + std::to_string(f) + " refers to vertex " + tok + ", but the file has " +
                 std::to_string(nV) + " vertices");
      idx.push_back(static_cast<int>(i));
    }
    for (size_t c = static_cast<size_t>(1 + k); c < t.size(); ++c) {
      double x = 0;
      if (!parse_double(t[c], x))
        fail(what, path, L + "face " + std::to_string(f) + ": colour value " + quote(t[c]) + " is not a number");
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
    fail(what, path,
         at_line(in.number()) + "unexpected data after the last of the " + std::to_string(nF) +
             " faces the header announces: " + quote(line));
  if (!in.ok()) fail(what, path, "read error");

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

// ASCII PLY: every record of every element must have exactly the values its
// properties ask for, integers where the type is an integer, and finite x, y, z
// for vertices. Binary PLY is checked by check_binary_ply_size. Returns "" or
// the problem, naming the line.
std::string check_ascii_ply(const std::string& file) {
  struct Prop {
    std::string name;
    bool list = false, int_count = true, int_value = false;
  };
  struct Element {
    std::string name;
    long long count = 0;
    std::vector<Prop> props;
  };
  auto is_int = [](const std::string& ty) { return ply_type_size(ty) > 0 && ty.find("float") == std::string::npos && ty != "double"; };
  Lines in(file);
  std::string line;
  if (!in.next(line) || line != "ply") return "";  // the reader will complain
  std::vector<Element> elements;
  bool ascii = false, ended = false;
  while (in.next(line)) {
    const auto t = tokens_of(line, false);
    if (t.empty()) continue;
    const std::string L = at_line(in.number());
    if (t[0] == "format") {
      ascii = t.size() >= 2 && t[1] == "ascii";
    } else if (t[0] == "element") {
      Element e;
      if (t.size() != 3 || !parse_int(t[2], e.count) || e.count < 0)
        return L + "bad element line in the header: " + quote(line);
      e.name = t[1];
      elements.push_back(e);
    } else if (t[0] == "property") {
      if (elements.empty()) return L + "a property before any element in the header";
      Prop pr;
      if (t.size() == 5 && t[1] == "list") {
        pr.list = true;
        pr.int_count = is_int(t[2]);
        pr.int_value = is_int(t[3]);
        pr.name = t[4];
        if (!pr.int_count || ply_type_size(t[3]) == 0) return L + "bad list property in the header: " + quote(line);
      } else if (t.size() == 3 && ply_type_size(t[1]) > 0) {
        pr.int_value = is_int(t[1]);
        pr.name = t[2];
      } else {
        return L + "bad property line in the header: " + quote(line);
      }
      elements.back().props.push_back(pr);
    } else if (t[0] == "end_header") {
      ended = true;
      break;
    }
  }
  if (!ended || !ascii) return "";  // binary, or a header problem the other checks report
  std::vector<std::string> t;
  auto next_tokens = [&]() {
    while (in.next(line)) {
      t = tokens_of(line, false);
      if (!t.empty()) return true;
    }
    return false;
  };
  for (const Element& e : elements) {
    const bool vertex = e.name == "vertex";
    for (long long r = 0; r < e.count; ++r) {
      const std::string what = e.name + " " + std::to_string(r);
      if (!next_tokens())
        return "the file is truncated: the header announces " + std::to_string(e.count) + " " + e.name +
               " records, the file ends after " + std::to_string(r);
      const std::string L = at_line(in.number());
      size_t k = 0;
      for (const Prop& pr : e.props) {
        long long n = 1;
        if (pr.list) {
          if (k >= t.size()) return L + what + " has too few values (property '" + pr.name + "' is missing)";
          if (!parse_int(t[k], n) || n < 0)
            return L + what + ": list length " + quote(t[k]) + " of '" + pr.name + "' is not a non-negative integer";
          ++k;
        }
        for (long long c = 0; c < n; ++c, ++k) {
          if (k >= t.size()) return L + what + " has too few values (property '" + pr.name + "' is missing)";
          double x = 0;
          long long i = 0;
          if (pr.int_value ? !parse_int(t[k], i) : !parse_double(t[k], x))
            return L + what + ": " + quote(t[k]) + " is not " + (pr.int_value ? "an integer" : "a number") +
                   " (property '" + pr.name + "')";
          if (vertex && !pr.list && (pr.name == "x" || pr.name == "y" || pr.name == "z") && !pr.int_value &&
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

// ASCII STL: solid / facet normal a b c / outer loop / 3 x vertex x y z /
// endloop / endfacet ... endsolid, with numbers that parse completely and
// finite vertex coordinates. Returns "" or the problem, naming the line.
std::string check_ascii_stl(const std::string& file) {
  // A token stream over the lines (streamed: ASCII STL files can be large).
  Lines in(file);
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

// Wavefront OBJ, read here instead of by OpenMesh: its reader silently drops a
// face with a repeated corner ("f 1 1 1"), removes repeated corners from others
// ("f 1 2 2 3" becomes one triangle) and skips "v nan 0 0" lines, which shifts
// every later vertex index. Here every face is kept as stored, like the OFF and
// PLY paths do, so that check_mesh sees the file's own defects. Keywords other
// than v, vn and f (vt, g, o, s, usemtl, l, ...) are ignored. Vertex normals are
// those the face corners name ("f 1//3"); they are returned only when every
// vertex gets one. Throws MeshIOError naming the line.
void read_obj(const std::string& file, const std::string& path, MeshData& out) {
  const char* what = "load_mesh";
  Lines in(file);
  std::string line;
  std::vector<double> V, VN;
  std::vector<std::array<int, 3>> tris;
  std::vector<int> normal_of;  // per vertex: index into VN or -1
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
        fail(what, path,
             L + "'" + t[0] + "' has " + std::to_string(t.size() - 1) + " values, expected " +
                 (pos ? "3 (x y z, optionally w or r g b)" : "3"));
      for (size_t k = 1; k < t.size(); ++k) {
        double x = 0;
        if (!parse_double(t[k], x)) fail(what, path, L + quote(t[k]) + " is not a number");
        if (pos && k <= 3 && !std::isfinite(x))
          fail(what, path,
               L + "vertex " + std::to_string(V.size() / 3) + " has a non-finite coordinate " + quote(t[k]) +
                   " (NaN, Inf or out of double range)");
        if (k <= 3) (pos ? V : VN).push_back(x);
      }
      if (V.size() / 3 > static_cast<size_t>(std::numeric_limits<int>::max()))
        fail(what, path, L + "too many vertices for this reader");
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
          fail(what, path, L + "face corner " + quote(c) + " is not 'v', 'v/vt', 'v/vt/vn' or 'v//vn' with v a non-zero integer");
        if (v < 0) {
          if (-v > nv)
            fail(what, path,
                 L + "face corner " + quote(c) + " refers back further than the " + std::to_string(nv) +
                     " vertices defined before it");
          v = nv + v;
        } else {
          v -= 1;
          if (v >= worst.index) worst = {in.number(), v + 1};
        }
        if (v > std::numeric_limits<int>::max()) fail(what, path, L + "vertex index " + quote(c) + " is too large");
        if (vn < 0) vn = nn + vn + 1;
        if (!d.empty() && (vn < 1 || vn > nn))
          fail(what, path,
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
          if (normal_of.size() <= static_cast<size_t>(idx[k])) normal_of.resize(static_cast<size_t>(idx[k]) + 1, -1);
          normal_of[static_cast<size_t>(idx[k])] = static_cast<int>(nidx[k]);
        }
    }
  }
  if (!in.ok()) fail(what, path, "read error");
  const Index nV = static_cast<Index>(V.size() / 3);
  if (worst.index > nV)
    fail(what, path,
         at_line(worst.line) + "a face refers to vertex " + std::to_string(worst.index) + " (1-based), but the file has " +
             std::to_string(nV) + " vertices");
  out.V.resize(nV, 3);
  for (Index v = 0; v < nV; ++v)
    for (int c = 0; c < 3; ++c) out.V(v, c) = V[static_cast<size_t>(3 * v + c)];
  if (nV > 0 && static_cast<Index>(normal_of.size()) == nV &&
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

}  // namespace

std::vector<std::string> mesh_formats() { return kFormats; }

MeshData read_mesh(const std::string& path) {
  const char* what = "load_mesh";
  std::error_code ec;
  if (path.empty()) fail(what, path, "empty file name");
  const fs::path p(path);
  if (!fs::exists(p, ec)) fail(what, path, "no such file");
  if (fs::is_directory(p, ec)) fail(what, path, "is a directory, not a mesh file");
  const auto size = fs::file_size(p, ec);
  if (ec) fail(what, path, "cannot read its size (" + ec.message() + ")");
  if (size == 0) fail(what, path, "the file is empty");
  {
    std::ifstream probe(path, std::ios::binary);
    if (!probe) fail(what, path, "cannot open it for reading (permission denied?)");
  }

  MeshData out;
  std::string ext = lower(p.extension().string());
  std::string stem_path = path;
  if (ext == ".gz") {
    out.gzipped = true;
    ext = lower(p.stem().extension().string());
  }
  if (!ext.empty()) ext = ext.substr(1);
  if (std::find(kFormats.begin(), kFormats.end(), ext) == kFormats.end())
    fail(what, path,
         ext.empty() ? "no file extension; expected .obj, .off, .ply, .stl or .om (optionally .gz)"
                     : "unknown format '." + ext + "'; expected .obj, .off, .ply, .stl or .om (optionally .gz)");
  out.format = ext;

  std::unique_ptr<GunzipTemp> gz;
  std::string file = path;
  std::uintmax_t file_size = size;
  if (out.gzipped) {
    gz = std::make_unique<GunzipTemp>(path, ext);
    file = gz->path();
    file_size = gz->bytes();
    if (file_size == 0) fail(what, path, "the decompressed file is empty");
  }
  {
    std::string problem = ext == "ply"   ? check_binary_ply_size(file, file_size)
                                : ext == "stl" ? check_stl_complete(file, file_size)
                                               : std::string();
    if (problem.empty() && ext == "ply") problem = check_ascii_ply(file);
    if (!problem.empty()) fail(what, path, problem);
  }
  if (ext == "obj" || (ext == "off" && !off_is_binary(file))) {
    if (ext == "obj")
      read_obj(file, path, out);
    else
      read_ascii_off(file, path, out);
    if (out.V.rows() == 0) fail(what, path, "no vertices found (not a ." + ext + " file, or an empty mesh)");
    if (out.F.rows() == 0)
      fail(what, path,
           "no faces found (" + std::to_string(out.V.rows()) +
               " vertices): a point cloud or a truncated file, not a surface");
    return out;
  }

  std::lock_guard<std::mutex> lock(io_mutex());
  OMesh mesh;
  mesh.request_vertex_normals();
  RecordingImporter importer(mesh);
  OpenMesh::IO::Options opt = OpenMesh::IO::Options::VertexNormal;
  bool ok = false;
  std::string messages;
  {
    OmerrCapture capture;
    try {
      ok = OpenMesh::IO::IOManager().read(file, importer, opt);
    } catch (const std::bad_alloc&) {
      fail(what, path, "out of memory while reading (a corrupt header with huge counts?)");
    } catch (const std::exception& e) {
      fail(what, path, std::string("the reader failed: ") + e.what());
    }
    messages = capture.summary();
  }
  if (!ok)
    fail(what, path,
         "OpenMesh's " + ext + " reader could not read it (not a valid ." + ext + " file?)" +
             (messages.empty() ? std::string() : ": " + messages));

  // Vertices: the ones the reader added (OpenMesh appends copies for faces it
  // could not insert; those are not part of the file).
  const bool raw = importer.polygons > 0;
  const Index nV = raw ? importer.vertices_added : static_cast<Index>(mesh.n_vertices());
  out.V.resize(nV, 3);
  for (Index v = 0; v < nV; ++v) {
    const auto& q = mesh.point(OpenMesh::VertexHandle(static_cast<int>(v)));
    out.V.row(v) << q[0], q[1], q[2];
  }
  if (opt.vertex_has_normal() && mesh.has_vertex_normals()) {
    out.N.resize(nV, 3);
    for (Index v = 0; v < nV; ++v) {
      const auto& q = mesh.normal(OpenMesh::VertexHandle(static_cast<int>(v)));
      out.N.row(v) << q[0], q[1], q[2];
    }
  }
  if (raw) {
    out.polygons = importer.polygons;
    out.triangulated_polygons = importer.triangulated;
    out.skipped_faces = importer.skipped;
    out.F.resize(static_cast<Index>(importer.tris.size()), 3);
    for (size_t f = 0; f < importer.tris.size(); ++f)
      for (int c = 0; c < 3; ++c) out.F(static_cast<Index>(f), c) = importer.tris[f][c];
  } else {
    // The OM reader rebuilds OpenMesh's halfedge structure directly.
    std::vector<std::array<int, 3>> tris;
    for (auto fh : mesh.faces()) {
      std::vector<int> vs;
      for (auto vh : mesh.fv_range(fh)) vs.push_back(vh.idx());
      ++out.polygons;
      if (vs.size() > 3) ++out.triangulated_polygons;
      for (size_t k = 1; k + 1 < vs.size(); ++k) tris.push_back({vs[0], vs[k], vs[k + 1]});
    }
    out.F.resize(static_cast<Index>(tris.size()), 3);
    for (size_t f = 0; f < tris.size(); ++f)
      for (int c = 0; c < 3; ++c) out.F(static_cast<Index>(f), c) = tris[f][c];
  }

  if (importer.header_vertices > 0 && nV < importer.header_vertices)
    fail(what, path,
         "the file is truncated: the header announces " + std::to_string(importer.header_vertices) +
             " vertices, " + std::to_string(nV) + " were read");
  if (importer.header_faces > 0 && raw && out.polygons < importer.header_faces)
    fail(what, path,
         "the file is truncated: the header announces " + std::to_string(importer.header_faces) + " faces, " +
             std::to_string(out.polygons) + " were read");
  if (nV == 0) fail(what, path, "no vertices found (not a ." + ext + " file, or an empty mesh)");
  if (out.F.rows() == 0)
    fail(what, path,
         "no faces found (" + std::to_string(nV) + " vertices): a point cloud or a truncated file, not a surface");
  for (Index v = 0; v < nV; ++v)
    if (!out.V.row(v).allFinite())
      fail(what, path, "vertex " + std::to_string(v) + " has a non-finite coordinate");
  for (Index f = 0; f < out.F.rows(); ++f)
    for (int c = 0; c < 3; ++c)
      if (out.F(f, c) < 0 || out.F(f, c) >= nV)
        fail(what, path,
             "face " + std::to_string(f) + " refers to vertex " + std::to_string(out.F(f, c)) + ", but the file has " +
                 std::to_string(nV) + " vertices");
  if (out.N.rows() > 0 && !out.N.allFinite()) out.N.resize(0, 3);  // unusable normals are dropped, not fatal
  return out;
}

WriteReport write_mesh(const std::string& path, const Eigen::Ref<const RowMatrixX3d>& V,
                       const Eigen::Ref<const RowMatrixX3i>& F, const Eigen::Ref<const RowMatrixX3d>& N,
                       const WriteOptions& options) {
  const char* what = "save_mesh";
  validate_mesh(V, F, "save_mesh");
  VPFFD_CHECK(N.rows() == 0 || N.rows() == V.rows(), "save_mesh: ", N.rows(), " normals for ", V.rows(),
              " vertices");
  VPFFD_CHECK(N.rows() == 0 || N.allFinite(), "save_mesh: the normals contain NaN or Inf");
  VPFFD_CHECK(options.binary >= -1 && options.binary <= 1, "save_mesh: binary must be -1, 0 or 1");
  VPFFD_CHECK(options.precision >= 1 && options.precision <= 17, "save_mesh: precision must be in 1..17, got ",
              options.precision);
  const fs::path p(path);
  std::string ext = lower(p.extension().string());
  if (ext == ".gz") fail(what, path, "writing compressed files is not supported; drop the .gz");
  if (!ext.empty()) ext = ext.substr(1);
  if (std::find(kFormats.begin(), kFormats.end(), ext) == kFormats.end())
    fail(what, path,
         ext.empty() ? "no file extension; expected .obj, .off, .ply, .stl or .om"
                     : "unknown format '." + ext + "'; expected .obj, .off, .ply, .stl or .om");
  if (ext == "obj" && options.binary == 1) throw InvalidInputError("save_mesh: OBJ has no binary encoding");
  if (ext == "om" && options.binary == 0) throw InvalidInputError("save_mesh: OM is a binary format only");
  std::error_code ec;
  const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
  if (!fs::is_directory(dir, ec)) fail(what, path, "the folder '" + dir.string() + "' does not exist");
  if (fs::is_directory(p, ec)) fail(what, path, "is a directory");

  const bool binary = options.binary == 1 || (options.binary == -1 && (ext == "ply" || ext == "stl" || ext == "om"));
  std::lock_guard<std::mutex> lock(io_mutex());
  OMesh mesh;
  const bool normals = N.rows() > 0;
  if (normals) mesh.request_vertex_normals();
  WriteReport report;
  std::string messages;
  bool ok = false;
  {
    OmerrCapture capture;
    const Index nV = V.rows();
    for (Index v = 0; v < nV; ++v) {
      auto vh = mesh.add_vertex(OMesh::Point(V(v, 0), V(v, 1), V(v, 2)));
      if (normals) mesh.set_normal(vh, OMesh::Normal(N(v, 0), N(v, 1), N(v, 2)));
    }
    std::vector<OpenMesh::VertexHandle> vh(3);
    for (Index f = 0; f < F.rows(); ++f) {
      const int a = F(f, 0), b = F(f, 1), c = F(f, 2);
      if (a == b || b == c || a == c) {
        ++report.dropped_faces;
        continue;
      }
      vh = {OpenMesh::VertexHandle(a), OpenMesh::VertexHandle(b), OpenMesh::VertexHandle(c)};
      if (mesh.add_face(vh).is_valid()) continue;
      // A face the halfedge structure cannot take (non-manifold edge or vertex)
      // gets its own copies of its corners, as OpenMesh's importer does.
      ++report.split_faces;
      for (auto& h : vh) {
        const auto q = mesh.point(h);
        const auto nh = mesh.add_vertex(q);
        if (normals) mesh.set_normal(nh, OMesh::Normal(mesh.normal(h)));
        h = nh;
      }
      mesh.add_face(vh);
    }
    report.vertices_written = static_cast<Index>(mesh.n_vertices());
    OpenMesh::IO::Options opt;
    if (binary) opt += OpenMesh::IO::Options::Binary;
    if (binary && ext != "om") opt += OpenMesh::IO::Options::LSB;
    if (normals) opt += OpenMesh::IO::Options::VertexNormal;
    try {
      ok = OpenMesh::IO::write_mesh(mesh, path, opt, options.precision);
    } catch (const std::exception& e) {
      fail(what, path, std::string("the writer failed: ") + e.what());
    }
    messages = capture.summary();
  }
  if (!ok)
    fail(what, path,
         "OpenMesh's " + ext + " writer failed (folder not writable, disk full?)" +
             (messages.empty() ? std::string() : ": " + messages));
  return report;
}

}  // namespace vpffd
