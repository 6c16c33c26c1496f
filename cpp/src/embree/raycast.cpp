// Picking and ray-cast rendering with Embree 3. Embree errors are read back on
// the thread that made the failing call and thrown as DeviceError by that call.
//
// Length: picking, refitting and rendering share RayScene::Impl (the Embree scene in
// its normalised frame, the double-precision hit refinement, the cached normals);
// split across files they would need that private state in a header.

#include "vpffd/render/raycast.h"

#include <Eigen/Geometry>  // cross products (Core alone declares them without a definition)
#include <embree3/rtcore.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <mutex>
#include <shared_mutex>
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
  // stableNorm: a scene 1e200 across (or 1e-200) has finite directions whose squared
  // lengths are not.
  const Vector3d d = cam.target - cam.eye;
  VPFFD_CHECK(d.stableNorm() > 0, "camera: eye and target coincide");
  fr.f = d / d.stableNorm();
  const double up = cam.up.stableNorm();
  const Vector3d r = up > 0 ? Vector3d(fr.f.cross(cam.up / up)) : Vector3d::Zero();
  VPFFD_CHECK(r.norm() > 1e-12, "camera: up is zero or parallel to the viewing direction");
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

// Embree works in float32 and rejects (asserts on, in Debian's build) ray
// origins beyond about 1.8e18; its vertices are floats too. So the scene lives
// in a normalised frame x' = (x - centre) / s with s a power of two at least
// half the bounding box's largest side: every vertex lies in [-1, 1]^3, the
// scaling is exact in binary, and any mesh whose box fits the double range is
// represented with float32's relative precision. Rays are carried into that
// frame in double (see prepare()), and hits are refined in double against the
// double triangle (refine()), so picking reports double-precision results.
namespace {

constexpr double kUnitRoundoff = 0.5 * std::numeric_limits<double>::epsilon();  // u = 2^-53
// Radius of the sphere around the normalised box [-1, 1]^3 (sqrt 3 = 1.7320...)
// outside which there is no geometry.
constexpr double kBoundRadius = 1.75;
// A ray whose position near the mesh is known (in double) only to worse than
// float32's grid on the normalised box is refused: Embree could not place it.
constexpr double kMaxPlacementError = 1.0 / (1 << 24);

// Barycentric weights (of A, B, C) of the point of segment [P, Q] nearest to X,
// as (1 - t) P + t Q; t in [0, 1].
double segment_parameter(const Vector3d& X, const Vector3d& P, const Vector3d& Q) {
  const Vector3d e = Q - P;
  const double ee = e.squaredNorm();
  if (!(ee > 0)) return 0.0;
  return std::clamp((X - P).dot(e) / ee, 0.0, 1.0);
}

// Weights (w0, w1, w2) >= 0 with w0 + w1 + w2 = 1 (up to one rounding) of the
// point of triangle ABC nearest to X. The interior case projects X onto the
// plane; otherwise the nearest of the three edges wins, so a degenerate
// (zero-area) triangle is handled by its edges.
Vector3d closest_on_triangle(const Vector3d& X, const Vector3d& A, const Vector3d& B, const Vector3d& C) {
  const Vector3d e1 = B - A, e2 = C - A, r = X - A;
  const double d11 = e1.dot(e1), d12 = e1.dot(e2), d22 = e2.dot(e2);
  const double det = d11 * d22 - d12 * d12;
  if (det > 1e-24 * d11 * d22) {
    const double b1 = (d22 * r.dot(e1) - d12 * r.dot(e2)) / det;
    const double b2 = (d11 * r.dot(e2) - d12 * r.dot(e1)) / det;
    if (b1 >= 0 && b2 >= 0 && b1 + b2 <= 1) return Vector3d(1.0 - b1 - b2, b1, b2);
  }
  const Vector3d* corner[3] = {&A, &B, &C};
  Vector3d best(1, 0, 0);
  double best_d = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 3; ++k) {
    const int i = k, j = (k + 1) % 3;
    const double t = segment_parameter(X, *corner[i], *corner[j]);
    const double dist = (X - ((1.0 - t) * *corner[i] + t * *corner[j])).squaredNorm();
    if (dist < best_d) {
      best_d = dist;
      best.setZero();
      best[i] = 1.0 - t;
      best[j] = t;
    }
  }
  return best;
}

}  // namespace

struct RayScene::Impl {
  RowMatrixX3d V;
  RowMatrixX3i F;
  RTCScene scene = nullptr;
  RTCGeometry geom = nullptr;  // the mesh, attached to scene
  // Queries share the scene; set_vertices waits for them and holds them off.
  mutable std::shared_mutex moving;
  double scale = 1.0;  // bounding box diagonal (world units)
  Vector3d centre = Vector3d::Zero();
  double s = 1.0, inv_s = 1.0;  // normalised frame: x' = (x - centre) * inv_s, s = 2^k
  ~Impl() {
    if (geom) rtcReleaseGeometry(geom);
    if (scene) rtcReleaseScene(scene);
  }

  // V in the normalised frame, as float32, into Embree's vertex buffer.
  void write_vertices();

  // Shading normals of V, made by the first render after a move (picking never
  // needs them); the vertex-face lists once, as the faces never change.
  std::mutex normals_mutex;
  std::unique_ptr<VertexFaces> vf;
  RowMatrixX3d normals;  // 0 rows: not made for the current V
  const RowMatrixX3d& shading_normals() {
    std::lock_guard<std::mutex> lock(normals_mutex);
    if (!vf) vf = std::make_unique<VertexFaces>(vertex_faces(F, V.rows()));
    if (normals.rows() != V.rows()) normals = vertex_normals(V, F, *vf);
    return normals;
  }

  // A ray carried into the normalised frame, ready for Embree.
  struct Prepared {
    enum Status { kMiss, kCast, kRefused } status = kMiss;
    Vector3d q;         // normalised: a point of the ray near its closest approach to the centre
    Vector3d u;         // unit direction (same in both frames)
    double tq = 0;      // world distance from the ray's origin to q along u (may be negative)
    double tau_s = 0;   // normalised parameter (from q along u) where Embree's ray starts
    double error = 0;   // bound on how far q may lie from the exact ray (normalised units)
  };

  // Bound on the distance from the ray of a point whose coordinates v were each
  // rounded once (|error_i| <= u |v_i|): only the part across the unit direction
  // u matters, |e_perp| <= sum_i u |v_i| sqrt(1 - u_i^2), so a coordinate along an
  // axis-aligned ray costs nothing.
  static double perpendicular_rounding(const Vector3d& v, const Vector3d& dir) {
    double e = 0;
    for (int c = 0; c < 3; ++c) e += std::abs(v[c]) * std::sqrt(std::max(0.0, 1.0 - dir[c] * dir[c]));
    return 1.01 * kUnitRoundoff * e;
  }

  // Moves the origin along the exact ray to near its closest approach to the
  // centre, clips the ray to the sphere of radius kBoundRadius and to
  // [tmin, inf). The ray is o + t d with the caller's d (never normalised
  // first: a rounded unit direction is a slightly rotated ray, off by u*|o|
  // near a far mesh). Each step q <- fma(t, d, q) lands on the exact ray up to
  // one rounding of the new point's coordinates, u*|q_new| across the ray; t's own error only
  // slides q along the ray. From a distance D the first step ends within about
  // u*D of the closest point, the second within u*|q| of it, so the total
  // placement error is ~u^2 D + u |centre| (world): exact for axis-aligned rays,
  // 1e-9 of the mesh size for an origin 1e23 mesh sizes away. Beyond
  // kMaxPlacementError the ray is refused.
  Prepared prepare(const Vector3d& o, const Vector3d& d, double tmin) const {
    Prepared p;
    int e = 0;
    std::frexp(d.cwiseAbs().maxCoeff(), &e);
    const Vector3d ds = d * std::ldexp(1.0, 1 - e);  // exact; max |ds_i| in [1, 2)
    const double dd = ds.squaredNorm(), dn = std::sqrt(dd);
    p.u = ds / dn;
    Vector3d q = o;
    double t_total = 0, err = 0;
    for (int k = 0; k < 64; ++k) {
      const Vector3d a = q - centre;
      // a . u / |ds| cannot overflow where a . ds / |ds|^2 could (|a| near the double maximum)
      const double t = -a.dot(p.u) / dn;
      if (!a.allFinite() || !std::isfinite(t)) {
        p.status = Prepared::kRefused;
        return p;
      }
      if (t == 0) break;
      Vector3d next;
      for (int c = 0; c < 3; ++c) next[c] = std::fma(t, ds[c], q[c]);
      if (!next.allFinite()) {
        p.status = Prepared::kRefused;
        return p;
      }
      q = next;
      t_total += t;
      err += perpendicular_rounding(q, p.u);
      if (std::abs(t) * dn <= s) break;  // the next step would be ~u times this one
    }
    p.tq = t_total * dn;
    p.q = (q - centre) * inv_s;
    p.error = (err + perpendicular_rounding(q - centre, p.u)) * inv_s;
    const double b = p.q.dot(p.u);
    const double rr = std::max(0.0, p.q.squaredNorm() - b * b);  // squared distance of the ray from the centre
    const double reach = kBoundRadius + p.error;
    if (!(rr <= reach * reach)) return p;  // misses the bounding sphere whatever the rounding
    if (!(p.error <= kMaxPlacementError)) {
      p.status = Prepared::kRefused;
      return p;
    }
    const double h = std::sqrt(std::max(0.0, kBoundRadius * kBoundRadius - rr));
    const double tau_origin = -p.tq * inv_s;  // the caller's origin, normalised parameter
    p.tau_s = std::max(-b - h, tau_origin + tmin * inv_s);
    if (!(p.tau_s <= -b + h)) return p;  // the part inside the sphere lies before tmin
    p.status = Prepared::kCast;
    return p;
  }

  // Embree's first hit of a prepared ray (normalised units from q + tau_s u).
  bool embree_hit(const Prepared& p, RTCRayHit& rh) const {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    const Vector3d start = p.q + p.tau_s * p.u;
    rh.ray.org_x = static_cast<float>(start.x());
    rh.ray.org_y = static_cast<float>(start.y());
    rh.ray.org_z = static_cast<float>(start.z());
    rh.ray.dir_x = static_cast<float>(p.u.x());
    rh.ray.dir_y = static_cast<float>(p.u.y());
    rh.ray.dir_z = static_cast<float>(p.u.z());
    rh.ray.tnear = 0.0f;
    rh.ray.tfar = std::numeric_limits<float>::infinity();
    rh.ray.time = 0;
    rh.ray.mask = 0xFFFFFFFFu;
    rh.ray.id = 0;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene, &ctx, &rh);
    return rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
  }

  Vector3d normalised(Index v) const { return (V.row(v).transpose() - centre) * inv_s; }

  // Embree (float32) chose the face; the hit is recomputed in double by
  // Moeller-Trumbore on the double triangle in the normalised frame. When the
  // double ray passes outside that face (Embree's float error let it through
  // an edge or a corner: the true hit is on the neighbour, within Embree's
  // error of the edge), the reported point is the point of the face nearest
  // to the ray's intersection with the face's plane: it lies on the shared
  // edge, i.e. on the surface, and its weights stay in [0, 1]. A ray (nearly)
  // parallel to the face's plane has no well-conditioned plane intersection;
  // then Embree's own point is snapped to the face the same way.
  RayHit refine(const Prepared& p, const RTCRayHit& rh, double tmin) const {
    RayHit h;
    h.hit = true;
    h.face = rh.hit.primID;
    const Vector3d A = normalised(F(h.face, 0)), B = normalised(F(h.face, 1)), C = normalised(F(h.face, 2));
    const Vector3d P = p.q + p.tau_s * p.u;
    const Vector3d e1 = B - A, e2 = C - A, pv = p.u.cross(e2);
    const double det = e1.dot(pv), area2 = e1.cross(e2).norm();
    Vector3d w;
    double tau;  // normalised parameter of the hit, from q
    if (std::abs(det) > 1e-12 * area2 && area2 > 0) {
      const double inv = 1.0 / det;
      const Vector3d tv = P - A, qv = tv.cross(e1);
      const double b1 = tv.dot(pv) * inv, b2 = p.u.dot(qv) * inv, t = e2.dot(qv) * inv;
      w = Vector3d(1.0 - b1 - b2, b1, b2);
      tau = p.tau_s + t;
      if (!(w.minCoeff() >= 0)) {
        const Vector3d X = P + t * p.u;
        w = closest_on_triangle(X, A, B, C);
        tau = (w[0] * A + w[1] * B + w[2] * C - p.q).dot(p.u);
      }
    } else {
      const Vector3d X = P + static_cast<double>(rh.ray.tfar) * p.u;
      w = closest_on_triangle(X, A, B, C);
      tau = (w[0] * A + w[1] * B + w[2] * C - p.q).dot(p.u);
    }
    h.u = w[1];
    h.v = w[2];
    const double w0 = 1.0 - h.u - h.v;
    h.point = w0 * V.row(F(h.face, 0)) + h.u * V.row(F(h.face, 1)) + h.v * V.row(F(h.face, 2));
    // The hit cannot lie before where the ray was allowed to start.
    h.distance = std::max(p.tq + tau * s, tmin);
    return h;
  }
};

namespace {

// The normalised frame of V (see above): centre, s = 2^k with every vertex in
// [-1, 1]^3, and the box diagonal.
void set_frame(const Eigen::Ref<const RowMatrixX3d>& V, Vector3d& centre, double& s, double& inv_s, double& scale) {
  const Vector3d lo = V.colwise().minCoeff(), hi = V.colwise().maxCoeff();
  const Vector3d ext = hi - lo;
  VPFFD_CHECK(ext.allFinite(), "RayScene: the mesh's bounding box (", lo.transpose(), ") to (", hi.transpose(),
              ") is wider than the largest double; scale the mesh down");
  scale = ext.norm();
  if (!std::isfinite(scale)) scale = std::numeric_limits<double>::max();
  centre = 0.5 * lo + 0.5 * hi;
  s = inv_s = 1.0;
  const double half = 0.5 * ext.maxCoeff();
  if (half > 0) {
    int e = 0;
    std::frexp(half, &e);  // half = m 2^e, m in [0.5, 1)
    s = std::ldexp(1.0, e);
    inv_s = std::ldexp(1.0, -e);
    VPFFD_CHECK(std::isfinite(inv_s) && inv_s > 0 && std::isnormal(half),
                "RayScene: the mesh is too small to ray cast (largest side ", 2 * half,
                " is below the normal double range); scale it up");
  }
}

}  // namespace

void RayScene::Impl::write_vertices() {
  auto* vb = static_cast<float*>(rtcGetGeometryBufferData(geom, RTC_BUFFER_TYPE_VERTEX, 0));
  throw_if_error("rtcGetGeometryBufferData");
  const Index n = V.rows();
#ifdef _OPENMP
#pragma omp parallel for schedule(static) if (n > 65536)
#endif
  for (Index v = 0; v < n; ++v)
    for (int c = 0; c < 3; ++c) vb[3 * v + c] = static_cast<float>((V(v, c) - centre[c]) * inv_s);
}

RayScene::RayScene(const Eigen::Ref<const RowMatrixX3d>& V, const Eigen::Ref<const RowMatrixX3i>& F,
                   bool fast_build, bool refit)
    : impl_(std::make_unique<Impl>()) {
  validate_mesh(V, F, "RayScene");
  impl_->V = V;
  impl_->F = F;
  set_frame(V, impl_->centre, impl_->s, impl_->inv_s, impl_->scale);
  Device& d = device();
  RTCScene scene = rtcNewScene(d.device);
  throw_if_error("rtcNewScene");
  impl_->scene = scene;
  // Robust traversal: a ray through a shared edge or vertex never slips between
  // the faces (picking on a closed mesh always hits). A refittable geometry
  // needs Embree's two-level structure (low scene quality) in a dynamic scene:
  // without the dynamic flag Embree 3.13 rebuilds the geometry's BVH on every
  // commit. Measured on 1.3 M triangles (CPU time): a refit costs ~0.3 of a low
  // quality build, a refit scene's first (SAH) build ~4 low quality builds.
  rtcSetSceneFlags(scene, refit ? RTC_SCENE_FLAG_ROBUST | RTC_SCENE_FLAG_DYNAMIC : RTC_SCENE_FLAG_ROBUST);
  rtcSetSceneBuildQuality(scene, fast_build || refit ? RTC_BUILD_QUALITY_LOW : RTC_BUILD_QUALITY_MEDIUM);
  RTCGeometry geom = rtcNewGeometry(d.device, RTC_GEOMETRY_TYPE_TRIANGLE);
  throw_if_error("rtcNewGeometry");
  impl_->geom = geom;  // released by ~Impl
  // In the two-level structure the geometry's own quality decides its BVH:
  // left at the default (medium) a "fast" build would be a full SAH build.
  if (refit || fast_build) rtcSetGeometryBuildQuality(geom, refit ? RTC_BUILD_QUALITY_REFIT : RTC_BUILD_QUALITY_LOW);
  auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                         3 * sizeof(float), static_cast<size_t>(V.rows())));
  auto* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                            3 * sizeof(unsigned), static_cast<size_t>(F.rows())));
  if (!vb || !ib) {
    throw_if_error("rtcSetNewGeometryBuffer");
    throw DeviceError("rtcSetNewGeometryBuffer: out of memory");
  }
  impl_->write_vertices();
  for (Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) ib[3 * f + c] = static_cast<unsigned>(F(f, c));
  rtcCommitGeometry(geom);
  rtcAttachGeometry(scene, geom);
  rtcCommitScene(scene);
  throw_if_error("rtcCommitScene");
}

void RayScene::set_vertices(const Eigen::Ref<const RowMatrixX3d>& V) {
  VPFFD_CHECK(V.rows() == impl_->V.rows(), "RayScene.set_vertices: ", V.rows(), " vertices for a scene of ",
              impl_->V.rows(), " (the faces stay, so the count must too)");
  for (Index v = 0; v < V.rows(); ++v)
    VPFFD_CHECK(std::isfinite(V(v, 0)) && std::isfinite(V(v, 1)) && std::isfinite(V(v, 2)),
                "RayScene.set_vertices: vertex ", v, " has a non-finite coordinate (", V(v, 0), ", ", V(v, 1), ", ",
                V(v, 2), ")");
  // Checked before anything changes: a refused mesh leaves the scene as it was.
  Vector3d centre;
  double s, inv_s, scale;
  set_frame(V, centre, s, inv_s, scale);
  std::unique_lock<std::shared_mutex> lock(impl_->moving);
  impl_->V = V;
  impl_->centre = centre;
  impl_->s = s;
  impl_->inv_s = inv_s;
  impl_->scale = scale;
  impl_->normals.resize(0, 3);
  impl_->write_vertices();
  rtcUpdateGeometryBuffer(impl_->geom, RTC_BUFFER_TYPE_VERTEX, 0);
  rtcCommitGeometry(impl_->geom);
  rtcCommitScene(impl_->scene);
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
    VPFFD_CHECK(directions.row(i).cwiseAbs().maxCoeff() > 0, "pick: direction ", i, " is zero");
  std::shared_lock<std::shared_mutex> lock(impl_->moving);
  std::vector<RayHit> hits(static_cast<size_t>(origins.rows()));
  const Index n = origins.rows();
  CallErrors errors;
  std::atomic<bool> refused{false};
#ifdef _OPENMP
#pragma omp parallel if (n > 1024)
#endif
  {
#ifdef _OPENMP
#pragma omp for schedule(static)
#endif
    for (Index i = 0; i < n; ++i) {
      const Impl::Prepared p = impl_->prepare(origins.row(i).transpose(), directions.row(i).transpose(), tmin);
      if (p.status == Impl::Prepared::kRefused) {
        refused.store(true);
        continue;
      }
      RTCRayHit rh;
      if (p.status == Impl::Prepared::kCast && impl_->embree_hit(p, rh)) hits[i] = impl_->refine(p, rh, tmin);
    }
    errors.collect();  // this thread's own Embree error slot
  }
  errors.throw_if_any("rtcIntersect1");
  if (refused.load())
    for (Index i = 0; i < n; ++i) {
      const Impl::Prepared p = impl_->prepare(origins.row(i).transpose(), directions.row(i).transpose(), tmin);
      VPFFD_CHECK(p.status != Impl::Prepared::kRefused, "pick: ray ", i, " (origin ", origins.row(i),
                  ", direction ", directions.row(i), ") starts too far from the mesh (box centre ",
                  impl_->centre.transpose(), ", size ", impl_->scale,
                  "): double precision cannot place it near the mesh to float32 accuracy; start it closer");
    }
  return hits;
}

std::vector<std::uint8_t> RayScene::render(const RenderCamera& cam, const RenderOptions& opt,
                                           std::vector<float>* depth_out) const {
  const int W = opt.width, H = opt.height, S = opt.samples;
  std::shared_lock<std::shared_mutex> lock(impl_->moving);
  VPFFD_CHECK(W > 0 && H > 0 && static_cast<Index>(W) * H <= (Index(1) << 28), "render: bad image size ", W, " x ",
              H);
  VPFFD_CHECK(S >= 1 && S <= 8, "render: samples must be in 1..8, got ", S);
  VPFFD_CHECK(opt.line_alpha >= 0 && opt.line_alpha <= 1, "render: line_alpha must be in [0, 1], got ", opt.line_alpha);
  VPFFD_CHECK(opt.hidden_alpha >= 0 && opt.hidden_alpha <= 1, "render: hidden_alpha must be in [0, 1], got ",
              opt.hidden_alpha);
  VPFFD_CHECK(opt.line_width > 0 && opt.line_width <= 64, "render: line_width must be in (0, 64] pixels, got ",
              opt.line_width);
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
  const RowMatrixX3d& N = opt.normals.rows() ? opt.normals : impl_->shading_normals();
  const bool colored = opt.vertex_colors.rows() > 0;

  // Two lights fixed to the camera: a head light and a key light from the upper
  // left, plus ambient; two-sided, so open surfaces show their inside too.
  const Vector3d key = (-0.5 * fr.r + 0.7 * fr.u - 0.6 * fr.f).normalized();
  std::vector<float> rgb(static_cast<size_t>(W) * H * 3);
  std::vector<float> depth(static_cast<size_t>(W) * H, std::numeric_limits<float>::infinity());
  const double inv = 1.0 / (S * S);
  // A ray the normalised frame cannot carry refuses the image: never drawn as background.
  std::atomic<bool> refused{false};

  // One shaded sample: colour, and the distance (inf on the background).
  auto sample = [&](double px, double py, Vector3d& col) -> float {
    const Vector3d dir = frame_ray(fr, W, H, px, py);
    const Impl::Prepared p = impl_->prepare(fr.eye, dir, 0.0);
    if (p.status == Impl::Prepared::kRefused) refused.store(true);
    RTCRayHit rh;
    if (p.status != Impl::Prepared::kCast || !impl_->embree_hit(p, rh)) {
      col = opt.background;
      return std::numeric_limits<float>::infinity();
    }
    const Index f = rh.hit.primID;
    const double u = rh.hit.u, v = rh.hit.v, w = 1.0 - u - v;
    const int a = impl_->F(f, 0), b = impl_->F(f, 1), c = impl_->F(f, 2);
    Vector3d n = w * N.row(a) + u * N.row(b) + v * N.row(c);
    if (n.squaredNorm() == 0) n = Vector3d(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z);
    n.normalize();
    const bool back = n.dot(dir) > 0;
    if (back) n = -n;
    const Vector3d albedo = colored ? Vector3d(w * opt.vertex_colors.row(a) + u * opt.vertex_colors.row(b) +
                                               v * opt.vertex_colors.row(c))
                                    : opt.base_color;
    const double head = std::max(0.0, -n.dot(dir)), kd = std::max(0.0, n.dot(key));
    const Vector3d h = (key - dir).normalized();
    const double spec = std::pow(std::max(0.0, n.dot(h)), 40.0);
    double light = 0.22 + 0.5 * head + 0.38 * kd;
    if (back) light *= 0.6;  // insides of open surfaces read as darker
    col = albedo * light + Vector3d::Constant(0.18 * spec);
    return static_cast<float>(p.tq + (p.tau_s + rh.ray.tfar) * impl_->s);
  };

  CallErrors errors;
  // Pass 1: one ray through each pixel centre. Pass 2 (samples > 1): S x S rays
  // in every pixel where anti-aliasing can show, i.e. next to a pixel that
  // differs from it (background/surface, a depth jump of an occluding contour,
  // or a colour step); elsewhere the centre ray's smooth shading stands for the
  // S x S average. With adaptive = false every pixel gets S x S rays.
  std::vector<unsigned char> refine(static_cast<size_t>(W) * H, S > 1 && !opt.adaptive ? 1 : 0);
  auto store = [&](size_t i, float dist, const Vector3d& col) {
    depth[i] = dist;
    for (int k = 0; k < 3; ++k) rgb[3 * i + k] = static_cast<float>(col[k]);
  };
  // Each pass visits every pixel (x, y, flat index i) once, rows shared out
  // among the threads of the enclosing parallel region.
  auto each_pixel = [&](auto&& visit) {
#ifdef _OPENMP
#pragma omp for schedule(dynamic, 4)
#endif
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) visit(x, y, static_cast<size_t>(y) * W + x);
  };
  // A pixel differs from a 4-neighbour j when one is background and the other
  // not, across a depth jump of 2 %, or across a colour step of 0.03.
  auto differs = [&](size_t i, size_t j) {
    const float d0 = depth[i], d1 = depth[j];
    if (std::isinf(d0) != std::isinf(d1)) return true;
    if (!std::isinf(d0) && std::abs(d0 - d1) > 0.02f * std::min(d0, d1)) return true;
    for (int c = 0; c < 3; ++c)
      if (std::abs(rgb[3 * i + c] - rgb[3 * j + c]) > 0.03f) return true;
    return false;
  };
#ifdef _OPENMP
#pragma omp parallel
#endif
  {
    each_pixel([&](int x, int y, size_t i) {
      if (refine[i]) return;
      Vector3d col;
      const float dist = sample(x, y, col);
      store(i, dist, col);
    });
    if (S > 1 && opt.adaptive)  // (the implicit barrier above: all centres are in)
      each_pixel([&](int x, int y, size_t i) {
        refine[i] = (x > 0 && differs(i, i - 1)) || (x + 1 < W && differs(i, i + 1)) ||
                    (y > 0 && differs(i, i - W)) || (y + 1 < H && differs(i, i + W));
      });
    if (S > 1)
      each_pixel([&](int x, int y, size_t i) {
        if (!refine[i]) return;
        Vector3d acc = Vector3d::Zero(), col;
        float dmin = std::numeric_limits<float>::infinity();
        for (int sy = 0; sy < S; ++sy)
          for (int sx = 0; sx < S; ++sx) {
            dmin = std::min(dmin, sample(x + (sx + 0.5) / S - 0.5, y + (sy + 0.5) / S - 0.5, col));
            acc += col;
          }
        store(i, dmin, acc * inv);
      });
    errors.collect();  // this thread's own Embree error slot
  }
  errors.throw_if_any("rtcIntersect1");
  VPFFD_CHECK(!refused.load(), "render: the camera (eye ", cam.eye.transpose(),
              ") is too far from the mesh (box centre ", impl_->centre.transpose(), ", size ", impl_->scale,
              ") for double precision to place its rays to float32 accuracy near the mesh; move it closer");

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
    // Anti-aliased: one step per pixel column (or row, for a steep line), and
    // across it the pixels within half the width, weighted by their coverage.
    const bool steep = std::abs(by - ay) > std::abs(bx - ax);
    const double a0 = steep ? ay : ax, a1 = steep ? by : bx, b0 = steep ? ax : ay, b1 = steep ? bx : by;
    if (!(std::abs(a1 - a0) > 1e-9)) continue;
    const double hw = 0.5 * opt.line_width;
    const int reach = static_cast<int>(std::ceil(hw + 1.0));
    const double extent = steep ? H : W;
    const double lo = std::max(std::min(a0, a1), -1.0 - reach), hi = std::min(std::max(a0, a1), extent + reach);
    const double slope = (b1 - b0) / (a1 - a0), norm = std::sqrt(1.0 + slope * slope);
    for (int m = static_cast<int>(std::ceil(lo)); m <= static_cast<int>(std::floor(hi)); ++m) {
      const double t = (m - a0) / (a1 - a0);  // screen-space fraction
      const double c = b0 + t * (b1 - b0);
      // Perspective-correct position along the 3D segment.
      const double q = (t / bz) / ((1 - t) / az + t / bz);
      const Vector3d X = A + q * (B - A);
      for (int k = static_cast<int>(std::floor(c)) - reach; k <= static_cast<int>(std::ceil(c)) + reach; ++k) {
        const double dist = std::abs(k - c) / norm;  // perpendicular distance to the line, pixels
        const double cover = std::clamp(hw + 0.5 - dist, 0.0, 1.0);
        if (cover > 0) plot(steep ? k : m, steep ? m : k, X, opt.line_color, opt.line_alpha * cover);
      }
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
