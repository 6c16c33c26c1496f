#pragma once
// Shared pieces of the binding files: dtype conventions and conversions.
// Inputs arrive as Eigen::Ref of row-major float64 / int32 matrices: the Python
// layer has already converted and validated them, so no hidden copy happens here.

#include <optional>
#include <tuple>
#include <vector>

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "vpffd/correction/options.h"
#include "vpffd/mesh/parts.h"
#include "vpffd/sparse/csr.h"

namespace py = pybind11;

namespace vpffd::bindings {

using RefV = Eigen::Ref<const RowMatrixX3d>;
using RefF = Eigen::Ref<const RowMatrixX3i>;

/// Moves a CSR matrix into a (data, indices, indptr, shape) tuple of numpy arrays.
inline py::tuple csr_to_python(CsrMatrix&& A) {
  auto move_vec = [](auto&& v) {
    using T = typename std::decay_t<decltype(v)>::value_type;
    auto* heap = new std::vector<T>(std::move(v));
    py::capsule owner(heap, [](void* p) { delete static_cast<std::vector<T>*>(p); });
    return py::array_t<T>(static_cast<py::ssize_t>(heap->size()), heap->data(), owner);
  };
  return py::make_tuple(move_vec(std::move(A.values)), move_vec(std::move(A.indices)),
                        move_vec(std::move(A.indptr)), py::make_tuple(A.rows, A.cols));
}

/// The caller's output array `out` (None, or a (rows, 3) float64 C-contiguous writable
/// array: the Python layer checks it first and words the errors; this is the last
/// line) as a pointer to fill, or null.
inline double* out_rows(const py::object& out, Index rows, const char* where) {
  if (out.is_none()) return nullptr;
  if (!py::isinstance<py::array>(out)) throw InvalidInputError(std::string(where) + ": out must be a numpy array");
  const py::array a = py::reinterpret_borrow<py::array>(out);
  const bool ok = a.dtype().is(py::dtype::of<double>()) && a.ndim() == 2 && a.shape(0) == rows && a.shape(1) == 3 &&
                  (a.flags() & py::array::c_style) && a.writeable();
  if (!ok)
    throw InvalidInputError(std::string(where) + ": out must be a writable C-contiguous float64 array of shape (" +
                            std::to_string(rows) + ", 3)");
  return static_cast<double*>(const_cast<void*>(a.data()));
}

/// A DeformResult as the dict that Deformer.deform returns (all backends).
inline py::dict result_to_python(DeformResult&& r) {
  py::dict d;
  d["vertices"] = py::cast(std::move(r.vertices));
  d["control_points"] = py::cast(std::move(r.control_points));
  d["offsets"] = py::cast(std::move(r.offsets));
  d["volume_before"] = r.volume_before;
  d["volume"] = r.volume;
  d["target_volume"] = r.target_volume;
  d["constraint_error"] = r.constraint_error;
  if (r.part_volumes.size() > 0) {
    d["part_volumes_before"] = py::cast(std::move(r.part_volumes_before));
    d["part_volumes"] = py::cast(std::move(r.part_volumes));
    if (r.part_targets.size() > 0) d["part_targets"] = py::cast(std::move(r.part_targets));
  }
  py::list steps;
  for (const AxisStep& s : r.steps) {
    py::dict e;
    e["axis"] = std::string(1, char('x' + s.axis));
    e["volume_before"] = s.volume_before;
    e["share"] = s.share;
    e["sum_squares"] = s.sum_squares;
    e["max_offset"] = s.max_offset;
    steps.append(e);
  }
  d["steps"] = steps;
  if (r.timings.recorded) {
    const FrameTimings& t = r.timings;
    py::dict tm;
    tm["plan_ms"] = t.plan;
    tm["ffd_ms"] = t.ffd;
    tm["coefficients_ms"] = t.coefficients;
    tm["solves_ms"] = t.solves;
    tm["gathers_ms"] = t.gathers;
    tm["volume_ms"] = t.volume;
    tm["reorder_ms"] = t.reorder;
    tm["total_ms"] = t.total;
    d["timings"] = tm;
  }
  return d;
}

/// Point constraints as Python passes them: (vertex or -1, rest-space point, target).
using PyConstraints = std::vector<std::tuple<Index, Vector3d, Vector3d>>;

void bind_options(py::module_& m);  // bind_options.cpp: CorrectionOptions, the options of every deform()
void bind_lattice(py::module_& m);
void bind_mesh(py::module_& m);
void bind_deformer(py::module_& m);
void bind_edits(py::module_& m);
void bind_vulkan(py::module_& m);  // bind_vulkan.cpp, with vpffd::vulkan
void bind_io(py::module_& m);      // bind_io.cpp, with vpffd::io (OpenMesh)
void bind_embree(py::module_& m);  // bind_embree.cpp, with vpffd::embree
void bind_subdiv(py::module_& m);  // bind_subdiv.cpp, with vpffd::subdiv
void bind_check(py::module_& m);   // bind_check.cpp: mesh defect report, orientation
void bind_normals(py::module_& m); // bind_normals.cpp: rest and deformed normals
void bind_folds(py::module_& m);   // bind_folds.cpp: fold-over certification
void bind_multires(py::module_& m); // bind_multires.cpp: multiresolution decomposition, FFD and RBF

/// None, "components" or one integer label per vertex (the Python layer has checked
/// the array's kind and shape) as MeshParts; nullopt for None.
inline std::optional<MeshParts> parse_parts(const py::object& parts, RefF F, Index n_vertices) {
  if (parts.is_none()) return std::nullopt;
  if (py::isinstance<py::str>(parts)) {
    const std::string s = parts.cast<std::string>();
    VPFFD_CHECK(s == "components", "parts: expected 'components' or one integer label per vertex, got '", s, "'");
    return parts_from_components(F, n_vertices);
  }
  const auto labels = parts.cast<std::vector<std::int64_t>>();
  return parts_from_labels(F, labels, n_vertices);
}

}  // namespace vpffd::bindings
