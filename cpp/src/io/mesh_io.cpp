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
#include <cmath>
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
      if (n < 0) return "the header has an element with a bad count: '" + line + "'";
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
    return "";
  }
  if (size < 84) return "the file is truncated: a binary STL needs an 84-byte header";
  if (size < want)
    return "truncated or not an STL file: the binary header announces " + std::to_string(n) + " triangles (" + std::to_string(want) +
           " bytes), the file has " + std::to_string(size) + " bytes";
  return "";
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
    const std::string problem = ext == "ply"   ? check_binary_ply_size(file, file_size)
                                : ext == "stl" ? check_stl_complete(file, file_size)
                                               : std::string();
    if (!problem.empty()) fail(what, path, problem);
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
