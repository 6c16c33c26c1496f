// Picking and ray-cast rendering (vpffd::embree). vpffd/render.py wraps these.

#include "common.h"
#include "vpffd/render/raycast.h"

namespace vpffd::bindings {

namespace {

RenderCamera make_camera(const Vector3d& eye, const Vector3d& target, const Vector3d& up, double fov) {
  RenderCamera c;
  c.eye = eye;
  c.target = target;
  c.up = up;
  c.fov_degrees = fov;
  return c;
}

}  // namespace

void bind_embree(py::module_& m) {
  m.def(
      "camera_ray",
      [](const Vector3d& eye, const Vector3d& target, const Vector3d& up, double fov, int width, int height, double x,
         double y) { return camera_ray(make_camera(eye, target, up, fov), width, height, x, y); },
      py::arg("eye"), py::arg("target"), py::arg("up"), py::arg("fov"), py::arg("width"), py::arg("height"),
      py::arg("x"), py::arg("y"), "Unit direction of the ray through the centre of pixel (x, y).");

  py::class_<RayScene>(m, "RayScene", "A triangle mesh in an Embree scene (picking, rendering).")
      .def(py::init<RefV, RefF, bool, bool>(), py::arg("vertices"), py::arg("faces"), py::arg("fast_build") = false,
           py::arg("refit") = false)
      .def(
          "set_vertices",
          [](RayScene& s, RefV V) {
            py::gil_scoped_release release;
            s.set_vertices(V);
          },
          py::arg("vertices"),
          "Moves the vertices (same count, same faces); refits the BVH of a scene built with refit=True.")
      .def_property_readonly("n_vertices", &RayScene::n_vertices)
      .def_property_readonly("n_faces", &RayScene::n_faces)
      .def(
          "intersect",
          [](const RayScene& s, RefV O, RefV D, double tmin) {
            std::vector<RayHit> hits;
            {
              py::gil_scoped_release release;
              hits = s.intersect(O, D, tmin);
            }
            const auto n = static_cast<py::ssize_t>(hits.size());
            py::array_t<bool> hit(n);
            py::array_t<std::int64_t> face(n);
            py::array_t<double> uv({n, py::ssize_t(2)}), dist(n), point({n, py::ssize_t(3)});
            auto h = hit.mutable_unchecked<1>();
            auto f = face.mutable_unchecked<1>();
            auto b = uv.mutable_unchecked<2>();
            auto d = dist.mutable_unchecked<1>();
            auto p = point.mutable_unchecked<2>();
            for (py::ssize_t i = 0; i < n; ++i) {
              const RayHit& r = hits[i];
              h(i) = r.hit;
              f(i) = r.face;
              b(i, 0) = r.u;
              b(i, 1) = r.v;
              d(i) = r.hit ? r.distance : std::numeric_limits<double>::infinity();
              for (int c = 0; c < 3; ++c) p(i, c) = r.point[c];
            }
            return py::make_tuple(hit, face, uv, dist, point);
          },
          py::arg("origins"), py::arg("directions"), py::arg("tmin") = 0.0,
          "(hit (n,) bool, face (n,) int64, uv (n, 2), distance (n,), point (n, 3)) of the first hits.")
      .def(
          "render",
          [](const RayScene& s, const Vector3d& eye, const Vector3d& target, const Vector3d& up, double fov, int width,
             int height, int samples, const Vector3d& background, const Vector3d& base_color,
             std::optional<RowMatrixX3d> colors, std::optional<RowMatrixX3d> normals,
             std::optional<RowMatrixX3d> points,
             std::optional<Eigen::Matrix<std::int32_t, Eigen::Dynamic, 2, Eigen::RowMajor>> lines,
             const Vector3d& line_color, const Vector3d& point_color, double point_radius, double hidden_alpha,
             double line_alpha, double line_width, bool adaptive) {
            RenderOptions o;
            o.width = width;
            o.height = height;
            o.samples = samples;
            o.background = background;
            o.base_color = base_color;
            if (colors) o.vertex_colors = std::move(*colors);
            if (normals) o.normals = std::move(*normals);
            if (points) o.points = std::move(*points);
            if (lines) o.lines = std::move(*lines);
            o.line_color = line_color;
            o.point_color = point_color;
            o.point_radius = point_radius;
            o.hidden_alpha = hidden_alpha;
            o.line_alpha = line_alpha;
            o.line_width = line_width;
            o.adaptive = adaptive;
            const RenderCamera cam = make_camera(eye, target, up, fov);
            auto* img = new std::vector<std::uint8_t>();
            auto* depth = new std::vector<float>();
            try {
              py::gil_scoped_release release;
              *img = s.render(cam, o, depth);
            } catch (...) {
              delete img;
              delete depth;
              throw;
            }
            py::capsule own_img(img, [](void* q) { delete static_cast<std::vector<std::uint8_t>*>(q); });
            py::capsule own_depth(depth, [](void* q) { delete static_cast<std::vector<float>*>(q); });
            py::array_t<std::uint8_t> image({py::ssize_t(height), py::ssize_t(width), py::ssize_t(3)}, img->data(),
                                            own_img);
            py::array_t<float> dep({py::ssize_t(height), py::ssize_t(width)}, depth->data(), own_depth);
            return py::make_tuple(image, dep);
          },
          py::arg("eye"), py::arg("target"), py::arg("up"), py::arg("fov"), py::arg("width"), py::arg("height"),
          py::arg("samples") = 1, py::arg("background") = Vector3d(1, 1, 1),
          py::arg("base_color") = Vector3d(0.72, 0.74, 0.78), py::arg("colors") = py::none(),
          py::arg("normals") = py::none(), py::arg("points") = py::none(), py::arg("lines") = py::none(),
          py::arg("line_color") = Vector3d(0.85, 0.25, 0.15), py::arg("point_color") = Vector3d(0.1, 0.2, 0.8),
          py::arg("point_radius") = 3.0, py::arg("hidden_alpha") = 0.25, py::arg("line_alpha") = 1.0,
          py::arg("line_width") = 1.0, py::arg("adaptive") = true,
          "(image (H, W, 3) uint8, depth (H, W) float32 distances, inf on the background).");
}

}  // namespace vpffd::bindings
