// VulkanMultires: the multiresolution frame (shaders/multires.comp) on a device shared
// with the VulkanDeformers: its own buffers, descriptor set, pipeline, command buffer
// and fence. Set-up embeds the foot points on the host (the CPU MultiresFFD does it,
// so both evaluate the same spans), sorts the vertices by lattice cell and uploads the
// frame data once; a frame is: upload copy of the control points -> dispatch ->
// copies of positions and normals to the host, one submission of a command buffer
// recorded once. After a VulkanDeformer's frame (deform with a Deformer) the commands
// are a tail of that frame's submission (detail::FrameTail): copies of the Deformer's
// control points and offsets -> corrected.comp (their sum) -> [the base
// Deformer's FFD of them] -> dispatch -> copies.
//
// Periodic lattices (lattice/periodic.h), as the VulkanDeformer: the device evaluates the
// extended lattice (N control points; the host expands the user's NDIST distinct ones each
// frame, a Deformer's frame holds them expanded already, and its offsets, per distinct
// point, reach the tied copies through the tie map in corrected.comp). The foot points
// are wrapped into the box by the host's embedding (MultiresFFD's, so both evaluate the
// same spans); what the seams add there (foot_seams.h) is per vertex data: a shift seam's
// translation in three more rows of the frame data, a twist seam's mirror of J folded
// into S_u and S_v.

#include "vpffd/backend/vulkan_multires.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <mutex>
#include <numeric>

#include "context.h"
#include "pipelines.h"
#include "deformer_impl.h"  // put_reals, ms_since
#include "shaders/multires_layout.h"
#include "vk_handle.h"
#include "vpffd/shaders/multires_spirv.h"

namespace vpffd::vulkan {

using detail::Buffer;

struct VulkanMultires::Impl {
  std::shared_ptr<detail::Device> dev;  // first: destroyed last
  std::unique_ptr<MultiresFFD> cpu;
  VkDevice d = VK_NULL_HANDLE;
  Precision precision = Precision::Float64;
  bool ff = false;
  Index nv = 0, N = 0, n_distinct = 0;  // N: the extended lattice's control points
  std::uint32_t groups = 1;
  Vector3d origin;
  double scale = 1.0;
  std::vector<std::int32_t> order;  // device vertex i is input vertex order[i]

  enum Buf { bP, bTab, bSpan, bData, bX, bN, bSrcP, bSrcDelta, bTies, kNumBuf };
  static_assert(bP == VPFFD_MR_B_P && bTab == VPFFD_MR_B_TAB && bSpan == VPFFD_MR_B_SPAN &&
                    bData == VPFFD_MR_B_DATA && bX == VPFFD_MR_B_X && bN == VPFFD_MR_B_N &&
                    bSrcP == VPFFD_MR_B_SRC_P && bSrcDelta == VPFFD_MR_B_SRC_DELTA && bTies == VPFFD_MR_B_TIES &&
                    kNumBuf == VPFFD_MR_B_COUNT,
                "the bindings of shaders/multires_layout.h");
  Buffer buf[kNumBuf];
  Buffer up_P, rb_X, rb_N;

  detail::ComputePipelines pl;  // the descriptor set and one pipeline per MultiresPipe
  Owned<VkCommandPool> cmd_pool;
  VkCommandBuffer frame_cb = VK_NULL_HANDLE;  // recorded once, submitted every frame
  VkCommandBuffer tail_cb = VK_NULL_HANDLE;   // after a Deformer's frame: recorded per frame
  std::uint32_t groups_cp = 1;
  Owned<VkFence> fence;
  Owned<VkQueryPool> queries;

  mutable std::mutex mutex;  // one frame at a time
  bool pending = false;      // a submission whose wait failed may still run
  FrameTimings timings;

  ~Impl() {
    if (d && pending) vkWaitForFences(d, 1, &fence.get(), VK_TRUE, UINT64_MAX);
  }

  void build(const std::string& selector, Precision wanted);
  void create_pipeline(const std::array<std::int32_t, 11>& spec);
  void record_frame();
  void record_tail(VulkanDeformer::Impl& src, bool corrected, VulkanDeformer::Impl* base);
  void read_timings(FrameTimings& tm);
  void unpack(MultiresFrame& out) const;
  void unpack(double* X, double* N) const;  // into the caller's #V x 3 arrays
  void submit_and_wait(VkCommandBuffer cb);
};

void VulkanMultires::Impl::submit_and_wait(VkCommandBuffer cb) {
  detail::submit_and_wait(*dev, fence.get(), pending, &cb, 1);
}

void VulkanMultires::Impl::create_pipeline(const std::array<std::int32_t, 11>& spec) {
  detail::create_compute_pipelines(d, buf, kNumBuf, 4, spec.data(), std::uint32_t(spec.size()),
                                   ff ? kMultiresShadersFF : kMultiresShaders64, kMultiresPipes, pl);
}

void VulkanMultires::Impl::record_frame() {
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
  // The previous frame's copies read the outputs this dispatch overwrites.
  barrier(VK_ACCESS_TRANSFER_READ_BIT, VK_ACCESS_SHADER_WRITE_BIT, tr, cs);
  const VkBufferCopy cp{0, 0, 12 * VkDeviceSize(N)};
  vkCmdCopyBuffer(frame_cb, up_P.handle(), buf[bP].handle(), 1, &cp);
  barrier(VK_ACCESS_TRANSFER_WRITE_BIT, VK_ACCESS_SHADER_READ_BIT, tr, cs);
  vkCmdBindPipeline(frame_cb, VK_PIPELINE_BIND_POINT_COMPUTE, pl.pipes[kMultires].get());
  vkCmdBindDescriptorSets(frame_cb, VK_PIPELINE_BIND_POINT_COMPUTE, pl.layout.get(), 0, 1, &pl.set, 0, nullptr);
  vkCmdDispatch(frame_cb, groups, 1, 1);
  barrier(VK_ACCESS_SHADER_WRITE_BIT, VK_ACCESS_TRANSFER_READ_BIT, cs, tr);
  const VkBufferCopy cx{0, 0, 12 * VkDeviceSize(nv)};
  vkCmdCopyBuffer(frame_cb, buf[bX].handle(), rb_X.handle(), 1, &cx);
  vkCmdCopyBuffer(frame_cb, buf[bN].handle(), rb_N.handle(), 1, &cx);
  barrier(VK_ACCESS_TRANSFER_WRITE_BIT, VK_ACCESS_HOST_READ_BIT, tr, VK_PIPELINE_STAGE_HOST_BIT);
  if (dev->timestamps) vkCmdWriteTimestamp(frame_cb, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, queries.get(), 1);
  detail::check(vkEndCommandBuffer(frame_cb), "vkEndCommandBuffer");
}

void VulkanMultires::Impl::record_tail(VulkanDeformer::Impl& src, bool corrected, VulkanDeformer::Impl* base) {
  const VkCommandBuffer cb = tail_cb;
  detail::check(vkResetCommandBuffer(cb, 0), "vkResetCommandBuffer");
  VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  detail::check(vkBeginCommandBuffer(cb, &bi), "vkBeginCommandBuffer");
  if (dev->timestamps) {
    vkCmdResetQueryPool(cb, queries.get(), 0, 2);
    vkCmdWriteTimestamp(cb, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, queries.get(), 0);
  }
  // The Deformer's frame wrote its control points (a copy) and offsets (shaders); this
  // frame's previous submission read the buffers written below: one barrier for both.
  VulkanDeformer::Impl::barrier(cb);
  VulkanDeformer::Impl::copy(cb, src.buf[VulkanDeformer::Impl::bP], buf[bSrcP], 12 * VkDeviceSize(N));
  if (corrected)
    VulkanDeformer::Impl::copy(cb, src.buf[VulkanDeformer::Impl::bDelta], buf[bSrcDelta],
                               24 * VkDeviceSize(n_distinct));
  VulkanDeformer::Impl::barrier(cb);
  const std::int32_t push = corrected ? 1 : 0;
  vkCmdBindDescriptorSets(cb, VK_PIPELINE_BIND_POINT_COMPUTE, pl.layout.get(), 0, 1, &pl.set, 0, nullptr);
  vkCmdBindPipeline(cb, VK_PIPELINE_BIND_POINT_COMPUTE, pl.pipes[kCorrected].get());
  vkCmdPushConstants(cb, pl.layout.get(), VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
  vkCmdDispatch(cb, groups_cp, 1, 1);
  VulkanDeformer::Impl::barrier(cb);
  if (base) {
    // The base mesh's FFD of the same control points, with its own pipeline.
    VulkanDeformer::Impl::copy(cb, buf[bP], base->buf[VulkanDeformer::Impl::bP], 12 * VkDeviceSize(N));
    base->record_ffd_readback(cb);
    vkCmdBindDescriptorSets(cb, VK_PIPELINE_BIND_POINT_COMPUTE, pl.layout.get(), 0, 1, &pl.set, 0, nullptr);
  }
  vkCmdBindPipeline(cb, VK_PIPELINE_BIND_POINT_COMPUTE, pl.pipes[kMultires].get());
  vkCmdDispatch(cb, groups, 1, 1);
  VulkanDeformer::Impl::barrier(cb);
  const VkBufferCopy cx{0, 0, 12 * VkDeviceSize(nv)};
  vkCmdCopyBuffer(cb, buf[bX].handle(), rb_X.handle(), 1, &cx);
  vkCmdCopyBuffer(cb, buf[bN].handle(), rb_N.handle(), 1, &cx);
  VulkanDeformer::Impl::host_barrier(cb);
  if (dev->timestamps) vkCmdWriteTimestamp(cb, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, queries.get(), 1);
  detail::check(vkEndCommandBuffer(cb), "vkEndCommandBuffer");
}

void VulkanMultires::Impl::read_timings(FrameTimings& tm) {
  if (!dev->timestamps) return;
  std::uint64_t ts[2] = {};
  detail::check(vkGetQueryPoolResults(d, queries.get(), 0, 2, sizeof(ts), ts, sizeof(std::uint64_t),
                                      VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
                "vkGetQueryPoolResults");
  tm.has_timestamps = true;
  tm.gpu_total = double(ts[1] - ts[0]) * dev->timestamp_period_ns * 1e-6;
}

void VulkanMultires::Impl::unpack(MultiresFrame& out) const {
  out.vertices.resize(nv, 3);
  out.normals.resize(nv, 3);
  unpack(out.vertices.data(), out.normals.data());
}

void VulkanMultires::Impl::unpack(double* X, double* N) const {
  const float* x = static_cast<const float*>(rb_X.mapped());
  const float* n = static_cast<const float*>(rb_N.mapped());
  for (Index i = 0; i < nv; ++i) {
    const Index v = order[i];
    for (int a = 0; a < 3; ++a) {
      if (X) X[3 * v + a] = double(x[3 * i + a]) * scale + origin[a];
      if (N) N[3 * v + a] = double(n[3 * i + a]);
    }
  }
}

void VulkanMultires::Impl::build(const std::string& selector, Precision wanted) {
  dev = detail::open_device(selector);
  d = dev->handle;
  if (wanted == Precision::Float64 && !dev->info.float64)
    throw BackendUnavailableError("vulkan: device " + dev->info.name +
                                  " has no shaderFloat64: use precision 'float-float' or 'auto'");
  precision = wanted == Precision::Auto ? (dev->info.float64 ? Precision::Float64 : Precision::FloatFloat) : wanted;
  ff = precision == Precision::FloatFloat;
  const Multires& m = cpu->multires();
  const Lattice& L = cpu->lattice();
  const BasisTables& T = cpu->tables();
  const Embedding& E = cpu->embedding();
  const FootSeams& seams = cpu->seams();
  const Ties& ties = cpu->ties();
  const bool shifted = seams.any_shift();
  const int rows = shifted ? MR_ROWS_SHIFTED : MR_ROWS;
  nv = m.n_vertices();
  N = L.n_control_points();
  n_distinct = cpu->n_control_points();
  if (nv * Index(rows) >= (Index(1) << 31))
    throw InvalidInputError("VulkanMultires: the mesh is too large for 32-bit device indices");
  origin = 0.5 * (L.box_min + L.box_max);
  {
    const double half = 0.5 * (L.box_max - L.box_min).norm();
    scale = std::isfinite(half) && half > 0 ? std::exp2(std::round(std::log2(half))) : 1.0;
  }

  // Device order: foot points sorted by cell (stable: input order within a cell).
  std::vector<std::int32_t> cell(nv);
  for (Index i = 0; i < nv; ++i) cell[i] = vpffd::detail::cell_index(T, E, i);
  order.resize(nv);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](std::int32_t a, std::int32_t b) { return cell[a] < cell[b]; });

  std::vector<std::int32_t> span(3 * nv);
  std::vector<float> data(size_t(rows) * nv);
  const int twist = seams.twisted_axis();
  auto put = [&](int r, Index i, double x) { data[size_t(r) * nv + i] = static_cast<float>(x); };
  for (Index i = 0; i < nv; ++i) {
    const Index v = order[i];
    const bool mirrored = seams.mirrored(v);
    const Vector3d shift = seams.shift(v);
    for (int a = 0; a < 3; ++a) {
      span[a * nv + i] = E.span[a][v] - T.poly[a].degree;
      put(MR_TAU + a, i, E.tau[a][v]);
      const double flip = mirrored && a != twist ? -1.0 : 1.0;
      put(MR_SU + a, i, flip * m.su[a][v] / scale);
      put(MR_SV + a, i, flip * m.sv[a][v] / scale);
      if (shifted) put(MR_SHIFT + a, i, shift[a] / scale);
    }
    put(MR_D, i, m.d[v] / scale);
    // a, b multiply tangents (now in scale units), g the unit normal: a, b times scale.
    for (int k = 0; k < 6; ++k) put(MR_COEF + k, i, k % 3 == 2 ? m.coef[k][v] : m.coef[k][v] * scale);
  }
  for (float x : data)
    if (!std::isfinite(x))
      throw InvalidInputError("VulkanMultires: the decomposition's frame data exceeds float32's range in device "
                              "units (degenerate base triangles?)");
  // The power forms, then d tau / d y in device units per axis and span (normals.comp's table).
  std::vector<double> tab;
  std::array<std::int32_t, 3> poly_off{};
  {
    const Vector3d du_dx = parameter_scale(L);
    for (int a = 0; a < 3; ++a) {
      poly_off[a] = static_cast<std::int32_t>(tab.size());
      tab.insert(tab.end(), T.poly[a].coef.begin(), T.poly[a].coef.end());
    }
    for (int a = 0; a < 3; ++a)
      for (double w : T.poly[a].inv_width) tab.push_back(w * du_dx[a] * scale);
  }
  std::vector<double> tab_dev(tab.size());  // 8 bytes per real in either precision
  detail::put_reals(tab_dev.data(), tab.data(), tab.size(), ff);

  auto mk = [&](Buf i, size_t bytes, const char* what) { buf[i] = Buffer(*dev, bytes, Buffer::DeviceLocal, what); };
  mk(bP, 12 * N, "control points");
  mk(bTab, 8 * tab_dev.size(), "basis table");
  mk(bSpan, 4 * span.size(), "foot point spans");
  mk(bData, 4 * data.size(), "multiresolution frame data");
  mk(bX, 12 * nv, "multiresolution vertices");
  mk(bN, 12 * nv, "multiresolution normals");
  mk(bSrcP, 12 * N, "control points of a Deformer's frame");
  mk(bSrcDelta, 24 * n_distinct, "offsets of a Deformer's frame");
  // The tie map only for a periodic lattice (else a placeholder: bindings need a buffer).
  const std::vector<std::int32_t> tie_map = ties.identity ? std::vector<std::int32_t>{} : ties.source;
  mk(bTies, std::max<size_t>(16, 4 * tie_map.size()), "periodic ties");
  up_P = Buffer(*dev, 12 * N, Buffer::Upload, "control points (upload)");
  rb_X = Buffer(*dev, 12 * nv, Buffer::Readback, "multiresolution vertices (read-back)");
  rb_N = Buffer(*dev, 12 * nv, Buffer::Readback, "multiresolution normals (read-back)");

  cmd_pool = detail::create_command_pool(*dev);  // resettable buffers: tail_cb
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
      staging.emplace_back(*dev, bytes, Buffer::Upload, "staging");
      std::memcpy(staging.back().mapped(), src, bytes);
      const VkBufferCopy c{0, 0, bytes};
      vkCmdCopyBuffer(cb, staging.back().handle(), buf[i].handle(), 1, &c);
    };
    upload(bTab, tab_dev.data(), 8 * tab_dev.size());
    upload(bSpan, span.data(), 4 * span.size());
    upload(bData, data.data(), 4 * data.size());
    if (!tie_map.empty()) upload(bTies, tie_map.data(), 4 * tie_map.size());
    detail::check(vkEndCommandBuffer(cb), "vkEndCommandBuffer");
    submit_and_wait(cb);
    vkFreeCommandBuffers(d, cmd_pool.get(), 1, &cb);
  }

  const auto dims = L.dims();
  create_pipeline({T.order[0], T.order[1], T.order[2], dims[0], dims[1], dims[2], static_cast<std::int32_t>(nv),
                   poly_off[1], poly_off[2], ties.identity ? 0 : static_cast<std::int32_t>(n_distinct),
                   shifted ? 1 : 0});
  groups = static_cast<std::uint32_t>(
      std::clamp<Index>((nv + VPFFD_MR_GROUP - 1) / VPFFD_MR_GROUP, 1, dev->limits.maxComputeWorkGroupCount[0]));
  groups_cp = static_cast<std::uint32_t>(
      std::clamp<Index>((N + VPFFD_MR_GROUP - 1) / VPFFD_MR_GROUP, 1, dev->limits.maxComputeWorkGroupCount[0]));
  record_frame();
  tail_cb = detail::allocate_command_buffer(d, cmd_pool.get());
}

// ---- public API ----------------------------------------------------------------

VulkanMultires::VulkanMultires(std::shared_ptr<const Multires> m, Lattice L, const std::string& device,
                               Precision precision)
    : impl_(std::make_unique<Impl>()) {
  // MultiresFFD validates the decomposition and the lattice and embeds the foot points.
  impl_->cpu = std::make_unique<MultiresFFD>(std::move(m), std::move(L));
  impl_->build(device, precision);
}

VulkanMultires::~VulkanMultires() = default;

const MultiresFFD& VulkanMultires::cpu() const { return *impl_->cpu; }
const DeviceInfo& VulkanMultires::device() const { return impl_->dev->info; }
Precision VulkanMultires::precision() const { return impl_->precision; }
FrameTimings VulkanMultires::last_timings() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->timings;
}
const Vector3d& VulkanMultires::origin() const { return impl_->origin; }
double VulkanMultires::scale() const { return impl_->scale; }
std::uint64_t VulkanMultires::vertex_buffer_handle() const {
  return reinterpret_cast<std::uint64_t>(impl_->buf[Impl::bX].handle());
}
std::uint64_t VulkanMultires::normal_buffer_handle() const {
  return reinterpret_cast<std::uint64_t>(impl_->buf[Impl::bN].handle());
}
const std::vector<std::int32_t>& VulkanMultires::vertex_order() const { return impl_->order; }

MultiresFrame VulkanMultires::deform(const Eigen::Ref<const RowMatrixX3d>& P) {
  MultiresFrame out;
  out.vertices.resize(impl_->nv, 3);
  out.normals.resize(impl_->nv, 3);
  deform(P, out.vertices.data(), out.normals.data());
  return out;
}

void VulkanMultires::deform(const Eigen::Ref<const RowMatrixX3d>& P, double* vertices, double* normals) {
  const auto t_start = std::chrono::steady_clock::now();
  Impl& m = *impl_;
  m.cpu->check_control_points(P);
  // The extended lattice's points in double, each rounded once below (a periodic
  // lattice's tied copies, with a shift seam's constant; P itself otherwise).
  const RowMatrixX3d expanded = m.cpu->ties().identity ? RowMatrixX3d() : expand_points(m.cpu->ties(), P);
  const Eigen::Ref<const RowMatrixX3d> Pe = m.cpu->ties().identity ? P : Eigen::Ref<const RowMatrixX3d>(expanded);
  std::lock_guard<std::mutex> lock(m.mutex);
  float* p = static_cast<float*>(m.up_P.mapped());
  // Device coordinates up to 2^100 box half-diagonals: the shader's products and
  // sums of them (basis derivatives are a few span widths^-1) stay far from float32's
  // 3.4e38, so no frame overflows into Inf silently.
  constexpr double kMaxDevice = 0x1p100;
  for (Index c = 0; c < m.N; ++c)
    for (int a = 0; a < 3; ++a) {
      const double y = (Pe(c, a) - m.origin[a]) / m.scale;
      if (!(std::abs(y) <= kMaxDevice))
        throw InvalidInputError(vpffd::detail::concat(
            "VulkanMultires: control point ", c, " is beyond float32's range relative to the lattice (", Pe(c, a),
            " along axis ", a, ", more than 2^100 box half-diagonals from its centre)"));
      p[3 * c + a] = static_cast<float>(y);
    }
  m.submit_and_wait(m.frame_cb);
  FrameTimings tm;
  m.read_timings(tm);
  m.unpack(vertices, normals);
  tm.host_total = detail::ms_since(t_start);
  m.timings = tm;
}

namespace {

bool same_lattice(const Lattice& a, const Lattice& b) {
  return a.degree == b.degree && a.knots == b.knots && a.box_min == b.box_min && a.box_max == b.box_max &&
         a.seam == b.seam;
}

}  // namespace

MultiresDeviceFrame VulkanMultires::deform(VulkanDeformer& correction, const Eigen::Ref<const RowMatrixX3d>& P,
                                           const CorrectionOptions& opt, VulkanDeformer* base, double* vertices,
                                           double* normals) {
  const auto t_start = std::chrono::steady_clock::now();
  Impl& m = *impl_;
  VulkanDeformer::Impl& src = *correction.impl_;
  VulkanDeformer::Impl* b = base ? base->impl_.get() : nullptr;
  VPFFD_CHECK(base != &correction, "VulkanMultires: the base Deformer must not be the correction's Deformer");
  for (const VulkanDeformer::Impl* x : {&src, b}) {
    if (!x) continue;
    const char* who = x == &src ? "the correction's Deformer" : "the base Deformer";
    VPFFD_CHECK(x->dev.get() == m.dev.get(), "VulkanMultires: ", who, " runs on device ", x->dev->info.name,
                ", this frame on ", m.dev->info.name, " (the same VkDevice is needed)");
    VPFFD_CHECK(same_lattice(x->topo->lattice, m.cpu->lattice()), "VulkanMultires: ", who,
                " has another lattice (its control points cannot drive this reconstruction)");
    VPFFD_CHECK(x->precision == m.precision, "VulkanMultires: ", who, " sums in ", precision_name(x->precision),
                ", this frame in ", precision_name(m.precision));
    // Same lattice, so same units; checked because the copies assume them.
    VPFFD_CHECK(x->origin == m.origin && x->scale == m.scale, "VulkanMultires: ", who,
                " has other device units");
  }
  std::lock_guard<std::mutex> lock(m.mutex);
  std::unique_lock<std::mutex> base_lock;
  MultiresDeviceFrame out;
  FrameTimings tm;
  detail::FrameTail tail;
  tail.record = [&](bool corrected) {
    if (b) {
      base_lock = std::unique_lock<std::mutex>(b->frame_mutex);
      b->settle();
      b->readback();  // its read-back buffer, made on first use
    }
    m.record_tail(src, corrected, b);
    return m.tail_cb;
  };
  tail.finish = [&] {
    m.read_timings(tm);
    if (vertices || normals) {
      if (!vertices) out.frame.vertices.resize(m.nv, 3);
      if (!normals) out.frame.normals.resize(m.nv, 3);
      m.unpack(vertices ? vertices : out.frame.vertices.data(), normals ? normals : out.frame.normals.data());
    } else {
      m.unpack(out.frame);
    }
    if (b) out.base_vertices = b->unpack_vertices();
  };
  out.correction = src.run_frame(P, opt, /*read_vertices=*/b == nullptr, nullptr, &tail);
  if (!b) out.base_vertices = std::move(out.correction.vertices);
  tm.host_total = detail::ms_since(t_start);
  m.timings = tm;
  return out;
}

}  // namespace vpffd::vulkan
