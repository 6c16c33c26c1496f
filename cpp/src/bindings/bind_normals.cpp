// Normals of rest and deformed surfaces (header-only core; works without Embree).

#include "common.h"
#include "vpffd/ffd/normals.h"

namespace vpffd::bindings {

void bind_normals(py::module_& m) {
  m.def(
      "vertex_normals",
      [](RefV V, RefF F, int threads) {
        py::gil_scoped_release release;
        return vertex_normals(V, F, threads);
      },
      py::arg("vertices"), py::arg("faces"), py::arg("threads") = 0,
      "(V, 3) unit area-weighted vertex normals.");
  m.def(
      "deformed_normals_exact",
      [](Eigen::Ref<const RowMatrixXd> J, RefV N0, int threads) {
        py::gil_scoped_release release;
        return deformed_normals_exact(J, N0, threads);
      },
      py::arg("jacobians"), py::arg("rest_normals"), py::arg("threads") = 0,
      "(V, 3) unit normals cof(J) n0 / |cof(J) n0| from (V, 9) row-major Jacobians.");
  m.def(
      "deformed_normals_tangent",
      [](const Lattice& L, RefV P, RefV X, RefV N0, double eps, int threads) {
        py::gil_scoped_release release;
        return deformed_normals_tangent(L, P, X, N0, eps, threads);
      },
      py::arg("lattice"), py::arg("control_points"), py::arg("points"), py::arg("rest_normals"), py::arg("eps"),
      py::arg("threads") = 0, "(V, 3) unit normals by mapped tangents (finite differences, step eps).");
}

}  // namespace vpffd::bindings
