// The Vulkan backend: _core.VulkanDeformer (deform() as _core.Deformer.deform),
// _core.VulkanMultires (deform() as _core.MultiresFFD.deform), _core.VulkanSubdivFrame
// (deform() as _core.SubdivisionMultires.deform, from plain arrays), _core.VulkanRbfFrame (deform() as
// _core.RbfRegions.deform) and _core.vulkan_devices().

#include <optional>

#include "common.h"
#include "vpffd/frame/deformer.h"
#include "vpffd/backend/vulkan.h"
#include "vpffd/backend/vulkan_multires.h"
#include "vpffd/backend/vulkan_rbf.h"
#include "vpffd/backend/vulkan_subdiv.h"
#include "vpffd/multires/rbf_regions.h"

namespace vpffd::bindings {

namespace {

py::dict device_to_python(const vulkan::DeviceInfo& d) {
  py::dict o;
  o["index"] = d.index;
  o["name"] = d.name;
  o["type"] = d.type;
  o["memory_bytes"] = d.memory_bytes;
  o["api_version"] = d.api_version;
  o["driver"] = d.driver;
  o["float64"] = d.float64;
  o["suitable"] = d.suitable;
  o["reason"] = d.reason;
  return o;
}

py::dict timings_to_python(const vulkan::FrameTimings& t) {
  py::dict o;
  o["gpu_total_ms"] = t.gpu_total;
  o["gpu_ffd_ms"] = t.gpu_ffd;
  o["gpu_steps_ms"] = t.gpu_steps;
  o["gpu_final_ms"] = t.gpu_final;
  o["gpu_move_ms"] = t.gpu_move;
  o["gpu_readback_ms"] = t.gpu_readback;
  o["host_total_ms"] = t.host_total;
  o["host_prepare_ms"] = t.host_prepare;
  o["host_submit_wait_ms"] = t.host_submit_wait;
  o["host_unpack_ms"] = t.host_unpack;
  o["has_timestamps"] = t.has_timestamps;
  return o;
}

}  // namespace

void bind_vulkan(py::module_& m) {
  using vulkan::VulkanDeformer;
  m.def(
      "vulkan_devices",
      [] {
        std::string why;
        std::vector<vulkan::DeviceInfo> ds;
        {
          py::gil_scoped_release release;
          ds = vulkan::devices(&why);
        }
        py::list out;
        for (const auto& d : ds) out.append(device_to_python(d));
        return py::make_tuple(out, why);
      },
      "([device dicts], why): the Vulkan devices, and why there are none when the list is empty.");

  py::class_<VulkanDeformer, std::unique_ptr<VulkanDeformer>>(m, "VulkanDeformer")
      .def(py::init([](RefV V, RefF F, const Lattice& L, const std::string& outside, const std::string& device,
                       const std::string& precision, const py::object& parts) {
             const OutsidePolicy pol = parse_outside_policy(outside);
             const vulkan::Precision prec = vulkan::parse_precision(precision);
             const std::optional<MeshParts> mp = parse_parts(parts, F, V.rows());
             py::gil_scoped_release release;
             return std::make_unique<VulkanDeformer>(V, F, L, pol, device, prec, mp ? &*mp : nullptr);
           }),
           py::arg("vertices"), py::arg("faces"), py::arg("lattice"), py::arg("outside") = "error",
           py::arg("device") = "", py::arg("precision") = "auto", py::arg("parts") = py::none())
      .def("rest_part_volumes", &VulkanDeformer::rest_part_volumes,
           "(K,) each part's volume of the current rest mesh (the whole mesh's without parts).")
      .def_property_readonly(
          "cpu", [](const VulkanDeformer& d) -> const Deformer& { return d.cpu(); },
          py::return_value_policy::reference_internal,
          "The CPU Deformer of the current rest mesh (ffd, jacobians, matrices); after set_rest_vertices "
          "the first access re-embeds it on the host.")
      .def(
          "set_rest_vertices",
          [](VulkanDeformer& d, RefV X) {
            py::gil_scoped_release release;
            d.set_rest_vertices(X);
          },
          py::arg("vertices"),
          "Moves the rest mesh (V, 3): embedded and sorted by cell on the device (see "
          "vpffd::vulkan::VulkanDeformer::set_rest_vertices).")
      .def(
          "set_rest_offsets",
          [](VulkanDeformer& d, RefV offsets) {
            py::gil_scoped_release release;
            d.set_rest_offsets(offsets);
          },
          py::arg("offsets"),
          "Moves each part (the whole mesh without parts) by its row of offsets (K, 3) from the base "
          "positions: only the offsets go to the device (see vpffd::vulkan::VulkanDeformer::set_rest_offsets).")
      .def_property_readonly(
          "rest_vertices", [](const VulkanDeformer& d) { return RowMatrixX3d(d.rest_vertices()); },
          "(V, 3) the current rest vertices (a copy).")
      .def("rest_volume", &VulkanDeformer::rest_volume, py::arg("allow_open") = false,
           py::call_guard<py::gil_scoped_release>(),
           "Enclosed volume of the current rest mesh (raises for an open mesh unless allow_open), "
           "summed on the host on first use after a move.")
      .def_property_readonly("rest_volume_known", &VulkanDeformer::rest_volume_known)
      .def("rest_volume_of", &VulkanDeformer::rest_volume_of, py::arg("vertices"),
           py::call_guard<py::gil_scoped_release>(),
           "The rest volume set_rest_vertices(vertices) would give (the same sum), without moving.")
      .def_property_readonly("device", [](const VulkanDeformer& d) { return device_to_python(d.device()); })
      .def_property_readonly("origin", &VulkanDeformer::origin)
      .def_property_readonly("scale", &VulkanDeformer::scale,
                             "Unit of the device positions: (world - origin) / scale (a power of two).")
      .def_property_readonly(
          "precision", [](const VulkanDeformer& d) { return std::string(vulkan::precision_name(d.precision())); },
          "How the device sums: 'float64' or 'float-float'.")
      .def("vertices",
           [](const VulkanDeformer& d) {
             py::gil_scoped_release release;
             return d.vertices();
           })
      .def("last_timings",
           [](const VulkanDeformer& d) {
             vulkan::FrameTimings t;
             {
               // A frame of another thread may hold the deformer's lock.
               py::gil_scoped_release release;
               t = d.last_timings();
             }
             return timings_to_python(t);
           })
      .def_property_readonly("vertex_buffer_handle", &VulkanDeformer::vertex_buffer_handle)
      .def_property_readonly("index_buffer_handle", &VulkanDeformer::index_buffer_handle)
      .def_property_readonly("vertex_order",
                             [](const VulkanDeformer& d) {
                               const auto& o = d.vertex_order();
                               return py::array_t<std::int32_t>(static_cast<py::ssize_t>(o.size()), o.data());
                             })
      .def(
          "deform",
          [](VulkanDeformer& d, RefV P, const CorrectionOptions& o, bool read_vertices, bool normals,
             const py::object& out, const py::object& out_normals) {
            const Index nv = static_cast<Index>(d.vertex_order().size());  // cpu() might re-embed
            double* into = read_vertices ? out_rows(out, nv, "deform") : nullptr;
            double* into_n = normals ? out_rows(out_normals, nv, "deform (normals)") : nullptr;
            DeformResult r;
            RowMatrixX3d N;
            std::shared_ptr<const double> shared;
            {
              py::gil_scoped_release release;
              if (read_vertices && !into) {
                // The vertices are the read-back memory itself (no copy), held by the array.
                if (normals && !into_n) N.resize(nv, 3);
                r = d.deform(P, o, &shared, into_n ? into_n : (normals ? N.data() : nullptr));
              } else if (into || into_n) {
                // read back into the caller's arrays; the vertices into a buffer of ours
                // only when asked for without `out`.
                RowMatrixX3d X(into || !read_vertices ? 0 : nv, 3);
                if (normals && !into_n) N.resize(nv, 3);
                r = d.deform(P, o, into ? into : (read_vertices ? X.data() : nullptr),
                             into_n ? into_n : (normals ? N.data() : nullptr));
                if (!into && read_vertices) r.vertices = std::move(X);
              } else {
                r = d.deform(P, o, read_vertices, normals ? &N : nullptr);
              }
            }
            py::dict res = result_to_python(std::move(r));
            if (into) res["vertices"] = out;
            if (shared) {
              // The array keeps the memory (and the device) alive; the deformer writes it
              // again only once this array and every view of it are gone.
              auto* keep = new std::shared_ptr<const double>(shared);
              py::capsule owner(keep, [](void* p) { delete static_cast<std::shared_ptr<const double>*>(p); });
              res["vertices"] = py::array_t<double>({static_cast<py::ssize_t>(nv), py::ssize_t(3)},
                                                    const_cast<double*>(shared.get()), owner);
            }
            if (normals) res["normals"] = into_n ? out_normals : py::cast(std::move(N));
            return res;
          },
          py::arg("control_points"), py::arg("options") = CorrectionOptions(), py::arg("read_vertices") = true,
          py::arg("normals") = false, py::arg("out") = py::none(), py::arg("out_normals") = py::none(),
          "One frame (see vpffd::vulkan::VulkanDeformer::deform), the options as for Deformer.deform. normals=True "
          "adds 'normals': the (V, 3) unit normals of the deformed surface, computed on the device in the same "
          "submission.");

  using vulkan::VulkanMultires;
  py::class_<VulkanMultires, std::unique_ptr<VulkanMultires>>(
      m, "VulkanMultires", "The multiresolution frame of a decomposition's base FFD on a Vulkan device.")
      .def(py::init([](std::shared_ptr<Multires> mr, const Lattice& L, const std::string& device,
                       const std::string& precision) {
             const vulkan::Precision prec = vulkan::parse_precision(precision);
             py::gil_scoped_release release;
             return std::make_unique<VulkanMultires>(std::move(mr), L, device, prec);
           }),
           py::arg("multires"), py::arg("lattice"), py::arg("device") = "", py::arg("precision") = "auto")
      .def_property_readonly_static("frame_bytes_per_vertex",
                                    [](py::object) { return VulkanMultires::frame_bytes_per_vertex; })
      .def_property_readonly("device", [](const VulkanMultires& d) { return device_to_python(d.device()); })
      .def_property_readonly("origin", &VulkanMultires::origin)
      .def_property_readonly("scale", &VulkanMultires::scale)
      .def_property_readonly(
          "precision", [](const VulkanMultires& d) { return std::string(vulkan::precision_name(d.precision())); })
      .def_property_readonly("vertex_buffer_handle", &VulkanMultires::vertex_buffer_handle)
      .def_property_readonly("normal_buffer_handle", &VulkanMultires::normal_buffer_handle)
      .def_property_readonly("vertex_order",
                             [](const VulkanMultires& d) {
                               const auto& o = d.vertex_order();
                               return py::array_t<std::int32_t>(static_cast<py::ssize_t>(o.size()), o.data());
                             })
      .def("last_timings",
           [](const VulkanMultires& d) {
             vulkan::FrameTimings t;
             {
               py::gil_scoped_release release;
               t = d.last_timings();
             }
             return timings_to_python(t);
           })
      .def(
          "deform",
          [](VulkanMultires& d, RefV P, const py::object& out, const py::object& out_normals) {
            const Index nv = static_cast<Index>(d.vertex_order().size());
            double* X = out_rows(out, nv, "deform");
            double* N = out_rows(out_normals, nv, "deform (normals)");
            MultiresFrame f;
            if (!X) f.vertices.resize(nv, 3);
            if (!N) f.normals.resize(nv, 3);
            {
              py::gil_scoped_release release;
              d.deform(P, X ? X : f.vertices.data(), N ? N : f.normals.data());
            }
            return py::make_tuple(X ? out : py::cast(std::move(f.vertices)),
                                  N ? out_normals : py::cast(std::move(f.normals)));
          },
          py::arg("control_points"), py::arg("out") = py::none(), py::arg("out_normals") = py::none(),
          "(vertices (V, 3), approximate unit normals (V, 3)), input order.")
      .def(
          "deform_after",
          [](VulkanMultires& d, VulkanDeformer& correction, RefV P, const CorrectionOptions& o,
             VulkanDeformer* base, const py::object& out, const py::object& out_normals) {
            const Index nv = static_cast<Index>(d.vertex_order().size());
            double* X = out_rows(out, nv, "deform");
            double* N = out_rows(out_normals, nv, "deform (normals)");
            vulkan::MultiresDeviceFrame f;
            {
              py::gil_scoped_release release;
              f = d.deform(correction, P, o, base, X, N);
            }
            return py::make_tuple(X ? out : py::cast(std::move(f.frame.vertices)),
                                  N ? out_normals : py::cast(std::move(f.frame.normals)),
                                  py::cast(std::move(f.base_vertices)), result_to_python(std::move(f.correction)));
          },
          py::arg("correction"), py::arg("control_points"), py::arg("options"), py::arg("base") = nullptr,
          py::arg("out") = py::none(), py::arg("out_normals") = py::none(),
          "One submission: correction's frame (as VulkanDeformer.deform), then the reconstruction from its "
          "corrected control points (and, with base, the base Deformer's FFD of them): (vertices, normals, "
          "base vertices, the correction's result dict without 'vertices').");

  using vulkan::VulkanSubdivFrame;
  using IdxPtr = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>;
  using IdxArr = py::array_t<std::int32_t, py::array::c_style | py::array::forcecast>;
  using DblArr = py::array_t<double, py::array::c_style | py::array::forcecast>;
  py::class_<VulkanSubdivFrame, std::unique_ptr<VulkanSubdivFrame>>(
      m, "VulkanSubdivFrame",
      "The frame of a displaced subdivision surface on a Vulkan device, from the decomposition's plain arrays "
      "(SubdivisionMultires.stencils, displacements, normal_coefficients).")
      .def(py::init([](const IdxPtr& indptr, const IdxArr& indices, const DblArr& w, const DblArr& wu,
                       const DblArr& wv, const DblArr& d, const DblArr& coef, RefV rest, const std::string& device,
                       const std::string& precision) {
             const vulkan::Precision prec = vulkan::parse_precision(precision);
             // The view holds pointers: the lengths are checked here, the contents by the constructor.
             VPFFD_CHECK(indptr.ndim() == 1 && indptr.size() >= 1, "VulkanSubdivFrame: indptr must be 1-D, V + 1");
             const Index nv = Index(indptr.size()) - 1;
             const std::int64_t nnz = indptr.at(nv);
             for (const DblArr* a : {&w, &wu, &wv})
               VPFFD_CHECK(a->ndim() == 1 && std::int64_t(a->size()) == nnz, "VulkanSubdivFrame: the weights must "
                           "have indptr[-1] = ", nnz, " entries, got ", a->size());
             VPFFD_CHECK(indices.ndim() == 1 && std::int64_t(indices.size()) == nnz,
                         "VulkanSubdivFrame: indices must have indptr[-1] = ", nnz, " entries, got ", indices.size());
             VPFFD_CHECK(d.ndim() == 1 && Index(d.size()) == nv, "VulkanSubdivFrame: expected ", nv,
                         " displacements, got ", d.size());
             VPFFD_CHECK(Index(coef.size()) == 6 * nv, "VulkanSubdivFrame: expected ", nv,
                         " x 6 normal coefficients, got ", coef.size(), " numbers");
             vulkan::SubdivStencilsView s;
             s.n_vertices = nv;
             s.n_control = rest.rows();
             s.indptr = indptr.data();
             s.indices = indices.data();
             s.w = w.data();
             s.wu = wu.data();
             s.wv = wv.data();
             s.d = d.data();
             s.coef = coef.data();
             py::gil_scoped_release release;
             return std::make_unique<VulkanSubdivFrame>(s, rest, device, prec);
           }),
           py::arg("indptr"), py::arg("indices"), py::arg("w"), py::arg("wu"), py::arg("wv"), py::arg("displacements"),
           py::arg("normal_coefficients"), py::arg("rest_control_points"), py::arg("device") = "",
           py::arg("precision") = "auto")
      .def_property_readonly("device", [](const VulkanSubdivFrame& f) { return device_to_python(f.device()); })
      .def_property_readonly("origin", &VulkanSubdivFrame::origin)
      .def_property_readonly("scale", &VulkanSubdivFrame::scale)
      .def_property_readonly("n_vertices", &VulkanSubdivFrame::n_vertices)
      .def_property_readonly("n_control", &VulkanSubdivFrame::n_control)
      .def_property_readonly(
          "precision", [](const VulkanSubdivFrame& f) { return std::string(vulkan::precision_name(f.precision())); })
      .def("last_timings",
           [](const VulkanSubdivFrame& f) {
             vulkan::FrameTimings t;
             {
               py::gil_scoped_release release;
               t = f.last_timings();
             }
             return timings_to_python(t);
           })
      .def(
          "deform",
          [](VulkanSubdivFrame& f, RefV C) {
            vulkan::SubdivDeviceFrame r;
            {
              py::gil_scoped_release release;
              r = f.deform(C);
            }
            return py::make_tuple(py::cast(std::move(r.vertices)), py::cast(std::move(r.normals)),
                                  py::cast(std::move(r.base)));
          },
          py::arg("control_points"),
          "(vertices (V, 3), approximate unit normals (V, 3), limit points S'(t_i) (V, 3)), as "
          "SubdivisionMultires.deform.");

  using vulkan::VulkanRbfFrame;
  py::class_<VulkanRbfFrame, std::unique_ptr<VulkanRbfFrame>>(
      m, "VulkanRbfFrame", "The RBF regions frame (Marinov et al. §6) on a Vulkan device, from an RbfRegions setting.")
      .def(py::init([](const RbfRegions& r, const std::string& device, const std::string& precision) {
             const vulkan::Precision prec = vulkan::parse_precision(precision);
             const Multires& mr = r.multires();
             const Index nv = mr.n_vertices();
             // The decomposition's SoA rest data as the view's V x 3 and V x 6 arrays.
             std::vector<double> foot(3 * nv), su(3 * nv), sv(3 * nv), d(nv), coef(6 * nv);
             for (Index i = 0; i < nv; ++i) {
               for (int a = 0; a < 3; ++a) {
                 foot[3 * i + a] = mr.foot[a][i];
                 su[3 * i + a] = mr.su[a][i];
                 sv[3 * i + a] = mr.sv[a][i];
               }
               d[i] = mr.d[i];
               for (int k = 0; k < 6; ++k) coef[6 * i + k] = mr.coef[k][i];
             }
             vulkan::RbfRegionsView s;
             s.n_vertices = nv;
             s.n_regions = r.n_regions();
             s.labels = r.labels().data();
             s.basis = r.basis().data();
             s.foot = foot.data();
             s.su = su.data();
             s.sv = sv.data();
             s.fine = mr.fine.data();
             s.normals = mr.rest_normals.data();
             s.base = mr.base.data();
             s.d = d.data();
             s.coef = coef.data();
             py::gil_scoped_release release;
             return std::make_unique<VulkanRbfFrame>(s, device, prec);
           }),
           py::arg("regions"), py::arg("device") = "", py::arg("precision") = "auto")
      .def_property_readonly("device", [](const VulkanRbfFrame& f) { return device_to_python(f.device()); })
      .def_property_readonly("origin", &VulkanRbfFrame::origin)
      .def_property_readonly("scale", &VulkanRbfFrame::scale)
      .def_property_readonly("n_vertices", &VulkanRbfFrame::n_vertices)
      .def_property_readonly("n_regions", &VulkanRbfFrame::n_regions)
      .def_property_readonly("n_free", &VulkanRbfFrame::n_free)
      .def_property_readonly(
          "precision", [](const VulkanRbfFrame& f) { return std::string(vulkan::precision_name(f.precision())); })
      .def("last_timings",
           [](const VulkanRbfFrame& f) {
             vulkan::FrameTimings t;
             {
               py::gil_scoped_release release;
               t = f.last_timings();
             }
             return timings_to_python(t);
           })
      .def(
          "deform",
          [](VulkanRbfFrame& f, const std::vector<Eigen::Matrix4d>& T) {
            vulkan::RbfDeviceFrame r;
            {
              py::gil_scoped_release release;
              r = f.deform(T);
            }
            return py::make_tuple(py::cast(std::move(r.vertices)), py::cast(std::move(r.normals)),
                                  py::cast(std::move(r.base)));
          },
          py::arg("transforms"),
          "(vertices (V, 3), unit normals (V, 3), base vertices (V, 3)) for K (4, 4) affine maps, as "
          "RbfRegions.deform.");
}

}  // namespace vpffd::bindings
