// All vpffd asks of OpenMesh: formatting OM files for writing (into memory:
// atomic_write.cpp puts the bytes on the disk). OM stores OpenMesh's halfedge
// connectivity, so the mesh goes through OpenMesh's own structure, which splits
// non-manifold faces off and cannot hold a face with a repeated corner (both
// counted in the WriteReport). OpenMesh reports failures as a bool plus text on
// its omerr() stream; both become MeshIOError here, with the file name.

#include <OpenMesh/Core/IO/IOManager.hh>
#include <OpenMesh/Core/IO/MeshIO.hh>
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

// Double-precision points and normals: OM files keep float64 exactly.
struct DoubleTraits : OpenMesh::DefaultTraits {
  typedef OpenMesh::Vec3d Point;
  typedef OpenMesh::Vec3d Normal;
};
using OMesh = OpenMesh::PolyMesh_ArrayKernelT<DoubleTraits>;

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

}  // namespace

WriteReport write_om(const std::string& path, const std::string& shown, const ConstV& V, const ConstF& F,
                     const ConstV& N) {
  const char* what = "save_mesh";
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
    OpenMesh::IO::Options opt = OpenMesh::IO::Options::Binary;
    if (normals) opt += OpenMesh::IO::Options::VertexNormal;
    // Into memory: OpenMesh does not check its writes. replace_file writes the bytes,
    // checking each write, and puts them in place only when all are on the disk.
    try {
      ok = OpenMesh::IO::write_mesh(mesh, bytes, ".om", opt);
    } catch (const std::exception& e) {
      fail(what, shown, "the writer failed: " + printable(e.what()));
    }
    messages = printable(capture.summary());
  }
  if (!ok || !bytes)
    fail(what, shown, "OpenMesh's OM writer failed" + (messages.empty() ? std::string() : ": " + messages));
  replace_file(path, shown, bytes.str(), what);
  return report;
}

}  // namespace vpffd::io_detail
