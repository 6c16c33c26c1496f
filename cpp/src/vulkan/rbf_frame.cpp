// VulkanRbfFrame: the RBF regions frame (shaders/rbf_regions.comp) on a device shared
// with the other Vulkan frames: its own buffers, descriptor set, pipeline, command
// buffer and fence. Set-up checks the plain arrays and uploads the labels, rest points,
// basis and float data once; a frame is: upload copy of the K maps -> one dispatch ->
// copies of vertices, normals and base vertices to the host, one submission of a
// command buffer recorded once.

#include "vpffd/backend/vulkan_rbf.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <mutex>
#include <vector>

#include "context.h"
#include "deformer_impl.h"  // put_reals, ms_since
#include "pipelines.h"
#include "shaders/rbf_regions_layout.h"
#include "vk_handle.h"
#include "vpffd/multires/rbf_regions.h"  // detail::check_affine: the CPU frame's checks and messages
#include "vpffd/shaders/rbf_regions_spirv.h"

namespace vpffd::vulkan {

using detail::Buffer;

struct VulkanRbfFrame::Impl {
  std::shared_ptr<detail::Device> dev;  // first: destroyed last
  VkDevice d = VK_NULL_HANDLE;
  Precision precision = Precision::Float64;
  bool ff = false;
  Index nv = 0, K = 0, nf = 0;
  std::uint32_t groups = 1;
  Vector3d origin = Vector3d::Zero();
  double scale = 1.0;

  enum Buf { bMaps, bLab, bPts, bBasis, bData, bX, bN, bB, kNumBuf };
  static_assert(bMaps == VPFFD_RB_B_MAPS && bLab == VPFFD_RB_B_LAB && bPts == VPFFD_RB_B_PTS &&
                    bBasis == VPFFD_RB_B_BASIS && bData == VPFFD_RB_B_DATA && bX == VPFFD_RB_B_X &&
                    bN == VPFFD_RB_B_N && bB == VPFFD_RB_B_B && kNumBuf == VPFFD_RB_B_COUNT,
                "the bindings of shaders/rbf_regions_layout.h");
  Buffer buf[kNumBuf];
  Buffer up_maps, rb_X, rb_N, rb_B;

  detail::ComputePipelines pl;
  Owned<VkCommandPool> cmd_pool;
  VkCommandBuffer frame_cb = VK_NULL_HANDLE;  // recorded once, submitted every frame
  Owned<VkFence> fence;
  Owned<VkQueryPool> queries;

  mutable std::mutex mutex;  // one frame at a time
  bool pending = false;      // a submission whose wait failed may still run
  FrameTimings timings;

  ~Impl() {
    if (d && pending) vkWaitForFences(d, 1, &fence.get(), VK_TRUE, UINT64_MAX);
  }

  void build(const RbfRegionsView& s, const std::string& selector, Precision wanted);
  void record_frame();
};

void VulkanRbfFrame::Impl::record_frame() {
  frame_cb = detail::allocate_command_buffer(d, cmd_pool.get());
  VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  detail::check(vkBeginCommandBuffer(frame_cb, &bi), "vkBeginCommandBuffer");
  const VkPipelineStageFlags cs = VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, tr = VK_PIPELINE_STAGE_TRANSFER_BIT;
  auto barrier = [&](VkAccessFlags src, VkAccessFlags dst, VkPipelineStageFlags from, VkPipelineStageFlags to) {
    VkMemoryBarrier mb{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    mb.srcAccessMask = src;
    mb.dstAccessMask = dst;
    vkCmdPipelineBarrier(frame_cb, from, to, 0, 1, &mb, 0, nullptr, 0, nullptr);
  };
  if (dev->timestamps) {
    vkCmdResetQueryPool(frame_cb, queries.get(), 0, 2);
    vkCmdWriteTimestamp(frame_cb, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, queries.get(), 0);
  }
  // The previous frame's copies read the outputs this dispatch overwrites, and its
  // dispatch read the maps the copy below overwrites.
  barrier(VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_SHADER_READ_BIT,
          VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT, tr | cs, cs | tr);
  const VkBufferCopy cp{0, 0, 8 * VkDeviceSize(RB_MAP_REALS) * VkDeviceSize(K)};
  vkCmdCopyBuffer(frame_cb, up_maps.handle(), buf[bMaps].handle(), 1, &cp);
  barrier(VK_ACCESS_TRANSFER_WRITE_BIT, VK_ACCESS_SHADER_READ_BIT, tr, cs);
  vkCmdBindPipeline(frame_cb, VK_PIPELINE_BIND_POINT_COMPUTE, pl.pipes[kRbfRegions].get());
  vkCmdBindDescriptorSets(frame_cb, VK_PIPELINE_BIND_POINT_COMPUTE, pl.layout.get(), 0, 1, &pl.set, 0, nullptr);
  vkCmdDispatch(frame_cb, groups, 1, 1);
  barrier(VK_ACCESS_SHADER_WRITE_BIT, VK_ACCESS_TRANSFER_READ_BIT, cs, tr);
  const VkBufferCopy cx{0, 0, 12 * VkDeviceSize(nv)};
  vkCmdCopyBuffer(frame_cb, buf[bX].handle(), rb_X.handle(), 1, &cx);
  vkCmdCopyBuffer(frame_cb, buf[bN].handle(), rb_N.handle(), 1, &cx);
  vkCmdCopyBuffer(frame_cb, buf[bB].handle(), rb_B.handle(), 1, &cx);
  barrier(VK_ACCESS_TRANSFER_WRITE_BIT, VK_ACCESS_HOST_READ_BIT, tr, VK_PIPELINE_STAGE_HOST_BIT);
  if (dev->timestamps) vkCmdWriteTimestamp(frame_cb, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, queries.get(), 1);
  detail::check(vkEndCommandBuffer(frame_cb), "vkEndCommandBuffer");
}

void VulkanRbfFrame::Impl::build(const RbfRegionsView& s, const std::string& selector, Precision wanted) {
  // The arrays first: a bad setting is refused before Vulkan starts.
  nv = s.n_vertices;
  K = s.n_regions;
  VPFFD_CHECK(nv > 0, "VulkanRbfFrame: no vertices");
  VPFFD_CHECK(K >= 1 && K <= kMaxRbfRegions, "VulkanRbfFrame: ", K, " handle regions, expected 1..", kMaxRbfRegions);
  VPFFD_CHECK(s.labels && s.basis && s.foot && s.su && s.sv && s.fine && s.normals && s.base && s.d && s.coef,
              "VulkanRbfFrame: a null array");
  std::vector<std::int32_t> lab(2 * size_t(nv));
  nf = 0;
  for (Index i = 0; i < nv; ++i) {
    const std::int32_t l = s.labels[i];
    VPFFD_CHECK(l >= -1 && l <= K, "VulkanRbfFrame: vertex ", i, " has label ", l, ", expected -1..", K);
    lab[2 * i] = l;
    lab[2 * i + 1] = l == 0 ? static_cast<std::int32_t>(nf++) : -1;
  }
  VPFFD_CHECK(nf > 0, "VulkanRbfFrame: no free vertex");
  // 16 K nf reals, RB_PTS V reals and 3V floats are indexed with 32-bit ints in the shader.
  VPFFD_CHECK(16 * K * nf < (Index(1) << 31) && Index(RB_PTS) * nv < (Index(1) << 31) &&
                  Index(RB_ROWS) * nv < (Index(1) << 31),
              "VulkanRbfFrame: the setting is too large for 32-bit device indices");
  for (Index k = 0; k < 16 * K * nf; ++k)
    VPFFD_CHECK(std::isfinite(s.basis[k]), "VulkanRbfFrame: basis entry ", k, " is not finite");
  for (const double* a : {s.foot, s.su, s.sv, s.fine, s.normals, s.base})
    for (Index k = 0; k < 3 * nv; ++k) VPFFD_CHECK(std::isfinite(a[k]), "VulkanRbfFrame: a rest datum is not finite");

  // Device units: relative to the box centre of the rest fine and base vertices, in the
  // power of two nearest to its half diagonal (a power of two: the scaling is exact).
  Vector3d lo = Vector3d::Constant(INFINITY), hi = Vector3d::Constant(-INFINITY);
  for (Index i = 0; i < nv; ++i)
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min({lo[a], s.fine[3 * i + a], s.base[3 * i + a]});
      hi[a] = std::max({hi[a], s.fine[3 * i + a], s.base[3 * i + a]});
    }
  origin = 0.5 * (lo + hi);
  {
    const double half = 0.5 * (hi - lo).norm();
    scale = std::isfinite(half) && half > 0 ? std::exp2(std::round(std::log2(half))) : 1.0;
  }
  // Rest points (SoA rows of V): free vertices S, S_u, S_v, q; the others p, 0, 0, q.
  std::vector<double> pts(size_t(RB_PTS) * nv, 0.0);
  std::vector<float> data(size_t(RB_ROWS) * nv);
  for (Index i = 0; i < nv; ++i) {
    const bool free_v = lab[2 * i] == 0;
    for (int a = 0; a < 3; ++a) {
      pts[size_t(RB_S + a) * nv + i] = ((free_v ? s.foot : s.fine)[3 * i + a] - origin[a]) / scale;
      if (free_v) {
        pts[size_t(RB_SU + a) * nv + i] = s.su[3 * i + a] / scale;
        pts[size_t(RB_SV + a) * nv + i] = s.sv[3 * i + a] / scale;
      }
      pts[size_t(RB_Q + a) * nv + i] = (s.base[3 * i + a] - origin[a]) / scale;
      data[size_t(RB_NRM + a) * nv + i] = static_cast<float>(s.normals[3 * i + a]);
    }
    data[size_t(RB_D) * nv + i] = static_cast<float>(s.d[i] / scale);
    // a, b multiply tangents (now in scale units): a, b times scale; g the unit normal.
    for (int k = 0; k < 6; ++k)
      data[size_t(RB_COEF + k) * nv + i] =
          static_cast<float>(k % 3 == 2 ? s.coef[6 * i + k] : s.coef[6 * i + k] * scale);
  }
  for (float x : data)
    VPFFD_CHECK(std::isfinite(x), "VulkanRbfFrame: the displacements or normal coefficients exceed float32's "
                                  "range in device units (or are not finite)");
  // The basis in device units: a world 4-vector alpha = (x, w) multiplied by a
  // displacement [M | t] gives M x + t w; with alpha_dev = ((x - o w) / s, w) and
  // D_dev = [M | (M o + t) / s] (see deform), D_dev alpha_dev = (M x + t w) / s: the
  // same sums in device units, for points and tangents alike.
  std::vector<double> basis(16 * size_t(K) * nf);
  for (size_t g = 0; g < basis.size() / 4; ++g) {
    const double* src = s.basis + 4 * g;
    double* dst = basis.data() + 4 * g;
    for (int a = 0; a < 3; ++a) dst[a] = (src[a] - origin[a] * src[3]) / scale;
    dst[3] = src[3];
  }

  dev = detail::open_device(selector);
  d = dev->handle;
  if (wanted == Precision::Float64 && !dev->info.float64)
    throw BackendUnavailableError("vulkan: device " + dev->info.name +
                                  " has no shaderFloat64: use precision 'float-float' or 'auto'");
  precision = wanted == Precision::Auto ? (dev->info.float64 ? Precision::Float64 : Precision::FloatFloat) : wanted;
  ff = precision == Precision::FloatFloat;
  std::vector<double> pts_dev(pts.size()), basis_dev(basis.size());  // 8 bytes per real in either precision
  detail::put_reals(pts_dev.data(), pts.data(), pts.size(), ff);
  detail::put_reals(basis_dev.data(), basis.data(), basis.size(), ff);

  // A zero-entry buffer is not allowed: at least 8 bytes each.
  const size_t map_bytes = 8 * size_t(RB_MAP_REALS) * size_t(K);
  auto mk = [&](Buf i, size_t bytes, const char* what) {
    buf[i] = Buffer(*dev, std::max<size_t>(bytes, 8), Buffer::DeviceLocal, what);
  };
  mk(bMaps, map_bytes, "RBF region maps");
  mk(bLab, 4 * lab.size(), "RBF labels");
  mk(bPts, 8 * pts_dev.size(), "RBF rest points");
  mk(bBasis, 8 * basis_dev.size(), "RBF basis");
  mk(bData, 4 * data.size(), "RBF frame data");
  mk(bX, 12 * nv, "RBF vertices");
  mk(bN, 12 * nv, "RBF normals");
  mk(bB, 12 * nv, "RBF base vertices");
  up_maps = Buffer(*dev, map_bytes, Buffer::Upload, "RBF region maps (upload)");
  rb_X = Buffer(*dev, 12 * nv, Buffer::Readback, "RBF vertices (read-back)");
  rb_N = Buffer(*dev, 12 * nv, Buffer::Readback, "RBF normals (read-back)");
  rb_B = Buffer(*dev, 12 * nv, Buffer::Readback, "RBF base vertices (read-back)");

  cmd_pool = detail::create_command_pool(*dev);
  fence = detail::create_fence(d);
  queries = detail::create_timestamp_queries(*dev, 2);

  // One-time upload through staging buffers, one submission.
  {
    const VkCommandBuffer cb = detail::allocate_command_buffer(d, cmd_pool.get());
    VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    detail::check(vkBeginCommandBuffer(cb, &bi), "vkBeginCommandBuffer");
    std::vector<Buffer> staging;
    auto upload = [&](Buf i, const void* src, size_t bytes) {
      if (bytes == 0) return;
      staging.emplace_back(*dev, bytes, Buffer::Upload, "staging");
      std::memcpy(staging.back().mapped(), src, bytes);
      const VkBufferCopy c{0, 0, bytes};
      vkCmdCopyBuffer(cb, staging.back().handle(), buf[i].handle(), 1, &c);
    };
    upload(bLab, lab.data(), 4 * lab.size());
    upload(bPts, pts_dev.data(), 8 * pts_dev.size());
    upload(bBasis, basis_dev.data(), 8 * basis_dev.size());
    upload(bData, data.data(), 4 * data.size());
    detail::check(vkEndCommandBuffer(cb), "vkEndCommandBuffer");
    detail::submit_and_wait(*dev, fence.get(), pending, &cb, 1);
    vkFreeCommandBuffers(d, cmd_pool.get(), 1, &cb);
  }

  const std::int32_t spec[2] = {static_cast<std::int32_t>(nv), static_cast<std::int32_t>(K)};
  detail::create_compute_pipelines(d, buf, kNumBuf, 0, spec, 2, ff ? kRbfRegionsShadersFF : kRbfRegionsShaders64,
                                   kRbfRegionsPipes, pl);
  groups = static_cast<std::uint32_t>(
      std::clamp<Index>((nv + VPFFD_RB_GROUP - 1) / VPFFD_RB_GROUP, 1, dev->limits.maxComputeWorkGroupCount[0]));
  record_frame();
}

// ---- public API ----------------------------------------------------------------

VulkanRbfFrame::VulkanRbfFrame(const RbfRegionsView& s, const std::string& device, Precision precision)
    : impl_(std::make_unique<Impl>()) {
  impl_->build(s, device, precision);
}

VulkanRbfFrame::~VulkanRbfFrame() = default;

Index VulkanRbfFrame::n_vertices() const { return impl_->nv; }
Index VulkanRbfFrame::n_regions() const { return impl_->K; }
Index VulkanRbfFrame::n_free() const { return impl_->nf; }
const DeviceInfo& VulkanRbfFrame::device() const { return impl_->dev->info; }
Precision VulkanRbfFrame::precision() const { return impl_->precision; }
FrameTimings VulkanRbfFrame::last_timings() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->timings;
}
const Vector3d& VulkanRbfFrame::origin() const { return impl_->origin; }
double VulkanRbfFrame::scale() const { return impl_->scale; }

RbfDeviceFrame VulkanRbfFrame::deform(const std::vector<Eigen::Matrix4d>& T) {
  RbfDeviceFrame out;
  out.vertices.resize(impl_->nv, 3);
  out.normals.resize(impl_->nv, 3);
  out.base.resize(impl_->nv, 3);
  deform(T, out.vertices.data(), out.normals.data(), out.base.data());
  return out;
}

void VulkanRbfFrame::deform(const std::vector<Eigen::Matrix4d>& T, double* vertices, double* normals, double* base) {
  const auto t_start = std::chrono::steady_clock::now();
  Impl& m = *impl_;
  // The CPU frame's checks and messages (RbfRegions::check_transforms).
  VPFFD_CHECK(Index(T.size()) == m.K, "RBF regions: ", T.size(), " transforms for ", m.K, " handle regions");
  for (Index k = 0; k < m.K; ++k) vpffd::detail::check_affine(T[k], k + 1);
  // The maps in device units y = (x - o) / s: a displacement [M | t] becomes
  // [M | (M o + t) / s], the map [A | t] becomes [A | (A o + t - o) / s]; the cofactor
  // only turns normals, which are unit either way.
  using M34 = Eigen::Matrix<double, 3, 4>;
  auto to_device = [&](const M34& D, bool map) {
    M34 out = D;
    out.col(3) = (D.leftCols<3>() * m.origin + D.col(3) - (map ? m.origin : Vector3d(Vector3d::Zero()))) / m.scale;
    return out;
  };
  const M34 I34 = M34::Identity();
  std::vector<double> maps(size_t(RB_MAP_REALS) * m.K);
  for (Index k = 0; k < m.K; ++k) {
    // As RbfRegions::deform: D_1 multiplies alpha_1, D_{k+1} - D_1 multiplies alpha_{k+1}.
    const M34 D = k == 0 ? M34(T[0].topRows<3>() - I34) : M34(T[k].topRows<3>() - T[0].topRows<3>());
    const M34 Dd = to_device(D, false), Td = to_device(T[k].topRows<3>(), true);
    const Matrix3d A = T[k].topLeftCorner<3, 3>();
    const Matrix3d cof = A.determinant() * A.inverse().transpose();
    double* o = maps.data() + size_t(RB_MAP_REALS) * k;
    for (int a = 0; a < 3; ++a)
      for (int c = 0; c < 4; ++c) {
        o[RB_MAP_D + 4 * a + c] = Dd(a, c);
        o[RB_MAP_T + 4 * a + c] = Td(a, c);
      }
    for (int a = 0; a < 3; ++a)
      for (int c = 0; c < 3; ++c) o[RB_MAP_COF + 3 * a + c] = cof(a, c);
    // Device values up to 2^100, as VulkanSubdivFrame's control points: the sums
    // (basis and rest points of a few units) stay far from float32's 3.4e38, so no
    // vertex becomes Inf on the device silently.
    constexpr double kMaxDevice = 0x1p100;
    for (int j = 0; j < RB_MAP_REALS; ++j)
      VPFFD_CHECK(std::isfinite(o[j]) && std::abs(o[j]) <= kMaxDevice, "VulkanRbfFrame: the transform of handle "
                  "region ", k + 1, " moves the mesh beyond float32's range on the device (more than 2^100 units of ",
                  m.scale, " from the rest box centre)");
  }
  std::lock_guard<std::mutex> lock(m.mutex);
  detail::put_reals(m.up_maps.mapped(), maps.data(), maps.size(), m.ff);
  detail::submit_and_wait(*m.dev, m.fence.get(), m.pending, &m.frame_cb, 1);
  FrameTimings tm;
  if (m.dev->timestamps) {
    std::uint64_t ts[2] = {};
    detail::check(vkGetQueryPoolResults(m.d, m.queries.get(), 0, 2, sizeof(ts), ts, sizeof(std::uint64_t),
                                        VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
                  "vkGetQueryPoolResults");
    tm.has_timestamps = true;
    tm.gpu_total = double(ts[1] - ts[0]) * m.dev->timestamp_period_ns * 1e-6;
  }
  const float* x = static_cast<const float*>(m.rb_X.mapped());
  const float* n = static_cast<const float*>(m.rb_N.mapped());
  const float* b = static_cast<const float*>(m.rb_B.mapped());
  for (Index i = 0; i < 3 * m.nv; ++i) {
    const int a = int(i % 3);
    if (vertices) vertices[i] = double(x[i]) * m.scale + m.origin[a];
    if (normals) normals[i] = double(n[i]);
    if (base) base[i] = double(b[i]) * m.scale + m.origin[a];
  }
  tm.host_total = detail::ms_since(t_start);
  m.timings = tm;
}

}  // namespace vpffd::vulkan
