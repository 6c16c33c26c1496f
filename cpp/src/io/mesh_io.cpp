// read_mesh and write_mesh: the dispatch by extension.
//
// Who reads and writes what:
//   OBJ   read by vpffd (read_obj.cpp): OpenMesh's reader drops faces with a
//         repeated corner and skips "v nan 0 0" lines, shifting later indices.
//   OFF   read by vpffd, ASCII and binary (read_off.cpp): OpenMesh's reader
//         turns unparsable numbers into 0 and trusts binary counts.
//   OM    read by vpffd (read_om.cpp; why, at its top): OpenMesh's reader
//         asserts, double-frees and returns corrupt halfedge connectivity.
//   PLY   read by vpffd (read_ply.cpp): every scalar, count and index type the
//         format names, ASCII and both byte orders; OpenMesh's reader took only a
//         few count types and integer coordinates not at all.
//   STL   read by vpffd, ASCII and binary (read_stl.cpp), the whole file checked;
//         equal positions merged into one vertex, as STL has no shared vertices.
//   .gz   decompressed by vpffd (gzip.cpp) to a temporary file with a size
//         bound, then read as above.
//   Writing: OBJ, OFF, PLY and STL formatted by vpffd into memory (write_*.cpp),
//         every face as given (no halfedge structure, so non-manifold meshes and
//         repeated corners are written unchanged); OM by OpenMesh
//         (openmesh_backend.cpp), the only part of vpffd::io that needs it. Then
//         to the disk by replace_file (atomic_write.cpp): checked writes to a
//         temporary file, fsync, rename over the target; a failure leaves the old
//         file.
// Nothing a reader returns is trusted: finish_mesh checks every face index
// against the vertex count and every coordinate for finiteness, and std::bad_alloc
// becomes a MeshIOError naming the file.

#include "vpffd/io/mesh_io.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <new>

#include "atomic_write.h"
#include "gzip.h"
#include "io_util.h"
#include "readers.h"
#include "vpffd/core/check.h"
#include "vpffd/core/exceptions.h"
#include "vpffd/mesh/validate.h"

namespace fs = std::filesystem;

namespace vpffd {
namespace io_detail {

void finish_mesh(const std::string& shown, const std::vector<double>& V, const std::vector<int>& tris,
                 MeshData& out) {
  const char* what = "load_mesh";
  const auto nV = static_cast<Index>(V.size() / 3);
  const auto nF = static_cast<Index>(tris.size() / 3);
  for (Index f = 0; f < nF; ++f)
    for (int c = 0; c < 3; ++c) {
      const int i = tris[static_cast<size_t>(3 * f + c)];
      if (i < 0 || i >= nV)
        fail(what, shown,
             "face " + std::to_string(f) + " refers to vertex " + std::to_string(i) + ", but the file has " +
                 std::to_string(nV) + " vertices");
    }
  for (Index v = 0; v < nV; ++v)
    for (int c = 0; c < 3; ++c)
      if (!std::isfinite(V[static_cast<size_t>(3 * v + c)]))
        fail(what, shown, "vertex " + std::to_string(v) + " has a non-finite coordinate");
  out.V = Eigen::Map<const RowMatrixX3d>(V.data(), nV, 3);
  out.F = Eigen::Map<const RowMatrixX3i>(tris.data(), nF, 3);
}

}  // namespace io_detail

namespace {

using io_detail::fail;

const std::vector<std::string> kFormats = {"obj", "off", "ply", "stl", "om"};

// The lower-case extension of the last path component ("" if none).
std::string extension_of(const fs::path& p) {
  std::string ext = io_detail::lower(p.extension().string());
  return ext.empty() ? ext : ext.substr(1);
}

void read_any(const std::string& path, const std::string& shown, MeshData& out) {
  const char* what = "load_mesh";
  std::error_code ec;
  if (path.empty()) fail(what, shown, "empty file name");
  if (path.find('\0') != std::string::npos) fail(what, shown, "the file name contains a NUL byte");
  const fs::path p(path);
  if (!fs::exists(p, ec)) fail(what, shown, "no such file");
  if (fs::is_directory(p, ec)) fail(what, shown, "is a directory, not a mesh file");
  const auto size = fs::file_size(p, ec);
  if (ec) fail(what, shown, "cannot read its size (" + ec.message() + ")");
  if (size == 0) fail(what, shown, "the file is empty");
  {
    std::ifstream probe(path, std::ios::binary);
    if (!probe) fail(what, shown, "cannot open it for reading (permission denied?)");
  }

  std::string ext = extension_of(p);
  if (ext == "gz") {
    out.gzipped = true;
    ext = extension_of(p.stem());
  }
  if (std::find(kFormats.begin(), kFormats.end(), ext) == kFormats.end())
    fail(what, shown,
         ext.empty() ? "no file extension; expected .obj, .off, .ply, .stl or .om (optionally .gz)"
                     : "unknown format " + io_detail::quote("." + ext) +
                           "; expected .obj, .off, .ply, .stl or .om (optionally .gz)");
  out.format = ext;

  std::unique_ptr<io_detail::GunzipTemp> gz;
  std::string file = path;
  std::uint64_t file_size = size;
  if (out.gzipped) {
    gz = std::make_unique<io_detail::GunzipTemp>(path, shown, ext);
    file = gz->path();
    file_size = gz->bytes();
    if (file_size == 0) fail(what, shown, "the decompressed file is empty");
  }
  if (ext == "obj") {
    io_detail::read_obj(file, shown, out);
  } else if (ext == "off") {
    io_detail::read_off(file, shown, file_size, out);
  } else if (ext == "om") {
    io_detail::read_om(file, shown, file_size, out);
  } else if (ext == "ply") {
    io_detail::read_ply(file, shown, file_size, out);
  } else {
    io_detail::read_stl(file, shown, file_size, out);
  }
  if (out.V.rows() == 0) fail(what, shown, "no vertices found (not a ." + ext + " file, or an empty mesh)");
  if (out.F.rows() == 0)
    fail(what, shown,
         "no faces found (" + std::to_string(out.V.rows()) +
             " vertices): a point cloud or a truncated file, not a surface");
}

}  // namespace

std::vector<std::string> mesh_formats() { return kFormats; }

MeshData read_mesh(const std::string& path) {
  const std::string shown = io_detail::display_name(path);
  MeshData out;
  try {
    read_any(path, shown, out);
  } catch (const std::bad_alloc&) {
    fail("load_mesh", shown, "out of memory while reading (the file is too large for the memory available)");
  } catch (const std::length_error&) {
    fail("load_mesh", shown, "out of memory while reading (the file is too large for the memory available)");
  }
  return out;
}

WriteReport write_mesh(const std::string& path, const Eigen::Ref<const RowMatrixX3d>& V,
                       const Eigen::Ref<const RowMatrixX3i>& F, const Eigen::Ref<const RowMatrixX3d>& N,
                       const WriteOptions& options) {
  const char* what = "save_mesh";
  const std::string shown = io_detail::display_name(path);
  validate_mesh(V, F, "save_mesh");
  VPFFD_CHECK(N.rows() == 0 || N.rows() == V.rows(), "save_mesh: ", N.rows(), " normals for ", V.rows(),
              " vertices");
  VPFFD_CHECK(N.rows() == 0 || N.allFinite(), "save_mesh: the normals contain NaN or Inf");
  VPFFD_CHECK(options.binary >= -1 && options.binary <= 1, "save_mesh: binary must be -1, 0 or 1");
  VPFFD_CHECK(options.precision >= 1 && options.precision <= 17, "save_mesh: precision must be in 1..17, got ",
              options.precision);
  if (path.empty()) fail(what, shown, "empty file name");
  if (path.find('\0') != std::string::npos) fail(what, shown, "the file name contains a NUL byte");
  const fs::path p(path);
  const std::string ext = extension_of(p);
  if (ext == "gz") fail(what, shown, "writing compressed files is not supported; drop the .gz");
  if (std::find(kFormats.begin(), kFormats.end(), ext) == kFormats.end())
    fail(what, shown,
         ext.empty() ? "no file extension; expected .obj, .off, .ply, .stl or .om"
                     : "unknown format " + io_detail::quote("." + ext) + "; expected .obj, .off, .ply, .stl or .om");
  if (ext == "obj" && options.binary == 1) throw InvalidInputError("save_mesh: OBJ has no binary encoding");
  const bool binary = options.binary == 1 || (options.binary == -1 && (ext == "ply" || ext == "stl" || ext == "om"));
  if (binary && (ext == "off" || ext == "stl")) {
    // Binary OFF and binary STL store float32: a coordinate past its range would
    // be written as infinity, a file no reader takes back.
    for (Index v = 0; v < V.rows(); ++v)
      for (int c = 0; c < 3; ++c)
        if (std::isinf(static_cast<float>(V(v, c))))
          throw InvalidInputError(detail::concat("save_mesh: vertex ", v, " (", V(v, 0), ", ", V(v, 1), ", ",
                                                 V(v, 2), ") is beyond the float32 range (3.4e38) that binary ." +
                                                     ext + " files store; save as ASCII, .ply or .om (float64), "
                                                           "or scale the mesh"));
    for (Index v = 0; ext == "off" && v < N.rows(); ++v)
      for (int c = 0; c < 3; ++c)
        if (std::isinf(static_cast<float>(N(v, c))))
          throw InvalidInputError(detail::concat("save_mesh: normal ", v, " is beyond the float32 range (3.4e38) "
                                                 "that binary .off files store"));
  }
  if (ext == "om" && options.binary == 0) throw InvalidInputError("save_mesh: OM is a binary format only");
  std::error_code ec;
  const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
  if (!fs::is_directory(dir, ec))
    fail(what, shown, "the folder '" + io_detail::display_name(dir.string()) + "' does not exist");
  if (fs::is_directory(p, ec)) fail(what, shown, "is a directory");
  // Where the file cannot be replaced safely (a FIFO, a device), fail before any work
  // (replace_file checks again when it writes).
  const fs::file_status status = fs::status(p, ec);
  if (!ec && fs::exists(status) && !fs::is_regular_file(status))
    fail(what, shown, "is not a regular file (a FIFO, a device or a socket), which cannot be replaced safely; "
                      "write to a regular file");
  try {
    if (ext == "om") return io_detail::write_om(path, shown, V, F, N);
    std::string bytes;
    WriteReport report;
    report.vertices_written = V.rows();
    if (ext == "obj") {
      bytes = io_detail::format_obj(V, F, N, options.precision);
    } else if (ext == "off") {
      bytes = io_detail::format_off(V, F, N, binary, options.precision);
    } else if (ext == "ply") {
      bytes = io_detail::format_ply(V, F, N, binary, options.precision);
    } else {
      bytes = io_detail::format_stl(V, F, binary, options.precision);
      report.vertices_written = 3 * F.rows();
    }
    io_detail::replace_file(path, shown, bytes, what);
    return report;
  } catch (const std::bad_alloc&) {
    fail(what, shown, "out of memory while writing");
  } catch (const std::length_error&) {
    fail(what, shown, "out of memory while writing");
  }
}

}  // namespace vpffd
