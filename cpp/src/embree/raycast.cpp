// Picking and ray-cast rendering with Embree 3. Embree errors are read back on
// the thread that made the failing call and thrown as DeviceError by that call.

#include "vpffd/render/raycast.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>
#include <string>

#include "vpffd/core/check.h"
#include "vpffd/core/exceptions.h"
#include "vpffd/ffd/normals.h"
#include "vpffd/mesh/validate.h"

namespace vpffd {
namespace {

// One Embree device for the process: creating one costs milliseconds and it is
// thread-safe. Its error state is NOT shared: Embree keeps one error code per
// thread and device, and calls the error function on the thread whose call
// failed. A single shared "last error" slot would let one thread's failure be
// thrown from another thread's unrelated call (or be lost), so the code is read
// with rtcGetDeviceError on the calling thread right after the calls it checks,
// and the callback's text is kept in a thread_local next to it.
struct Device {
  RTCDevice device = nullptr;
};

// Text of the first Embree error on this thread since the last take_error; the
// code itself lives in Embree's own per-thread slot.
thread_local std::string t_error_text;

void on_error(void*, RTCError, const char* msg) {
  // Keep the first message, like Embree keeps the first code.
  if (t_error_text.empty()) t_error_text = msg && *msg ? msg : "(no message)";
}

Device& device() {
  static Device d;
  static std::once_flag once;
  std::call_once(once, [] {
    d.device = rtcNewDevice(nullptr);
    if (d.device) rtcSetDeviceErrorFunction(d.device, on_error, nullptr);
  });
  if (!d.device)
    throw DeviceError("rtcNewDevice failed (Embree error " + std::to_string(static_cast<int>(rtcGetDeviceError(nullptr))) +
                      ")");
  return d;
}

// Reads and clears this thread's Embree error; "" when there is none.
std::string take_error() {
  const RTCError code = rtcGetDeviceError(device().device);
  std::string text = std::move(t_error_text);
  t_error_text.clear();
  if (code == RTC_ERROR_NONE) return "";
  return "Embree error " + std::to_string(static_cast<int>(code)) + (text.empty() ? "" : ": " + text);
}

void throw_if_error(const char* call) {
  std::string e = take_error();
  if (!e.empty()) throw DeviceError(std::string(call) + ": " + e);
}

// Errors raised on OpenMP worker threads sit in those threads' slots; each
// worker moves its own into this per-call collector so that the calling thread
// can throw it (and only the call that caused it sees it).
class CallErrors {
 public:
  void collect() {
    std::string e = take_error();
    if (e.empty()) return;
    std::lock_guard<std::mutex> lock(mutex_);
    if (first_.empty()) first_ = std::move(e);
  }
  void throw_if_any(const char* call) {
    collect();
    if (!first_.empty()) throw DeviceError(std::string(call) + ": " + first_);
  }

 private:
  std::mutex mutex_;
  std::string first_;
};

struct Frame {
  Vector3d eye, f, r, u;
  double tan_h, aspect;
};

Frame camera_frame(const RenderCamera& cam, int width, int height) {
  VPFFD_CHECK(width > 0 && height > 0, "render: image size must be positive, got ", width, " x ", height);
  VPFFD_CHECK(cam.eye.allFinite() && cam.target.allFinite() && cam.up.allFinite(), "camera: NaN or Inf");
  VPFFD_CHECK(cam.fov_degrees > 0 && cam.fov_degrees < 180, "camera: fov must be in (0, 180) degrees, got ",
              cam.fov_degrees);
  Frame fr;
  fr.eye = cam.eye;
  const Vector3d d = cam.target - cam.eye;
  VPFFD_CHECK(d.norm() > 0, "camera: eye and target coincide");
  fr.f = d.normalized();
  const Vector3d r = fr.f.cross(cam.up);
  VPFFD_CHECK(r.norm() > 1e-12 * cam.up.norm() && cam.up.norm() > 0,
              "camera: up is zero or parallel to the viewing direction");
  fr.r = r.normalized();
  fr.u = fr.r.cross(fr.f);
  fr.tan_h = std::tan(0.5 * cam.fov_degrees * M_PI / 180.0);
  fr.aspect = static_cast<double>(width) / height;
  return fr;
}

Vector3d frame_ray(const Frame& fr, int width, int height, double x, double y) {
  const double sx = (2.0 * (x + 0.5) / width - 1.0) * fr.tan_h * fr.aspect;
  const double sy = (1.0 - 2.0 * (y + 0.5) / height) * fr.tan_h;
  return (fr.f + sx * fr.r + sy * fr.u).normalized();
}

}  // namespace

Vector3d camera_ray(const RenderCamera& cam, int width, int height, double x, double y) {
  return frame_ray(camera_frame(cam, width, height), width, height, x, y);
}

struct RayScene::Impl {
  RowMatrixX3d V;
  RowMatrixX3i F;
  RTCScene scene = nullptr;
  double scale = 1.0;  // bounding box diagonal
  ~Impl() {
    if (scene) rtcReleaseScene(scene);
  }

  RTCRayHit make_ray(const Vector3d& o, const Vector3d& d, double tmin) const {
    RTCRayHit rh;
    rh.ray.org_x = static_cast<float>(o.x());
    rh.ray.org_y = static_cast<float>(o.y());
    rh.ray.org_z = static_cast<float>(o.z());
    rh.ray.dir_x = static_cast<float>(d.x());
    rh.ray.dir_y = static_cast<float>(d.y());
    rh.ray.dir_z = static_cast<float>(d.z());
    rh.ray.tnear = static_cast<float>(tmin);
    rh.ray.tfar = std::numeric_limits<float>::infinity();
    rh.ray.time = 0;
    rh.ray.mask = 0xFFFFFFFFu;
    rh.ray.id = 0;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    return rh;
  }

  RayHit cast(const Vector3d& o, const Vector3d& d, double tmin) const {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRayHit rh = make_ray(o, d, tmin);
    rtcIntersect1(scene, &ctx, &rh);
    RayHit h;
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return h;
    h.hit = true;
    h.face = rh.hit.primID;
    h.u = rh.hit.u;
    h.v = rh.hit.v;
    const Vector3d p0 = V.row(F(h.face, 0)), p1 = V.row(F(h.face, 1)), p2 = V.row(F(h.face, 2));
    h.point = (1.0 - h.u - h.v) * p0 + h.u * p1 + h.v * p2;
    h.distance = (h.point - o).dot(d);
    return h;
  }
};

RayScene::RayScene(const Eigen::Ref<const RowMatrixX3d>& V, const Eigen::Ref<const RowMatrixX3i>& F)
    : impl_(std::make_unique<Impl>()) {
  validate_mesh(V, F, "RayScene");
  impl_->V = V;
  impl_->F = F;
  impl_->scale = (V.colwise().maxCoeff() - V.colwise().minCoeff()).norm();
  Device& d = device();
  RTCScene scene = rtcNewScene(d.device);
  throw_if_error("rtcNewScene");
  impl_->scene = scene;
  // Robust traversal: a ray through a shared edge or vertex never slips between
  // the faces (picking on a closed mesh always hits).
  rtcSetSceneFlags(scene, RTC_SCENE_FLAG_ROBUST);
  rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_MEDIUM);
  RTCGeometry geom = rtcNewGeometry(d.device, RTC_GEOMETRY_TYPE_TRIANGLE);
  throw_if_error("rtcNewGeometry");
  auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                         3 * sizeof(float), static_cast<size_t>(V.rows())));
  auto* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                            3 * sizeof(unsigned), static_cast<size_t>(F.rows())));
  if (!vb || !ib) {
    rtcReleaseGeometry(geom);
    throw_if_error("rtcSetNewGeometryBuffer");
    throw DeviceError("rtcSetNewGeometryBuffer: out of memory");
  }
  for (Index v = 0; v < V.rows(); ++v)
    for (int c = 0; c < 3; ++c) vb[3 * v + c] = static_cast<float>(V(v, c));
  for (Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) ib[3 * f + c] = static_cast<unsigned>(F(f, c));
  rtcCommitGeometry(geom);
  rtcAttachGeometry(scene, geom);
  rtcReleaseGeometry(geom);
  rtcCommitScene(scene);
  throw_if_error("rtcCommitScene");
}

RayScene::~RayScene() = default;

Index RayScene::n_vertices() const { return impl_->V.rows(); }
Index RayScene::n_faces() const { return impl_->F.rows(); }

std::vector<RayHit> RayScene::intersect(const Eigen::Ref<const RowMatrixX3d>& origins,
                                        const Eigen::Ref<const RowMatrixX3d>& directions, double tmin) const {
  VPFFD_CHECK(origins.rows() == directions.rows(), "pick: ", origins.rows(), " origins but ", directions.rows(),
              " directions");
  VPFFD_CHECK(origins.allFinite() && directions.allFinite(), "pick: origins or directions contain NaN or Inf");
  VPFFD_CHECK(std::isfinite(tmin) && tmin >= 0, "pick: tmin must be finite and >= 0, got ", tmin);
  for (Index i = 0; i < directions.rows(); ++i)
    VPFFD_CHECK(directions.row(i).norm() > 0, "pick: direction ", i, " is zero");
  std::vector<RayHit> hits(static_cast<size_t>(origins.rows()));
  const Index n = origins.rows();
  CallErrors errors;
#ifdef _OPENMP
#pragma omp parallel if (n > 1024)
#endif
  {
#ifdef _OPENMP
#pragma omp for schedule(static)
#endif
    for (Index i = 0; i < n; ++i)
      hits[i] = impl_->cast(origins.row(i).transpose(), directions.row(i).transpose().normalized(), tmin);
    errors.collect();  // this thread's own Embree error slot
  }
  errors.throw_if_any("rtcIntersect1");
  return hits;
}

std::vector<std::uint8_t> RayScene::render(const RenderCamera& cam, const RenderOptions& opt,
                                           std::vector<float>* depth_out) const {
  const int W = opt.width, H = opt.height, S = opt.samples;
  VPFFD_CHECK(W > 0 && H > 0 && static_cast<Index>(W) * H <= (Index(1) << 28), "render: bad image size ", W, " x ",
              H);
  VPFFD_CHECK(S >= 1 && S <= 8, "render: samples must be in 1..8, got ", S);
  const Index nV = impl_->V.rows();
  VPFFD_CHECK(opt.vertex_colors.rows() == 0 || opt.vertex_colors.rows() == nV, "render: ",
              opt.vertex_colors.rows(), " vertex colours for ", nV, " vertices");
  VPFFD_CHECK(opt.normals.rows() == 0 || opt.normals.rows() == nV, "render: ", opt.normals.rows(), " normals for ",
              nV, " vertices");
  VPFFD_CHECK(opt.vertex_colors.allFinite() && opt.normals.allFinite() && opt.points.allFinite(),
              "render: colours, normals or points contain NaN or Inf");
  for (Index e = 0; e < opt.lines.rows(); ++e)
    for (int c = 0; c < 2; ++c)
      VPFFD_CHECK(opt.lines(e, c) >= 0 && opt.lines(e, c) < opt.points.rows(), "render: line ", e,
                  " refers to point ", opt.lines(e, c), ", there are ", opt.points.rows());
  const Frame fr = camera_frame(cam, W, H);
  const RowMatrixX3d N = opt.normals.rows() ? RowMatrixX3d(opt.normals) : vertex_normals(impl_->V, impl_->F);
  const bool colored = opt.vertex_colors.rows() > 0;

  // Two lights fixed to the camera: a head light and a key light from the upper
  // left, plus ambient; two-sided, so open surfaces show their inside too.
  const Vector3d key = (-0.5 * fr.r + 0.7 * fr.u - 0.6 * fr.f).normalized();
  std::vector<float> rgb(static_cast<size_t>(W) * H * 3);
  std::vector<float> depth(static_cast<size_t>(W) * H, std::numeric_limits<float>::infinity());
  const double inv = 1.0 / (S * S);

  CallErrors errors;
#ifdef _OPENMP
#pragma omp parallel
#endif
  {
#ifdef _OPENMP
#pragma omp for schedule(dynamic, 4)
#endif
    for (int y = 0; y < H; ++y) {
      RTCIntersectContext ctx;
      for (int x = 0; x < W; ++x) {
        Vector3d acc = Vector3d::Zero();
        float dmin = std::numeric_limits<float>::infinity();
        for (int sy = 0; sy < S; ++sy)
          for (int sx = 0; sx < S; ++sx) {
            const double px = x + (sx + 0.5) / S - 0.5, py = y + (sy + 0.5) / S - 0.5;
            const Vector3d dir = frame_ray(fr, W, H, px, py);
            rtcInitIntersectContext(&ctx);
            RTCRayHit rh = impl_->make_ray(fr.eye, dir, 0.0);
            rtcIntersect1(impl_->scene, &ctx, &rh);
            if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) {
              acc += opt.background;
              continue;
            }
            dmin = std::min(dmin, rh.ray.tfar);
            const Index f = rh.hit.primID;
            const double u = rh.hit.u, v = rh.hit.v, w = 1.0 - u - v;
            const int a = impl_->F(f, 0), b = impl_->F(f, 1), c = impl_->F(f, 2);
            Vector3d n = w * N.row(a) + u * N.row(b) + v * N.row(c);
            if (n.squaredNorm() == 0) n = Vector3d(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z);
            n.normalize();
            const bool back = n.dot(dir) > 0;
            if (back) n = -n;
            const Vector3d albedo =
                colored ? Vector3d(w * opt.vertex_colors.row(a) + u * opt.vertex_colors.row(b) +
                                   v * opt.vertex_colors.row(c))
                        : opt.base_color;
            const double head = std::max(0.0, -n.dot(dir)), kd = std::max(0.0, n.dot(key));
            const Vector3d h = (key - dir).normalized();
            const double spec = std::pow(std::max(0.0, n.dot(h)), 40.0);
            double light = 0.22 + 0.5 * head + 0.38 * kd;
            if (back) light *= 0.6;  // insides of open surfaces read as darker
            acc += albedo * light + Vector3d::Constant(0.18 * spec);
          }
        const size_t i = static_cast<size_t>(y) * W + x;
        const Vector3d col = acc * inv;
        for (int k = 0; k < 3; ++k) rgb[3 * i + k] = static_cast<float>(col[k]);
        depth[i] = dmin;
      }
    }
    errors.collect();  // this thread's own Embree error slot
  }
  errors.throw_if_any("rtcIntersect1");

  // Overlay: lattice lines and points, depth-tested against the surface; parts
  // behind it are drawn faintly so the lattice stays readable.
  const double near = 1e-6 * std::max(impl_->scale, (cam.target - cam.eye).norm());
  auto project = [&](const Vector3d& X, double& px, double& py, double& z) {
    const Vector3d d = X - fr.eye;
    z = d.dot(fr.f);
    px = (d.dot(fr.r) / z / (fr.tan_h * fr.aspect) + 1.0) * 0.5 * W - 0.5;
    py = (1.0 - d.dot(fr.u) / z / fr.tan_h) * 0.5 * H - 0.5;
  };
  auto plot = [&](int x, int y, const Vector3d& X, const Vector3d& color, double alpha) {
    if (x < 0 || y < 0 || x >= W || y >= H) return;
    const size_t i = static_cast<size_t>(y) * W + x;
    const double dist = (X - fr.eye).norm();
    const bool hidden = dist > depth[i] * (1.0 + 1e-4) + 1e-9 * impl_->scale;
    const double a = alpha * (hidden ? opt.hidden_alpha : 1.0);
    for (int k = 0; k < 3; ++k) rgb[3 * i + k] = static_cast<float>((1 - a) * rgb[3 * i + k] + a * color[k]);
  };
  for (Index e = 0; e < opt.lines.rows(); ++e) {
    Vector3d A = opt.points.row(opt.lines(e, 0)), B = opt.points.row(opt.lines(e, 1));
    double za = (A - fr.eye).dot(fr.f), zb = (B - fr.eye).dot(fr.f);
    if (za < near && zb < near) continue;
    // Clip against the near plane in 3D before projecting.
    if (za < near) A = A + (B - A) * ((near - za) / (zb - za));
    if (zb < near) B = B + (A - B) * ((near - zb) / (za - zb));
    double ax, ay, az, bx, by, bz;
    project(A, ax, ay, az);
    project(B, bx, by, bz);
    const double len = std::max(std::abs(bx - ax), std::abs(by - ay));
    const int steps = static_cast<int>(std::min(std::ceil(len), 1e5)) + 1;
    for (int s = 0; s <= steps; ++s) {
      const double t = static_cast<double>(s) / steps;  // screen-space fraction
      // Perspective-correct position along the 3D segment.
      const double q = (t / bz) / ((1 - t) / az + t / bz);
      plot(static_cast<int>(std::lround(ax + t * (bx - ax))), static_cast<int>(std::lround(ay + t * (by - ay))),
           A + q * (B - A), opt.line_color, 1.0);
    }
  }
  const double r = opt.point_radius;
  for (Index p = 0; p < opt.points.rows() && r > 0; ++p) {
    const Vector3d X = opt.points.row(p);
    double px, py, z;
    project(X, px, py, z);
    if (z < near) continue;
    const int R = static_cast<int>(std::ceil(r + 1));
    for (int dy = -R; dy <= R; ++dy)
      for (int dx = -R; dx <= R; ++dx) {
        const int x = static_cast<int>(std::lround(px)) + dx, y = static_cast<int>(std::lround(py)) + dy;
        const double dist = std::hypot(x - px, y - py);
        const double cover = std::clamp(r + 0.5 - dist, 0.0, 1.0);  // anti-aliased rim
        if (cover > 0) plot(x, y, X, opt.point_color, cover);
      }
  }

  std::vector<std::uint8_t> out(rgb.size());
  for (size_t i = 0; i < rgb.size(); ++i)
    out[i] = static_cast<std::uint8_t>(std::lround(std::clamp(rgb[i], 0.0f, 1.0f) * 255.0f));
  if (depth_out) *depth_out = std::move(depth);
  return out;
}

}  // namespace vpffd
