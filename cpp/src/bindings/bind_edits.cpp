// Ready-made control point edits (radians here; the Python layer takes degrees).

#include "common.h"
#include "vpffd/edits/lattice_edits.h"

namespace vpffd::bindings {

void bind_edits(py::module_& m) {
  m.def("twist", &twist, py::arg("points"), py::arg("angle"), py::arg("axis"), py::arg("center"), py::arg("lo") = 0.0,
        py::arg("hi") = 0.0);
  m.def("bend", &bend, py::arg("points"), py::arg("angle"), py::arg("axis"), py::arg("toward"), py::arg("center"),
        py::arg("lo") = 0.0, py::arg("hi") = 0.0);
  m.def("taper", &taper, py::arg("points"), py::arg("factor"), py::arg("axis"), py::arg("center"),
        py::arg("lo") = 0.0, py::arg("hi") = 0.0);
  m.def("scale", &scale, py::arg("points"), py::arg("factors"), py::arg("center"));
}

}  // namespace vpffd::bindings
