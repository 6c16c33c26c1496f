// Mesh checks, volume and the built-in shapes.

#include "common.h"
#include "vpffd/mesh/shapes.h"
#include "vpffd/mesh/validate.h"
#include "vpffd/mesh/volume.h"

namespace vpffd::bindings {

void bind_mesh(py::module_& m) {
  m.def("validate_mesh", [](RefV V, RefF F) { validate_mesh(V, F, "Mesh"); }, py::arg("vertices"),
        py::arg("faces"));
  m.def(
      "edge_report",
      [](RefF F) {
        VPFFD_CHECK(F.rows() == 0 || F.minCoeff() >= 0, "edge_report: negative vertex index");
        const EdgeReport r = edge_report(F);
        py::dict d;
        d["edges"] = r.edges;
        d["boundary_edges"] = r.boundary_edges;
        d["nonmanifold_edges"] = r.nonmanifold_edges;
        d["misoriented_edges"] = r.misoriented_edges;
        return d;
      },
      py::arg("faces"));
  m.def(
      "signed_volume",
      [](RefV V, RefF F, Vector3d origin, bool check) {
        // Mesh validated its (read-only) arrays once; a serial check per call
        // would cost as much as the parallel sum.
        if (check) validate_mesh(V, F, "signed_volume");
        py::gil_scoped_release release;
        return signed_volume(V, F, origin);
      },
      py::arg("vertices"), py::arg("faces"), py::arg("origin") = Vector3d::Zero(), py::arg("check") = true);
  m.def(
      "cone_volumes",
      [](RefV V, RefF F, Vector3d origin, bool check) {
        if (check) validate_mesh(V, F, "cone_volumes");  // as signed_volume's check
        py::gil_scoped_release release;
        return cone_volumes(V, F, origin);
      },
      py::arg("vertices"), py::arg("faces"), py::arg("origin"), py::arg("check") = true);
  m.def("require_closed", [](RefF F, const char* where) {
    VPFFD_CHECK(F.rows() == 0 || F.minCoeff() >= 0, where, ": negative vertex index");
    require_closed(edge_report(F), where);
  });
  m.def(
      "icosphere",
      [](int s, double r) {
        TriMesh t = icosphere(s, r);
        return py::make_tuple(std::move(t.V), std::move(t.F));
      },
      py::arg("subdivisions"), py::arg("radius") = 1.0);
  m.def(
      "box_mesh",
      [](int n, double size) {
        TriMesh t = box_mesh(n, size);
        return py::make_tuple(std::move(t.V), std::move(t.F));
      },
      py::arg("n"), py::arg("size") = 1.0);
}

}  // namespace vpffd::bindings
