// The extension module vpffd._core. The Python package (python/vpffd) wraps it
// with numpy-friendly classes; this layer stays thin.

#include "common.h"
#include "vpffd/core/parallel.h"

PYBIND11_MODULE(_core, m) {
  m.doc() = "vpffd C++ core: volume-preserving B-spline free-form deformation";
  m.attr("__version__") = VPFFD_VERSION;

  py::register_exception<vpffd::InvalidInputError>(m, "InvalidInputError", PyExc_ValueError);
  py::register_exception<vpffd::SolverError>(m, "SolverError", PyExc_RuntimeError);
  py::register_exception<vpffd::MeshIOError>(m, "MeshIOError", PyExc_OSError);
  py::register_exception<vpffd::BackendUnavailableError>(m, "BackendUnavailableError", PyExc_RuntimeError);
  py::register_exception<vpffd::DeviceError>(m, "DeviceError", PyExc_RuntimeError);

  m.def("has_openmp", &vpffd::has_openmp, "True when the CPU kernels were compiled with OpenMP.");
  m.def("max_threads", [] { return vpffd::resolve_threads(0); }, "Threads the OpenMP backend uses by default.");

  vpffd::bindings::bind_options(m);  // first: deform() takes its type as a default
  vpffd::bindings::bind_lattice(m);
  vpffd::bindings::bind_mesh(m);
  vpffd::bindings::bind_deformer(m);
  vpffd::bindings::bind_edits(m);
  vpffd::bindings::bind_check(m);
  vpffd::bindings::bind_normals(m);
  vpffd::bindings::bind_folds(m);
  vpffd::bindings::bind_multires(m);

  // Optional parts: each flag tells Python whether the part was built.
#ifdef VPFFD_HAS_VULKAN
  vpffd::bindings::bind_vulkan(m);
  m.attr("has_vulkan") = true;
#else
  m.attr("has_vulkan") = false;
#endif
#ifdef VPFFD_HAS_MESH_IO
  vpffd::bindings::bind_io(m);
  m.attr("has_mesh_io") = true;
#else
  m.attr("has_mesh_io") = false;
#endif
  // has_openmesh: .om files can be written; every other format is read and
  // written, and .om read, without OpenMesh.
#ifdef VPFFD_HAS_OPENMESH
  m.attr("has_openmesh") = true;
#else
  m.attr("has_openmesh") = false;
#endif
#ifdef VPFFD_HAS_EMBREE
  vpffd::bindings::bind_embree(m);
  m.attr("has_embree") = true;
#else
  m.attr("has_embree") = false;
#endif
#ifdef VPFFD_HAS_OPENSUBDIV
  vpffd::bindings::bind_subdiv(m);
  m.attr("has_opensubdiv") = true;
#else
  m.attr("has_opensubdiv") = false;
#endif
}
