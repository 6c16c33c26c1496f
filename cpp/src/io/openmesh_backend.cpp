// Everything vpffd asks of OpenMesh: reading STL (after check_stl went through
// the whole file), and formatting every format for writing (into memory:
// atomic_write.cpp puts the bytes on the disk). OpenMesh
// reports failures as a bool plus text on its omerr() stream; both become
// MeshIOError here, with the file name.

#include <OpenMesh/Core/IO/IOManager.hh>
#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/IO/importer/ImporterT.hh>
#include <OpenMesh/Core/Mesh/PolyMesh_ArrayKernelT.hh>
#include <OpenMesh/Core/System/omstream.hh>
#include <algorithm>
#include <array>
#include <cctype>
#include <iostream>
#include <mutex>
#include <sstream>

#include "atomic_write.h"
#include "io_util.h"
#include "readers.h"

namespace vpffd::io_detail {
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
    // The reader's indices come from the file: one out of range would make
    // OpenMesh's add_face write outside its arrays. Such a face is recorded
    // (read_with_openmesh reports it) but never given to OpenMesh.
    for (const auto& h : idx)
      if (h.idx() < 0 || h.idx() >= vertices_added) {
        if (bad_face < 0) bad_face = polygons - 1, bad_index = h.idx();
        return OpenMesh::FaceHandle();
      }
    if (idx.size() < 3) {
      ++skipped;
      return OpenMesh::FaceHandle();
    }
    if (idx.size() > 3) ++triangulated;
    for (size_t k = 1; k + 1 < idx.size(); ++k)
      tris.insert(tris.end(), {idx[0].idx(), idx[k].idx(), idx[k + 1].idx()});
    return Base::add_face(idx);
  }
  void reserve(unsigned int nV, unsigned int, unsigned int nF) override {
    header_vertices = nV;
    header_faces = nF;
  }

  std::vector<int> tris;
  Index vertices_added = 0, polygons = 0, triangulated = 0, skipped = 0;
  Index bad_face = -1, bad_index = -1;
  Index header_vertices = -1, header_faces = -1;
};

}  // namespace

void read_with_openmesh(const std::string& file, const std::string& shown, const std::string& ext, MeshData& out) {
  const char* what = "load_mesh";
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
      fail(what, shown, "out of memory while reading");
    } catch (const std::exception& e) {
      fail(what, shown, "the reader failed: " + printable(e.what()));
    }
    messages = printable(capture.summary());
  }
  if (!ok)
    fail(what, shown,
         "OpenMesh's " + ext + " reader could not read it (not a valid ." + ext + " file?)" +
             (messages.empty() ? std::string() : ": " + messages));
  if (importer.bad_face >= 0)
    fail(what, shown,
         "face " + std::to_string(importer.bad_face) + " refers to vertex " + std::to_string(importer.bad_index) +
             ", but the file has " + std::to_string(importer.vertices_added) + " vertices");

  // Vertices: the ones the reader added (OpenMesh's importer appends copies for
  // faces its halfedge structure could not take; those are not in the file).
  const Index nV = importer.vertices_added;
  if (importer.header_vertices > 0 && nV < importer.header_vertices)
    fail(what, shown,
         "the file is truncated: the header announces " + std::to_string(importer.header_vertices) +
             " vertices, " + std::to_string(nV) + " were read");
  if (importer.header_faces > 0 && importer.polygons < importer.header_faces)
    fail(what, shown,
         "the file is truncated: the header announces " + std::to_string(importer.header_faces) + " faces, " +
             std::to_string(importer.polygons) + " were read");
  std::vector<double> V(static_cast<size_t>(3 * nV));
  for (Index v = 0; v < nV; ++v) {
    const auto& q = mesh.point(OpenMesh::VertexHandle(static_cast<int>(v)));
    for (int c = 0; c < 3; ++c) V[static_cast<size_t>(3 * v + c)] = q[c];
  }
  out.polygons = importer.polygons;
  out.triangulated_polygons = importer.triangulated;
  out.skipped_faces = importer.skipped;
  finish_mesh(shown, V, importer.tris, out);
  if (opt.vertex_has_normal() && mesh.has_vertex_normals()) {
    out.N.resize(nV, 3);
    for (Index v = 0; v < nV; ++v) {
      const auto& q = mesh.normal(OpenMesh::VertexHandle(static_cast<int>(v)));
      out.N.row(v) << q[0], q[1], q[2];
    }
    if (!out.N.allFinite()) out.N.resize(0, 3);  // unusable normals are dropped, not fatal
  }
}

WriteReport write_with_openmesh(const std::string& path, const std::string& shown, const std::string& ext,
                                const Eigen::Ref<const RowMatrixX3d>& V, const Eigen::Ref<const RowMatrixX3i>& F,
                                const Eigen::Ref<const RowMatrixX3d>& N, const WriteOptions& options) {
  const char* what = "save_mesh";
  const bool binary = options.binary == 1 || (options.binary == -1 && (ext == "ply" || ext == "stl" || ext == "om"));
  std::lock_guard<std::mutex> lock(io_mutex());
  OMesh mesh;
  const bool normals = N.rows() > 0;
  if (normals) mesh.request_vertex_normals();
  WriteReport report;
  std::string messages;
  std::ostringstream bytes;
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
    // Into memory: OpenMesh does not check its writes. replace_file writes the bytes,
    // checking each write, and puts them in place only when all are on the disk.
    try {
      ok = OpenMesh::IO::write_mesh(mesh, bytes, "." + ext, opt, options.precision);
    } catch (const std::exception& e) {
      fail(what, shown, "the writer failed: " + printable(e.what()));
    }
    messages = printable(capture.summary());
  }
  if (!ok || !bytes)
    fail(what, shown,
         "OpenMesh's " + ext + " writer failed" + (messages.empty() ? std::string() : ": " + messages));
  replace_file(path, shown, bytes.str(), what);
  return report;
}

}  // namespace vpffd::io_detail
