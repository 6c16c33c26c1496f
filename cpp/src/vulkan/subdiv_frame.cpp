// VulkanSubdivFrame: the displaced-subdivision-surface frame (shaders/subdiv.comp) on a
// device shared with the other Vulkan frames: its own buffers, descriptor set,
// pipeline, command buffer and fence. Set-up checks the plain arrays and uploads the
// stencils (indices, real weights), d and the coefficients once; a frame is: upload
// copy of the control points -> one dispatch -> copies of positions, normals and limit
// points to the host, one submission of a command buffer recorded once.

#include "vpffd/backend/vulkan_subdiv.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <mutex>
#include <vector>

#include "context.h"
#include "deformer_impl.h"  // put_reals, ms_since
#include "pipelines.h"
#include "shaders/subdiv_layout.h"
#include "vk_handle.h"
#include "vpffd/shaders/subdiv_spirv.h"

namespace vpffd::vulkan {

using detail::Buffer;

struct VulkanSubdivFrame::Impl {
  std::shared_ptr<detail::Device> dev;  // first: destroyed last
  VkDevice d = VK_NULL_HANDLE;
  Precision precision = Precision::Float64;
  bool ff = false;
  Index nv = 0, M = 0;
  std::uint32_t groups = 1;
  Vector3d origin = Vector3d::Zero();
  double scale = 1.0;

  enum Buf { bC, bPtr, bIdx, bW, bData, bX, bN, bS, kNumBuf };
  static_assert(bC == VPFFD_SD_B_C && bPtr == VPFFD_SD_B_PTR && bIdx == VPFFD_SD_B_IDX && bW == VPFFD_SD_B_W &&
                    bData == VPFFD_SD_B_DATA && bX == VPFFD_SD_B_X && bN == VPFFD_SD_B_N && bS == VPFFD_SD_B_S &&
                    kNumBuf == VPFFD_SD_B_COUNT,
                "the bindings of shaders/subdiv_layout.h");
  Buffer buf[kNumBuf];
  Buffer up_C, rb_X, rb_N, rb_S;

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

  void build(const SubdivStencilsView& s, const Eigen::Ref<const RowMatrixX3d>& rest, const std::string& selector,
             Precision wanted);
  void record_frame();
};

void VulkanSubdivFrame::Impl::record_frame() {
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
  // dispatch read the control points the copy below overwrites.
  barrier(VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_SHADER_READ_BIT,
          VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT, tr | cs, cs | tr);
  const VkBufferCopy cp{0, 0, 12 * VkDeviceSize(M)};
  vkCmdCopyBuffer(frame_cb, up_C.handle(), buf[bC].handle(), 1, &cp);
  barrier(VK_ACCESS_TRANSFER_WRITE_BIT, VK_ACCESS_SHADER_READ_BIT, tr, cs);
  vkCmdBindPipeline(frame_cb, VK_PIPELINE_BIND_POINT_COMPUTE, pl.pipes[kSubdiv].get());
  vkCmdBindDescriptorSets(frame_cb, VK_PIPELINE_BIND_POINT_COMPUTE, pl.layout.get(), 0, 1, &pl.set, 0, nullptr);
  vkCmdDispatch(frame_cb, groups, 1, 1);
  barrier(VK_ACCESS_SHADER_WRITE_BIT, VK_ACCESS_TRANSFER_READ_BIT, cs, tr);
  const VkBufferCopy cx{0, 0, 12 * VkDeviceSize(nv)};
  vkCmdCopyBuffer(frame_cb, buf[bX].handle(), rb_X.handle(), 1, &cx);
  vkCmdCopyBuffer(frame_cb, buf[bN].handle(), rb_N.handle(), 1, &cx);
  vkCmdCopyBuffer(frame_cb, buf[bS].handle(), rb_S.handle(), 1, &cx);
  barrier(VK_ACCESS_TRANSFER_WRITE_BIT, VK_ACCESS_HOST_READ_BIT, tr, VK_PIPELINE_STAGE_HOST_BIT);
  if (dev->timestamps) vkCmdWriteTimestamp(frame_cb, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, queries.get(), 1);
  detail::check(vkEndCommandBuffer(frame_cb), "vkEndCommandBuffer");
}

void VulkanSubdivFrame::Impl::build(const SubdivStencilsView& s, const Eigen::Ref<const RowMatrixX3d>& rest,
                                    const std::string& selector, Precision wanted) {
  // The arrays first: a bad decomposition is refused before Vulkan starts.
  nv = s.n_vertices;
  M = s.n_control;
  VPFFD_CHECK(nv > 0 && M > 0, "VulkanSubdivFrame: empty decomposition (", nv, " vertices, ", M, " control points)");
  VPFFD_CHECK(s.indptr && s.indices && s.w && s.wu && s.wv && s.d && s.coef, "VulkanSubdivFrame: a null array");
  VPFFD_CHECK(rest.rows() == M, "VulkanSubdivFrame: expected ", M, " rest control points, got ", rest.rows());
  VPFFD_CHECK(rest.allFinite(), "VulkanSubdivFrame: the rest control points are not finite");
  VPFFD_CHECK(s.indptr[0] == 0, "VulkanSubdivFrame: indptr[0] must be 0, got ", s.indptr[0]);
  for (Index i = 0; i < nv; ++i)
    VPFFD_CHECK(s.indptr[i + 1] >= s.indptr[i], "VulkanSubdivFrame: indptr decreases at row ", i);
  const std::int64_t nnz = s.indptr[nv];
  // 3 nnz reals are indexed with 32-bit ints in the shader, as are 3V and 3M floats.
  VPFFD_CHECK(3 * nnz < (std::int64_t(1) << 31) && 3 * nv < (Index(1) << 31) && Index(SD_ROWS) * nv < (Index(1) << 31) &&
                  3 * M < (Index(1) << 31),
              "VulkanSubdivFrame: the decomposition is too large for 32-bit device indices");
  for (std::int64_t k = 0; k < nnz; ++k) {
    VPFFD_CHECK(s.indices[k] >= 0 && s.indices[k] < M, "VulkanSubdivFrame: stencil entry ", k,
                " names control point ", s.indices[k], ", out of range [0, ", M, ")");
    VPFFD_CHECK(std::isfinite(s.w[k]) && std::isfinite(s.wu[k]) && std::isfinite(s.wv[k]),
                "VulkanSubdivFrame: stencil weight ", k, " is not finite");
  }

  // Device units: relative to the rest control points' box centre, in the power of two
  // nearest to its half diagonal (a power of two: the scaling itself is exact).
  const Vector3d lo = rest.colwise().minCoeff(), hi = rest.colwise().maxCoeff();
  origin = 0.5 * (lo + hi);
  {
    const double half = 0.5 * (hi - lo).norm();
    scale = std::isfinite(half) && half > 0 ? std::exp2(std::round(std::log2(half))) : 1.0;
  }
  std::vector<float> data(size_t(SD_ROWS) * nv);
  for (Index i = 0; i < nv; ++i) {
    data[size_t(SD_D) * nv + i] = static_cast<float>(s.d[i] / scale);
    // a, b multiply tangents (now in scale units): a, b times scale; g the unit normal.
    for (int k = 0; k < 6; ++k)
      data[size_t(SD_COEF + k) * nv + i] = static_cast<float>(k % 3 == 2 ? s.coef[6 * i + k] : s.coef[6 * i + k] * scale);
  }
  for (float x : data)
    VPFFD_CHECK(std::isfinite(x), "VulkanSubdivFrame: the displacements or normal coefficients exceed float32's "
                                  "range in device units (or are not finite)");
  std::vector<std::int32_t> ptr(nv + 1);
  for (Index i = 0; i <= nv; ++i) ptr[i] = static_cast<std::int32_t>(s.indptr[i]);
  std::vector<double> w(3 * size_t(nnz));
  for (std::int64_t k = 0; k < nnz; ++k) {
    w[3 * k] = s.w[k];
    w[3 * k + 1] = s.wu[k];
    w[3 * k + 2] = s.wv[k];
  }

  dev = detail::open_device(selector);
  d = dev->handle;
  if (wanted == Precision::Float64 && !dev->info.float64)
    throw BackendUnavailableError("vulkan: device " + dev->info.name +
                                  " has no shaderFloat64: use precision 'float-float' or 'auto'");
  precision = wanted == Precision::Auto ? (dev->info.float64 ? Precision::Float64 : Precision::FloatFloat) : wanted;
  ff = precision == Precision::FloatFloat;
  std::vector<double> w_dev(w.size());  // 8 bytes per real in either precision
  detail::put_reals(w_dev.data(), w.data(), w.size(), ff);

  // A zero-entry buffer is not allowed: at least 8 bytes each.
  auto mk = [&](Buf i, size_t bytes, const char* what) {
    buf[i] = Buffer(*dev, std::max<size_t>(bytes, 8), Buffer::DeviceLocal, what);
  };
  mk(bC, 12 * M, "subdivision control points");
  mk(bPtr, 4 * ptr.size(), "stencil rows");
  mk(bIdx, 4 * size_t(nnz), "stencil indices");
  mk(bW, 8 * w_dev.size(), "stencil weights");
  mk(bData, 4 * data.size(), "subdivision frame data");
  mk(bX, 12 * nv, "subdivision vertices");
  mk(bN, 12 * nv, "subdivision normals");
  mk(bS, 12 * nv, "subdivision limit points");
  up_C = Buffer(*dev, 12 * M, Buffer::Upload, "subdivision control points (upload)");
  rb_X = Buffer(*dev, 12 * nv, Buffer::Readback, "subdivision vertices (read-back)");
  rb_N = Buffer(*dev, 12 * nv, Buffer::Readback, "subdivision normals (read-back)");
  rb_S = Buffer(*dev, 12 * nv, Buffer::Readback, "subdivision limit points (read-back)");

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
    upload(bPtr, ptr.data(), 4 * ptr.size());
    upload(bIdx, s.indices, 4 * size_t(nnz));
    upload(bW, w_dev.data(), 8 * w_dev.size());
    upload(bData, data.data(), 4 * data.size());
    detail::check(vkEndCommandBuffer(cb), "vkEndCommandBuffer");
    detail::submit_and_wait(*dev, fence.get(), pending, &cb, 1);
    vkFreeCommandBuffers(d, cmd_pool.get(), 1, &cb);
  }

  const std::int32_t spec[1] = {static_cast<std::int32_t>(nv)};
  detail::create_compute_pipelines(d, buf, kNumBuf, 0, spec, 1, ff ? kSubdivShadersFF : kSubdivShaders64,
                                   kSubdivPipes, pl);
  groups = static_cast<std::uint32_t>(
      std::clamp<Index>((nv + VPFFD_SD_GROUP - 1) / VPFFD_SD_GROUP, 1, dev->limits.maxComputeWorkGroupCount[0]));
  record_frame();
}

// ---- public API ----------------------------------------------------------------

VulkanSubdivFrame::VulkanSubdivFrame(const SubdivStencilsView& s, const Eigen::Ref<const RowMatrixX3d>& rest,
                                     const std::string& device, Precision precision)
    : impl_(std::make_unique<Impl>()) {
  impl_->build(s, rest, device, precision);
}

VulkanSubdivFrame::~VulkanSubdivFrame() = default;

Index VulkanSubdivFrame::n_vertices() const { return impl_->nv; }
Index VulkanSubdivFrame::n_control() const { return impl_->M; }
const DeviceInfo& VulkanSubdivFrame::device() const { return impl_->dev->info; }
Precision VulkanSubdivFrame::precision() const { return impl_->precision; }
FrameTimings VulkanSubdivFrame::last_timings() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->timings;
}
const Vector3d& VulkanSubdivFrame::origin() const { return impl_->origin; }
double VulkanSubdivFrame::scale() const { return impl_->scale; }

SubdivDeviceFrame VulkanSubdivFrame::deform(const Eigen::Ref<const RowMatrixX3d>& C) {
  SubdivDeviceFrame out;
  out.vertices.resize(impl_->nv, 3);
  out.normals.resize(impl_->nv, 3);
  out.base.resize(impl_->nv, 3);
  deform(C, out.vertices.data(), out.normals.data(), out.base.data());
  return out;
}

void VulkanSubdivFrame::deform(const Eigen::Ref<const RowMatrixX3d>& C, double* vertices, double* normals,
                               double* base) {
  const auto t_start = std::chrono::steady_clock::now();
  Impl& m = *impl_;
  // The CPU frame's checks and messages (detail::require_control_points).
  VPFFD_CHECK(C.rows() == m.M, "SubdivisionMultires.deform: expected ", m.M, " control points, got ", C.rows());
  for (Index j = 0; j < C.rows(); ++j)
    VPFFD_CHECK(C.row(j).allFinite(), "SubdivisionMultires.deform: control point ", j,
                " is not finite (NaN or infinity)");
  std::lock_guard<std::mutex> lock(m.mutex);
  float* p = static_cast<float*>(m.up_C.mapped());
  // Device coordinates up to 2^100 units, as VulkanMultires: the float32 conversion
  // and the stencil sums (weights of a few units) stay far from float32's 3.4e38, so
  // no control point becomes Inf on the device silently.
  constexpr double kMaxDevice = 0x1p100;
  for (Index c = 0; c < m.M; ++c)
    for (int a = 0; a < 3; ++a) {
      const double y = (C(c, a) - m.origin[a]) / m.scale;
      VPFFD_CHECK(std::abs(y) <= kMaxDevice, "VulkanSubdivFrame: control point ", c,
                  " is beyond float32's range relative to the rest control points (", C(c, a), " along axis ", a,
                  ", more than 2^100 units of ", m.scale, " from their box centre)");
      p[3 * c + a] = static_cast<float>(y);
    }
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
  const float* sb = static_cast<const float*>(m.rb_S.mapped());
  for (Index i = 0; i < 3 * m.nv; ++i) {
    const int a = int(i % 3);
    if (vertices) vertices[i] = double(x[i]) * m.scale + m.origin[a];
    if (normals) normals[i] = double(n[i]);
    if (base) base[i] = double(sb[i]) * m.scale + m.origin[a];
  }
  tm.host_total = detail::ms_since(t_start);
  m.timings = tm;
}

}  // namespace vpffd::vulkan
