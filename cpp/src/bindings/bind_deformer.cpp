// The stateful Deformer: one mesh embedded in one lattice, many frames.

#include <optional>

#include "common.h"
#include "vpffd/frame/deformer.h"
#include "vpffd/mesh/parts.h"
#include "vpffd/mesh/validate.h"

namespace vpffd::bindings {

namespace {

/// The paper's face matrix with its columns in the mesh's own face order (Python's
/// face_matrix: column j is face j of the caller's faces).
CsrMatrix face_matrix_in_face_order(const Deformer& d, int threads) {
  const auto state = d.rest_state();  // A lives as long as the state
  const CsrMatrix& A = face_matrix(d.topology(), *state, threads);
  const std::vector<std::int32_t>& fo = d.face_processing_order();
  CsrMatrix B = A;
  parallel_range(A.rows, threads, [&](Index b, Index e) {
    std::vector<std::pair<std::int32_t, double>> row;
    for (Index r = b; r < e; ++r) {
      row.clear();
      for (auto p = A.indptr[r]; p < A.indptr[r + 1]; ++p) row.emplace_back(fo[A.indices[p]], A.values[p]);
      std::sort(row.begin(), row.end());
      auto p = A.indptr[r];
      for (const auto& [c, v] : row) {
        B.indices[p] = c;
        B.values[p++] = v;
      }
    }
  });
  return B;
}

}  // namespace

void bind_deformer(py::module_& m) {
  py::class_<Deformer, std::unique_ptr<Deformer>>(m, "Deformer")
      .def(py::init([](RefV V, RefF F, const Lattice& L, const std::string& outside, int threads,
                       const py::object& parts) {
             const OutsidePolicy pol = parse_outside_policy(outside);
             std::optional<MeshParts> mp;
             {
               py::gil_scoped_release release;
               validate_mesh(V, F, "Deformer");
             }
             mp = parse_parts(parts, F, V.rows());
             py::gil_scoped_release release;
             return std::make_unique<Deformer>(V, F, L, pol, threads, mp ? &*mp : nullptr);
           }),
           py::arg("vertices"), py::arg("faces"), py::arg("lattice"), py::arg("outside") = "error",
           py::arg("threads") = 0, py::arg("parts") = py::none())
      .def(
          "set_rest_vertices",
          [](Deformer& d, RefV X, int threads) {
            py::gil_scoped_release release;
            d.set_rest_vertices(X, threads);
          },
          py::arg("vertices"), py::arg("threads") = 0)
      .def(
          "set_rest_offsets",
          [](Deformer& d, RefV offsets, int threads) {
            py::gil_scoped_release release;
            d.set_rest_offsets(offsets, threads);
          },
          py::arg("offsets"), py::arg("threads") = 0,
          "Moves each part (the whole mesh without parts) by its row of offsets (K, 3) from the base "
          "positions (see vpffd::Deformer::set_rest_offsets).")
      .def_property_readonly("rest_is_offset", &Deformer::rest_is_offset)
      .def_property_readonly("rest_vertices",
                             [](const Deformer& d) {
                               py::gil_scoped_release release;
                               return RowMatrixX3d(*d.rest_state()->V);
                             })
      .def_property_readonly("has_parts", &Deformer::has_parts)
      .def_property_readonly("n_parts", &Deformer::n_parts)
      .def_property_readonly("part_labels", [](const Deformer& d) { return d.parts().labels; })
      .def_property_readonly("vertex_parts",
                             [](const Deformer& d) {
                               const auto& vp = d.parts().vertex_part;
                               return py::array_t<std::int32_t>(static_cast<py::ssize_t>(vp.size()), vp.data());
                             })
      .def("rest_part_volumes", &Deformer::rest_part_volumes)
      .def_property_readonly("n_vertices", &Deformer::n_vertices)
      .def_property_readonly("n_faces", &Deformer::n_faces)
      .def_property_readonly("n_control_points", &Deformer::n_control_points)
      .def_property_readonly("is_closed", &Deformer::is_closed)
      .def("rest_volume", &Deformer::rest_volume, py::arg("allow_open") = false,
           py::call_guard<py::gil_scoped_release>(),
           "Enclosed volume of the current rest mesh, summed on first use after a move.")
      .def_property_readonly("rest_volume_known", &Deformer::rest_volume_known)
      .def("rest_volume_of", &Deformer::rest_volume_of, py::arg("vertices"), py::arg("threads") = 0,
           py::call_guard<py::gil_scoped_release>(),
           "The rest volume set_rest_vertices(vertices) would give (the same sum), without moving.")
      .def_property_readonly("bytes_per_vertex", &Deformer::bytes_per_vertex)
      .def_property_readonly("origin", &Deformer::origin)
      .def(
          "ffd",
          [](const Deformer& d, RefV P, int threads, const py::object& out) -> py::object {
            double* into = out_rows(out, d.n_vertices(), "ffd");
            if (!into) {
              RowMatrixX3d X;
              {
                py::gil_scoped_release release;
                X = d.ffd(P, threads);
              }
              return py::cast(std::move(X));
            }
            {
              py::gil_scoped_release release;
              d.ffd(P, into, threads);
            }
            return out;
          },
          py::arg("control_points"), py::arg("threads") = 0, py::arg("out") = py::none())
      .def(
          "jacobians",
          [](const Deformer& d, RefV P, int threads) {
            py::gil_scoped_release release;
            return d.jacobians(P, threads);
          },
          py::arg("control_points"), py::arg("threads") = 0)
      .def(
          "deformed_normals",
          [](const Deformer& d, RefV P, RefV N0, int threads, const py::object& out) -> py::object {
            double* into = out_rows(out, d.n_vertices(), "deformed_normals");
            if (!into) {
              RowMatrixX3d N;
              {
                py::gil_scoped_release release;
                N = d.deformed_normals(P, N0, threads);
              }
              return py::cast(std::move(N));
            }
            {
              py::gil_scoped_release release;
              d.deformed_normals(P, N0, into, threads);
            }
            return out;
          },
          py::arg("control_points"), py::arg("rest_normals"), py::arg("threads") = 0, py::arg("out") = py::none())
      .def(
          "basis_transpose",
          [](const Deformer& d, const Eigen::Ref<const VectorXd>& w, int threads) {
            py::gil_scoped_release release;
            return d.basis_transpose(w, threads);
          },
          py::arg("values"), py::arg("threads") = 0)
      .def(
          "jacobian_determinants",
          [](const Deformer& d, RefV P, int threads) {
            py::gil_scoped_release release;
            return d.jacobian_determinants(P, threads);
          },
          py::arg("control_points"), py::arg("threads") = 0)
      .def(
          "basis_matrix",
          [](const Deformer& d, int threads) {
            CsrMatrix A;
            {
              py::gil_scoped_release release;
              A = d.basis_matrix(threads);
            }
            return csr_to_python(std::move(A));
          },
          py::arg("threads") = 0)
      .def(
          "face_matrix",
          [](const Deformer& d, int threads) {
            CsrMatrix A;
            {
              py::gil_scoped_release release;
              A = face_matrix_in_face_order(d, threads);
            }
            return csr_to_python(std::move(A));
          },
          py::arg("threads") = 0)
      .def(
          "face_matrix_nnz",
          [](const Deformer& d, int threads) {
            py::gil_scoped_release release;
            const auto state = d.rest_state();
            return face_matrix(d.topology(), *state, threads).nnz();
          },
          py::arg("threads") = 0)
      .def(
          "volume_coefficients",
          [](const Deformer& d, RefV X, int axis, const std::string& method, int threads) {
            const CoefficientMethod mth = parse_method(method);
            AxisCoefficients c;
            {
              py::gil_scoped_release release;
              c = d.volume_coefficients(X, axis, mth, threads);
            }
            return py::make_tuple(std::move(c.alpha), c.volume);
          },
          py::arg("vertices"), py::arg("axis"), py::arg("method") = "traversal", py::arg("threads") = 0)
      .def(
          "deform",
          [](const Deformer& d, RefV P, const CorrectionOptions& o, const py::object& out) {
            double* into = out_rows(out, d.n_vertices(), "deform");
            DeformResult r;
            {
              py::gil_scoped_release release;
              r = d.deform(P, o, into);
            }
            py::dict res = result_to_python(std::move(r));
            if (into) res["vertices"] = out;
            return res;
          },
          py::arg("control_points"), py::arg("options") = CorrectionOptions(), py::arg("out") = py::none(),
          "One frame (vpffd::Deformer::deform): the result as a dict (vertices, control_points, offsets, volumes, "
          "steps, [part volumes], [timings]).");
}

}  // namespace vpffd::bindings
