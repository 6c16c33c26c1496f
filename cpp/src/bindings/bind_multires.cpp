// Multiresolution decomposition and its FFD and RBF deformers (paper 002).

#include "common.h"
#include "vpffd/multires/decomposition.h"
#include "vpffd/multires/ffd_map.h"
#include "vpffd/multires/rbf_map.h"
#include "vpffd/multires/rbf_regions.h"

namespace vpffd::bindings {

namespace {

py::array_t<double> vec(const std::vector<double>& v) { return py::array_t<double>(v.size(), v.data()); }

py::array_t<double> soa(const std::vector<double>* arrays, int k) {
  const py::ssize_t n = arrays[0].size();
  py::array_t<double> out({n, py::ssize_t(k)});
  auto o = out.mutable_unchecked<2>();
  for (py::ssize_t i = 0; i < n; ++i)
    for (int a = 0; a < k; ++a) o(i, a) = arrays[a][i];
  return out;
}

py::tuple frame_to_python(MultiresFrame&& f) {
  return py::make_tuple(py::cast(std::move(f.vertices)), py::cast(std::move(f.normals)));
}

/// A MultiresFFD frame method bound with the GIL released while it runs: Python's
/// (vertices, normals), written into the caller's `out` / `out_normals` where given.
auto frame_method(void (MultiresFFD::*method)(const Eigen::Ref<const RowMatrixX3d>&, double*, double*, int) const) {
  return [method](const MultiresFFD& d, RefV P, int threads, const py::object& out, const py::object& out_normals) {
    const Index nv = d.multires().n_vertices();
    double* X = out_rows(out, nv, "deform");
    double* N = out_rows(out_normals, nv, "deform (normals)");
    MultiresFrame f;
    if (!X) f.vertices.resize(nv, 3);
    if (!N) f.normals.resize(nv, 3);
    {
      py::gil_scoped_release release;
      (d.*method)(P, X ? X : f.vertices.data(), N ? N : f.normals.data(), threads);
    }
    return py::make_tuple(X ? out : py::cast(std::move(f.vertices)), N ? out_normals : py::cast(std::move(f.normals)));
  };
}

}  // namespace

void bind_multires(py::module_& m) {
  py::class_<Multires, std::shared_ptr<Multires>>(m, "Multires", "Two-scale decomposition (base + displacements).")
      .def(py::init([](RefV V, RefF F, double smoothing, int threads, bool exact, int fit_rounds, double fairness,
                       bool lift, py::object progress) {
             // The callback runs between stages on this thread: it takes the GIL back
             // for the call only (a Python exception in it unwinds decompose).
             DecomposeProgress report;
             if (!progress.is_none())
               report = [&progress](const char* stage, int done, int total, double rms) {
                 py::gil_scoped_acquire gil;
                 progress(stage, done, total, rms);
               };
             py::gil_scoped_release release;
             return std::make_shared<Multires>(
                 decompose(V, F, smoothing, threads, exact, fit_rounds, fairness, lift, report));
           }),
           py::arg("vertices"), py::arg("faces"), py::arg("smoothing"), py::arg("threads") = 0,
           py::arg("exact_foot_points") = true, py::arg("fit_rounds") = 4, py::arg("fairness") = 100.0,
           py::arg("lift") = true, py::arg("progress") = py::none())
      .def_property_readonly("lift", [](const Multires& r) {
        return r.lift.empty() ? vec(std::vector<double>(static_cast<size_t>(r.n_vertices()), 0.0)) : vec(r.lift);
      })
      .def_property_readonly("lifted_count", &Multires::lifted_count)
      .def_readonly("rms_displacement", &Multires::rms_displacement)
      .def_readonly("fairness", &Multires::fairness)
      .def_readonly("base", &Multires::base)
      .def_readonly("rest_normals", &Multires::rest_normals)
      .def_property_readonly("displacements", [](const Multires& r) { return vec(r.d); })
      .def_property_readonly("residuals", [](const Multires& r) { return vec(r.residual); })
      .def_property_readonly("foot_points", [](const Multires& r) { return soa(r.foot.data(), 3); })
      .def_property_readonly("tangents_u", [](const Multires& r) { return soa(r.su.data(), 3); })
      .def_property_readonly("tangents_v", [](const Multires& r) { return soa(r.sv.data(), 3); })
      .def_property_readonly("normal_coefficients", [](const Multires& r) { return soa(r.coef.data(), 6); })
      .def_property_readonly("foot_faces",
                             [](const Multires& r) { return py::array_t<std::int32_t>(r.face.size(), r.face.data()); })
      .def_property_readonly("foot_uv",
                             [](const Multires& r) {
                               const std::vector<double> uv[2] = {r.u, r.v};
                               return soa(uv, 2);
                             })
      .def_property_readonly("extrapolated_fraction", &Multires::extrapolated_fraction)
      .def_property_readonly("exact",
                             [](const Multires& r) {
                               py::array_t<bool> a(static_cast<py::ssize_t>(r.exact.size()));
                               for (size_t i = 0; i < r.exact.size(); ++i) a.mutable_data()[i] = r.exact[i] != 0;
                               return a;
                             })
      .def_property_readonly("unresolved_count", &Multires::unresolved_count)
      .def_property_readonly_static("bytes_per_vertex", [](py::object) { return Multires::bytes_per_vertex; })
      .def_property_readonly_static("frame_bytes_per_vertex",
                                    [](py::object) { return Multires::frame_bytes_per_vertex; });

  py::class_<MultiresFFD>(m, "MultiresFFD", "FFD of a decomposition's base, reconstruction of the fine mesh.")
      .def(py::init([](std::shared_ptr<Multires> mr, const Lattice& L, int threads) {
             py::gil_scoped_release release;
             return std::make_unique<MultiresFFD>(std::move(mr), L, threads);
           }),
           py::arg("multires"), py::arg("lattice"), py::arg("threads") = 0)
      .def_property_readonly_static("frame_bytes_per_vertex",
                                    [](py::object) { return MultiresFFD::frame_bytes_per_vertex; })
      .def(
          "deform",
          frame_method(&MultiresFFD::deform),
          py::arg("control_points"), py::arg("threads") = 0, py::arg("out") = py::none(),
          py::arg("out_normals") = py::none(), "(vertices (V, 3), unit normals (V, 3)).")
      .def(
          "deform_per_point",
          frame_method(&MultiresFFD::deform_per_point),
          py::arg("control_points"), py::arg("threads") = 0, py::arg("out") = py::none(),
          py::arg("out_normals") = py::none(),
          "deform() with the per-point kernel (its reference): (vertices (V, 3), unit normals (V, 3)).")
      .def_property_readonly("uses_cell_runs", &MultiresFFD::uses_cell_runs)
      .def_property_readonly("held_bytes_per_vertex", &MultiresFFD::held_bytes_per_vertex)
      .def(
          "foot_values_jacobians",
          [](const MultiresFFD& d, RefV P, int threads) {
            RowMatrixX3d X;
            RowMatrixXd J;
            {
              py::gil_scoped_release release;
              d.foot_values_jacobians(P, X, J, threads);
            }
            return py::make_tuple(X, J);
          },
          py::arg("control_points"), py::arg("threads") = 0, "(D at the foot points (V, 3), Jacobians (V, 9)).")
      .def(
          "foot_values_jacobians_per_point",
          [](const MultiresFFD& d, RefV P, int threads) {
            RowMatrixX3d X;
            RowMatrixXd J;
            {
              py::gil_scoped_release release;
              d.foot_values_jacobians_per_point(P, X, J, threads);
            }
            return py::make_tuple(X, J);
          },
          py::arg("control_points"), py::arg("threads") = 0,
          "foot_values_jacobians with the per-point kernel (the reference).");

  py::class_<RbfWeights>(m, "RbfWeights", "A solved RBF map (normalised coordinates).")
      .def_readonly("w", &RbfWeights::w)
      .def_readonly("A", &RbfWeights::A)
      .def_readonly("b", &RbfWeights::b);

  py::class_<RbfMap>(m, "RbfMap", "Triharmonic RBF space deformation, factorised once per handle set.")
      .def(py::init<const Eigen::Ref<const RowMatrixX3d>&>(), py::arg("handles"))
      .def_property_readonly("n_handles", &RbfMap::n_handles)
      .def_property_readonly("handles", &RbfMap::handles)
      .def("solve", &RbfMap::solve, py::arg("targets"))
      .def(
          "map",
          [](const RbfMap& r, const RbfWeights& W, RefV X, int threads) {
            py::gil_scoped_release release;
            return r.map(W, X, threads);
          },
          py::arg("weights"), py::arg("points"), py::arg("threads") = 0)
      .def(
          "jacobians",
          [](const RbfMap& r, const RbfWeights& W, RefV X, int threads) {
            RowMatrixX3d values;
            RowMatrixXd J;
            {
              py::gil_scoped_release release;
              r.map_jacobians(W, X, values, J, threads);
            }
            return J;
          },
          py::arg("weights"), py::arg("points"), py::arg("threads") = 0, "(n, 9) row-major Jacobians of the map.")
      .def(
          "deform",
          [](const RbfMap& r, std::shared_ptr<Multires> mr, const RbfWeights& W, int threads) {
            MultiresFrame f;
            {
              py::gil_scoped_release release;
              f = rbf_deform(*mr, r, W, threads);
            }
            return frame_to_python(std::move(f));
          },
          py::arg("multires"), py::arg("weights"), py::arg("threads") = 0);

  py::class_<RbfRegions>(m, "RbfRegions",
                         "Paper 002 Section 6: deformable region, K handle regions moved by affine maps, the RBF "
                         "deformation basis precomputed per free vertex.")
      .def(py::init([](std::shared_ptr<Multires> mr, py::array_t<std::uint8_t, py::array::c_style | py::array::forcecast>
                                                         deformable,
                       const std::vector<py::array_t<Index, py::array::c_style | py::array::forcecast>>& handles,
                       int fixed_rings, double spacing, int threads) {
             VPFFD_CHECK(deformable.ndim() == 1, "RBF regions: the deformable mask must be one-dimensional");
             std::vector<std::uint8_t> mask(deformable.data(), deformable.data() + deformable.size());
             std::vector<std::vector<Index>> h;
             for (const auto& a : handles) {
               VPFFD_CHECK(a.ndim() == 1, "RBF regions: each handle region must be a 1-D array of vertex indices");
               h.emplace_back(a.data(), a.data() + a.size());
             }
             py::gil_scoped_release release;
             return std::make_unique<RbfRegions>(std::move(mr), mask, h, fixed_rings, spacing, threads);
           }),
           py::arg("multires"), py::arg("deformable"), py::arg("handles"), py::arg("fixed_rings") = 2,
           py::arg("spacing") = 0.0, py::arg("threads") = 0)
      .def_property_readonly("n_regions", &RbfRegions::n_regions)
      .def_property_readonly("n_free", &RbfRegions::n_free)
      .def_property_readonly("doubles_per_free_vertex", &RbfRegions::doubles_per_free_vertex)
      .def_property_readonly("labels",
                             [](const RbfRegions& r) {
                               return py::array_t<std::int32_t>(r.labels().size(), r.labels().data());
                             })
      .def_property_readonly("constraint_vertices",
                             [](const RbfRegions& r) {
                               return py::array_t<Index>(r.constraint_vertices().size(), r.constraint_vertices().data());
                             })
      .def_property_readonly("constraint_regions",
                             [](const RbfRegions& r) {
                               return py::array_t<std::int32_t>(r.constraint_regions().size(),
                                                                r.constraint_regions().data());
                             })
      .def_property_readonly("constraint_points", &RbfRegions::constraint_points)
      .def_property_readonly("basis", &RbfRegions::basis,
                             "(n_free, 16 K) the precomputed basis of the free vertices (labels == 0, ascending).")
      .def(
          "targets",
          [](const RbfRegions& r, const std::vector<Matrix4d>& T) { return r.targets(T); }, py::arg("transforms"),
          "(H, 3) constraint targets of the K (4, 4) transforms.")
      .def(
          "deform",
          [](const RbfRegions& r, const std::vector<Matrix4d>& T, int threads) {
            const Index nv = r.multires().n_vertices();
            RowMatrixX3d X(nv, 3), N(nv, 3), B(nv, 3);
            {
              py::gil_scoped_release release;
              r.deform(T, X.data(), N.data(), B.data(), threads);
            }
            return py::make_tuple(std::move(X), std::move(N), std::move(B));
          },
          py::arg("transforms"), py::arg("threads") = 0,
          "(vertices (V, 3), unit normals (V, 3), base vertices (V, 3)) for K (4, 4) affine transforms.");
}

}  // namespace vpffd::bindings
