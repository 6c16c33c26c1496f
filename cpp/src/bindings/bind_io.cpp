// Mesh files (vpffd::io; OpenMesh for writing .om only). The Python layer (vpffd/io.py) builds Mesh
// objects from these arrays.

#include "common.h"
#include "vpffd/io/mesh_io.h"

namespace vpffd::bindings {

void bind_io(py::module_& m) {
  m.def(
      "read_mesh",
      [](const std::string& path) {
        MeshData d;
        {
          py::gil_scoped_release release;
          d = read_mesh(path);
        }
        py::dict out;
        out["vertices"] = std::move(d.V);
        out["faces"] = std::move(d.F);
        out["normals"] = d.N.rows() > 0 ? py::cast(std::move(d.N)) : py::none();
        out["polygons"] = d.polygons;
        out["triangulated_polygons"] = d.triangulated_polygons;
        out["skipped_faces"] = d.skipped_faces;
        out["format"] = d.format;
        out["gzipped"] = d.gzipped;
        out["notes"] = d.notes;
        return out;
      },
      py::arg("path"),
      "Reads a mesh file: dict with vertices (V, 3) float64, faces (F, 3) int32, normals (V, 3) or None, "
      "polygons, triangulated_polygons, skipped_faces, format, gzipped. Raises MeshIOError.");
  m.def(
      "write_mesh",
      [](const std::string& path, RefV V, RefF F, std::optional<RowMatrixX3d> N, int binary, int precision) {
        WriteOptions opt;
        opt.binary = binary;
        opt.precision = precision;
        const RowMatrixX3d none(0, 3);
        WriteReport r;
        {
          py::gil_scoped_release release;
          r = write_mesh(path, V, F, N ? *N : none, opt);
        }
        py::dict out;
        out["split_faces"] = r.split_faces;
        out["dropped_faces"] = r.dropped_faces;
        out["vertices_written"] = r.vertices_written;
        return out;
      },
      py::arg("path"), py::arg("vertices"), py::arg("faces"), py::arg("normals") = py::none(),
      py::arg("binary") = -1, py::arg("precision") = 17,
      "Writes a mesh file; binary -1 = the format's default. Returns split_faces and dropped_faces (non-zero "
      "only for .om, whose halfedge structure cannot hold every mesh as given) and vertices_written. Raises "
      "MeshIOError; BackendUnavailableError for .om in a build without OpenMesh.");
  m.def("mesh_formats", &mesh_formats, "File extensions read_mesh/write_mesh accept.");
}

}  // namespace vpffd::bindings
