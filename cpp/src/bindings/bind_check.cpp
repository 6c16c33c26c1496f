// Mesh defect report and orientation repair (header-only core; no OpenMesh).

#include "common.h"
#include "vpffd/mesh/check.h"

namespace vpffd::bindings {

void bind_check(py::module_& m) {
  m.def(
      "check_mesh",
      [](RefV V, RefF F) {
        MeshCheckReport r;
        {
          py::gil_scoped_release release;
          r = check_mesh(V, F);
        }
        py::dict d;
        d["vertices"] = r.vertices;
        d["faces"] = r.faces;
        d["edges"] = r.edges;
        d["boundary_edges"] = r.boundary_edges;
        d["boundary_loops"] = r.boundary_loops;
        d["nonmanifold_edges"] = r.nonmanifold_edges;
        d["nonmanifold_vertices"] = r.nonmanifold_vertices;
        d["misoriented_edges"] = r.misoriented_edges;
        d["degenerate_faces"] = r.degenerate_faces;
        d["duplicate_vertices"] = r.duplicate_vertices;
        d["duplicate_faces"] = r.duplicate_faces;
        d["unreferenced_vertices"] = r.unreferenced_vertices;
        d["components"] = r.components;
        d["euler_characteristic"] = r.euler_characteristic;
        d["signed_volume"] = r.signed_volume;
        return d;
      },
      py::arg("vertices"), py::arg("faces"), "Defect counts of a triangle mesh (see vpffd/mesh/check.h).");
  m.def(
      "orient_faces",
      [](RefV V, RefF F) {
        OrientResult r;
        {
          py::gil_scoped_release release;
          r = orient_faces(V, F);
        }
        return py::make_tuple(std::move(r.F), r.flipped_faces, r.conflicts, r.inward_components);
      },
      py::arg("vertices"), py::arg("faces"),
      "(faces, flipped_faces, conflicts, inward_components): consistent winding, closed components outward.");
}

}  // namespace vpffd::bindings
