// Displaced subdivision surfaces (paper 002, §5): decomposition, frames, affine
// group edits. Built with vpffd::subdiv only.

#include <memory>
#include <string>

#include "common.h"
#include "vpffd/subdiv/subdivision_frame.h"
#include "vpffd/subdiv/subdivision_multires.h"

namespace vpffd::bindings {

// A named namespace: the binding files compile as unity batches.
namespace subdiv_binding {

template <class T>
py::array_t<T> array(const std::vector<T>& v) {
  return py::array_t<T>(py::ssize_t(v.size()), v.data());
}

SubdivScheme parse_scheme(const std::string& s) {
  if (s == "loop") return SubdivScheme::Loop;
  if (s == "catmark") return SubdivScheme::CatmullClark;
  throw InvalidInputError("SubdivisionMultires: scheme must be 'loop' or 'catmark', got '" + s + "'");
}

SubdivOptions options(const std::string& scheme, double fairness, int iterations, int approx_level,
                      Index max_unresolved, int threads, const py::object& progress) {
  SubdivOptions o;
  // The callback runs between stages on the calling thread: it takes the GIL back for
  // the call only (a Python exception in it unwinds the decomposition).
  if (!progress.is_none())
    o.progress = [&progress](const char* stage, int done, int total, double rms) {
      py::gil_scoped_acquire gil;
      progress(stage, done, total, rms);
    };
  o.scheme = parse_scheme(scheme);
  o.fairness = fairness;
  o.iterations = iterations;
  o.approx_level = approx_level;
  o.max_unresolved = max_unresolved;
  o.threads = threads;
  return o;
}

py::tuple frame_to_python(SubdivFrame&& f) {
  return py::make_tuple(py::cast(std::move(f.vertices)), py::cast(std::move(f.normals)), py::cast(std::move(f.base)));
}

}  // namespace subdiv_binding

void bind_subdiv(py::module_& m) {
  namespace sb = subdiv_binding;
  using SM = SubdivisionMultires;
  py::class_<SM, std::shared_ptr<SM>>(m, "SubdivisionMultires",
                                      "Displaced subdivision surface: limit surface of a control mesh + displacements.")
      .def_property_readonly("scheme",
                             [](const SM& s) { return s.scheme == SubdivScheme::Loop ? "loop" : "catmark"; })
      .def_readonly("control_points", &SM::control_points)
      .def_property_readonly("control_face_sizes", [](const SM& s) { return sb::array(s.control_face_sizes); })
      .def_property_readonly("control_faces", [](const SM& s) { return sb::array(s.control_faces); })
      .def_readonly("rest_normals", &SM::rest_normals)
      .def_readonly("diagonal", &SM::diagonal)
      .def_property_readonly("patches", [](const SM& s) { return sb::array(s.patch); })
      .def_property_readonly("uv",
                             [](const SM& s) {
                               py::array_t<double> out({py::ssize_t(s.u.size()), py::ssize_t(2)});
                               auto o = out.mutable_unchecked<2>();
                               for (size_t i = 0; i < s.u.size(); ++i) o(i, 0) = s.u[i], o(i, 1) = s.v[i];
                               return out;
                             })
      .def_property_readonly("displacements", [](const SM& s) { return sb::array(s.d); })
      .def_property_readonly("residuals", [](const SM& s) { return sb::array(s.residual); })
      .def_property_readonly("unresolved", [](const SM& s) { return sb::array(s.unresolved); })
      .def_property_readonly("normal_coefficients",
                             [](const SM& s) {
                               const py::ssize_t n = py::ssize_t(s.d.size());
                               py::array_t<double> out({n, py::ssize_t(6)});
                               auto o = out.mutable_unchecked<2>();
                               for (py::ssize_t i = 0; i < n; ++i)
                                 for (int k = 0; k < 6; ++k) o(i, k) = s.coef[k][i];
                               return out;
                             })
      .def_property_readonly("stencils",
                             [](const SM& s) {
                               const LimitStencils& t = s.stencils;
                               return py::make_tuple(sb::array(t.indptr), sb::array(t.indices), sb::array(t.w),
                                                     sb::array(t.wu), sb::array(t.wv));
                             })
      .def_readonly("rms_initial", &SM::rms_initial)
      .def_readonly("rms_final", &SM::rms_final)
      .def_readonly("rms_rounds", &SM::rms_rounds)
      .def_readonly("seconds", &SM::seconds)
      .def_property_readonly("frame_bytes_per_vertex", &SM::frame_bytes_per_vertex)
      .def(
          "deform",
          [](const SM& s, RefV C, int threads) {
            SubdivFrame f;
            {
              py::gil_scoped_release release;
              f = deform_subdivision(s, C, threads);
            }
            return sb::frame_to_python(std::move(f));
          },
          py::arg("control_points"), py::arg("threads") = 0,
          "(vertices (V, 3), approximate unit normals (V, 3), base points S'(t_i) (V, 3)).")
      .def(
          "affine_group",
          [](const SM& s, RefV C, const std::vector<std::int32_t>& indices, int threads) {
            py::gil_scoped_release release;
            return make_affine_group(s, C, indices, threads);
          },
          py::arg("control_points"), py::arg("indices"), py::arg("threads") = 0)
      .def(
          "deform_affine",
          [](const SM& s, const AffineGroup& g, const Eigen::Matrix4d& T, int threads) {
            SubdivFrame f;
            {
              py::gil_scoped_release release;
              f = deform_affine_group(s, g, T, threads);
            }
            return sb::frame_to_python(std::move(f));
          },
          py::arg("group"), py::arg("transform"), py::arg("threads") = 0);

  py::class_<AffineGroup>(m, "SubdivAffineGroup", "A control-point group with its basis precomputed per fine vertex.")
      .def_property_readonly("indices", [](const AffineGroup& g) { return sb::array(g.indices); })
      .def_property_readonly("rows", [](const AffineGroup& g) { return sb::array(g.rows); })
      .def_property_readonly("bytes_per_vertex", &AffineGroup::bytes_per_vertex);

  m.def(
      "subdivision_decompose",
      [](RefV V, RefF F, RefV CV, const std::vector<std::int32_t>& sizes, const std::vector<std::int32_t>& verts,
         const std::string& scheme, double fairness, int iterations, int approx_level, Index max_unresolved,
         int threads, py::object progress) {
        const SubdivOptions o =
            sb::options(scheme, fairness, iterations, approx_level, max_unresolved, threads, progress);
        py::gil_scoped_release release;
        return std::make_shared<SM>(decompose_subdivision(V, F, CV, sizes, verts, o));
      },
      py::arg("vertices"), py::arg("faces"), py::arg("control_points"), py::arg("face_sizes"),
      py::arg("face_vertices"), py::arg("scheme"), py::arg("fairness"), py::arg("iterations"),
      py::arg("approx_level"), py::arg("max_unresolved"), py::arg("threads") = 0, py::arg("progress") = py::none(),
      "Decomposition over a given control mesh (polygons as sizes + concatenated vertices).");
  m.def(
      "subdivision_decompose_decimated",
      [](RefV V, RefF F, Index control_vertices, const std::string& scheme, double fairness, int iterations,
         int approx_level, Index max_unresolved, int threads, py::object progress) {
        const SubdivOptions o =
            sb::options(scheme, fairness, iterations, approx_level, max_unresolved, threads, progress);
        py::gil_scoped_release release;
        return std::make_shared<SM>(decompose_subdivision(V, F, control_vertices, o));
      },
      py::arg("vertices"), py::arg("faces"), py::arg("control_vertices"), py::arg("scheme"), py::arg("fairness"),
      py::arg("iterations"), py::arg("approx_level"), py::arg("max_unresolved"), py::arg("threads") = 0,
      py::arg("progress") = py::none(),
      "Decomposition over a control mesh decimated from the fine one.");
  m.def(
      "decimate_mesh",
      [](RefV V, RefF F, Index target) {
        py::gil_scoped_release release;
        return decimate_mesh(V, F, target);
      },
      py::arg("vertices"), py::arg("faces"), py::arg("target"),
      "(control points (M, 3), triangles) by quadric decimation to about `target` vertices.");
}

}  // namespace vpffd::bindings
