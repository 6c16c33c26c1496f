// VulkanDeformer: one frame of volume-preserving FFD as one queue submission.
//
// Device data (all in the device's vertex order, vertices sorted by lattice cell):
//   X (3V float, (positions - origin) / scale), F (3F int), vertex-face adjacency,
//   per vertex the first control point index and the local parameter per axis,
//   the per-span power-form basis table, the tiles (runs of <= 64 vertices of one
//   cell) and, per control point, the list of tile partials that touch it.
// A frame runs: upload copies -> FFD -> [volume] -> per axis step [coefficients ->
// combine -> solve (offsets included) -> vertex update] -> volume -> [normals of the
// corrected control points, when asked] -> copies of the offsets, the step results,
// the volume partials [and the normals] to the host. Lengths on the
// device are in units of `scale`, the power of two nearest to the lattice's half
// diagonal: float-float has float32's exponent range (volume coefficients squared
// of a 1e-9 m mesh would underflow it, those of a 1e10 mm one overflow it), and a
// power of two scales every float exactly, so float64 results do not change. See
// shaders/common.glsl for the precision and determinism rules, shaders/real.glsl for
// the two kinds of sums (float64, float-float) and their common buffer layout.
//
// The frame's command buffer depends only on the options' shape (which steps along
// which axes, whether volumes are measured): it is recorded once per shape and
// submitted again while only the control points, targets and weights change, which
// live in buffers. Point constraints without a volume row do not depend on the mesh
// at all, so the host solves them (exactly as the CPU backend, errors included) and
// the device only applies the offsets.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>

#include <Eigen/Eigenvalues>

#include "context.h"
#include "vpffd/backend/vulkan.h"
#include "vpffd/ffd/basis_matrix.h"
#include "vpffd/ffd/normals.h"

namespace vpffd::vulkan {

namespace {

// Each shader in both builds of shaders/real.glsl.
const std::uint32_t kSpvFfd64[] =
#include "vpffd/shaders/ffd.f64.spv.inc"
    ;
const std::uint32_t kSpvCoef64[] =
#include "vpffd/shaders/coef.f64.spv.inc"
    ;
const std::uint32_t kSpvCombine64[] =
#include "vpffd/shaders/combine.f64.spv.inc"
    ;
const std::uint32_t kSpvSolve64[] =
#include "vpffd/shaders/solve.f64.spv.inc"
    ;
const std::uint32_t kSpvGather64[] =
#include "vpffd/shaders/gather.f64.spv.inc"
    ;
const std::uint32_t kSpvVolume64[] =
#include "vpffd/shaders/volume.f64.spv.inc"
    ;
const std::uint32_t kSpvFfdFF[] =
#include "vpffd/shaders/ffd.ff.spv.inc"
    ;
const std::uint32_t kSpvCoefFF[] =
#include "vpffd/shaders/coef.ff.spv.inc"
    ;
const std::uint32_t kSpvCombineFF[] =
#include "vpffd/shaders/combine.ff.spv.inc"
    ;
const std::uint32_t kSpvSolveFF[] =
#include "vpffd/shaders/solve.ff.spv.inc"
    ;
const std::uint32_t kSpvGatherFF[] =
#include "vpffd/shaders/gather.ff.spv.inc"
    ;
const std::uint32_t kSpvVolumeFF[] =
#include "vpffd/shaders/volume.ff.spv.inc"
    ;
const std::uint32_t kSpvNormals64[] =
#include "vpffd/shaders/normals.f64.spv.inc"
    ;
const std::uint32_t kSpvNormalsFF[] =
#include "vpffd/shaders/normals.ff.spv.inc"
    ;

enum Pipe { kFfd, kCoef, kCombine, kSolve, kGather, kVolume, kNormals, kPipes };
struct Spv {
  const std::uint32_t* code;
  size_t bytes;
  const char* name;
};
#define VPFFD_SHADERS(S)                                                                          \
  {                                                                                               \
    {kSpvFfd##S, sizeof(kSpvFfd##S), "ffd"}, {kSpvCoef##S, sizeof(kSpvCoef##S), "coef"},          \
        {kSpvCombine##S, sizeof(kSpvCombine##S), "combine"},                                      \
        {kSpvSolve##S, sizeof(kSpvSolve##S), "solve"}, {kSpvGather##S, sizeof(kSpvGather##S), "gather"}, \
        {kSpvVolume##S, sizeof(kSpvVolume##S), "volume"},                                         \
        {kSpvNormals##S, sizeof(kSpvNormals##S), "normals"},                                      \
  }
const Spv kShaders64[kPipes] = VPFFD_SHADERS(64);
const Spv kShadersFF[kPipes] = VPFFD_SHADERS(FF);
#undef VPFFD_SHADERS

// Device reals (shaders/real.glsl): a double, or a float pair (hi, lo) with value
// hi + lo, in the same 8 bytes.
void put_reals(void* dst, const double* src, size_t n, bool ff) {
  if (!ff) {
    std::memcpy(dst, src, 8 * n);
    return;
  }
  float* f = static_cast<float*>(dst);
  for (size_t i = 0; i < n; ++i) {
    const float hi = static_cast<float>(src[i]);
    f[2 * i] = hi;
    f[2 * i + 1] = static_cast<float>(src[i] - double(hi));
  }
}
double get_real(const void* src, size_t i, bool ff) {
  if (!ff) return static_cast<const double*>(src)[i];
  const float* f = static_cast<const float*>(src);
  return double(f[2 * i]) + double(f[2 * i + 1]);
}

// Buffer layouts: mirror shaders/common.glsl.
constexpr int FR_TARGET = 0, FR_MAX_INVW = 1, FR_HI = 2, FR_RHS = 8;
constexpr int CI_NC = 0, CI_PTR = 1, CI_IDX = 2, CI_G = 3, CI_H = 4, CI_BASE = 8;
constexpr int ST_STEP = 0, ST_STEP_STRIDE = 8;
using detail::kBindings;
constexpr int kMaxSteps = 3 * kMaxRounds;  // distinct axes (Deformer::plan checks) x rounds
constexpr int ST_SIZE = kMaxSteps * ST_STEP_STRIDE;
constexpr int kTile = 64;                   // vertices per tile = coef.comp's workgroup size
constexpr int kGroup = 256;                 // workgroup size of the other passes
constexpr std::uint32_t kMaxGroups = 1024;  // grid-stride passes: fixed reduction shape (= RED_STRIDE)
constexpr std::uint32_t kQueries = 3 + kMaxSteps;
constexpr size_t kMaxRecorded = 4;  // frame command buffers kept, one per options shape

struct Push {
  std::int32_t axis = 0, step = 0, left = 1, flags = 0, slot = 0, count = 0;
};

std::uint32_t groups_for(std::int64_t n, std::uint32_t cap) {
  return static_cast<std::uint32_t>(std::clamp<std::int64_t>((n + kGroup - 1) / kGroup, 1, cap));
}

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// What the device does in a frame, apart from the data: equal shapes share one recording.
struct Shape {
  enum Mode { Plain, DeviceSteps, HostOffsets };
  Mode mode = Plain;
  bool measure = false;      // closed mesh or allow_open: volumes are measured
  bool open = false;         // cone weights in coef
  bool normals = false;      // the deformed vertex normals, read back with the frame
  std::vector<int> axes;     // DeviceSteps: the axis of every step; HostOffsets: the axes to apply
  bool operator==(const Shape& o) const {
    return mode == o.mode && measure == o.measure && open == o.open && normals == o.normals && axes == o.axes;
  }
};

}  // namespace

struct VulkanDeformer::Impl {
  using Buffer = detail::Buffer;
  std::shared_ptr<detail::Device> dev;  // first: destroyed last
  std::unique_ptr<Deformer> cpu;
  VkDevice d = VK_NULL_HANDLE;
  Precision precision = Precision::Float64;
  bool ff = false;  // float-float reals on the device

  Index nv = 0, nf = 0, N = 0, n_tiles = 0;
  int KKK = 0;
  std::uint32_t g_vert = 1, g_face = 1, g_cp = 1, g_tile = 1;
  Vector3d origin;
  double scale = 1.0;  // device lengths = world lengths / scale (a power of two)

  // Order = binding numbers of shaders/common.glsl.
  enum Buf {
    bP, bX, bF, bAdjPtr, bAdj, bSpan, bTau, bPoly, bTiles, bPartial, bTileVol, bCombPtr, bComb, bAlpha, bInvW,
    bDelta, bFrame, bConsI, bStats, bRed, bConsD, bWork, bNrm0, bNrm, bNrmTab, kNumBuf
  };
  static_assert(kNumBuf == int(kBindings), "one binding per device buffer");
  Buffer buf[kNumBuf];
  Buffer up_P, up_invw, up_frame, up_delta, up_cons_i, up_cons_d, rb_delta, rb_stats, rb_red, rb_X, rb_N;
  Buffer up_n0;  // staging of the rest normals, released after their upload
  bool normals_ready = false;  // the rest normals are on the device (a submission ran)
  // The vertices before the frame now running: a frame whose failure is only known
  // after it ran (see deform) puts them back, so a failed frame never becomes visible.
  Buffer x_good;

  VkDescriptorSetLayout dsl = VK_NULL_HANDLE;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkDescriptorPool pool = VK_NULL_HANDLE;
  VkDescriptorSet set = VK_NULL_HANDLE;
  VkShaderModule modules[kPipes] = {};
  VkPipeline pipes[kPipes] = {};
  VkCommandPool cmd_pool = VK_NULL_HANDLE;
  VkCommandBuffer cmd = VK_NULL_HANDLE;  // one-time work: uploads, restores
  // Copies the device vertices to rb_X; recorded once, submitted after a frame in the
  // same vkQueueSubmit (no second wait per frame) or alone by vertices().
  VkCommandBuffer readback_cb = VK_NULL_HANDLE;
  VkFence fence = VK_NULL_HANDLE;
  VkQueryPool queries = VK_NULL_HANDLE;

  struct Recorded {
    Shape shape;
    VkCommandBuffer cb = VK_NULL_HANDLE;
    std::uint32_t n_steps = 0;  // timestamped steps
    std::uint64_t last_use = 0;
  };
  std::vector<Recorded> recorded;
  std::uint64_t frames = 0;

  // The point constraints' block on the device (see solve.comp), kept while the
  // constraint sources and the weights stay the same.
  struct ConsBlock {
    bool valid = false;
    std::vector<std::int32_t> index;  // nc x KKK control point indices of the rows
    std::vector<double> value;        // nc x KKK basis values
    VectorXd inv_weight;
    bool bad = false;  // a row that cannot move or dependent rows: the CPU's error applies
    double hi = 1.0;   // largest eigenvalue of the unit-diagonal block (at least 1)
  } cons;

  std::mutex frame_mutex;  // one frame or read-back at a time per deformer
  bool pending = false;    // a submission whose fence was not waited for (after an error)
  VectorXd invw_uploaded;  // inverse weights on the device (empty: none yet)
  FrameTimings timings;    // of the last frame that ran on the device (guarded by frame_mutex)

  ~Impl() {
    if (!d) return;
    if (pending) vkWaitForFences(d, 1, &fence, VK_TRUE, UINT64_MAX);
    if (queries) vkDestroyQueryPool(d, queries, nullptr);
    if (fence) vkDestroyFence(d, fence, nullptr);
    if (cmd_pool) vkDestroyCommandPool(d, cmd_pool, nullptr);
    for (VkPipeline p : pipes)
      if (p) vkDestroyPipeline(d, p, nullptr);
    for (VkShaderModule m : modules)
      if (m) vkDestroyShaderModule(d, m, nullptr);
    if (pool) vkDestroyDescriptorPool(d, pool, nullptr);
    if (layout) vkDestroyPipelineLayout(d, layout, nullptr);
    if (dsl) vkDestroyDescriptorSetLayout(d, dsl, nullptr);
  }

  // ---- command helpers --------------------------------------------------------
  // A submission whose wait failed may still run: its command buffers and the fence
  // must not be reused before it ends.
  void settle() {
    if (!pending) return;
    const VkResult r = vkWaitForFences(d, 1, &fence, VK_TRUE, 600ull * 1000 * 1000 * 1000);
    if (r == VK_TIMEOUT) throw DeviceError("vulkan: an earlier submission is still running after 600 s (device hung?)");
    detail::check(r, "vkWaitForFences");
    pending = false;
    detail::check(vkResetFences(d, 1, &fence), "vkResetFences");
  }

  void begin(VkCommandBuffer cb, bool once) {
    settle();
    detail::check(vkResetCommandBuffer(cb, 0), "vkResetCommandBuffer");
    VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    bi.flags = once ? VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT : 0;
    detail::check(vkBeginCommandBuffer(cb, &bi), "vkBeginCommandBuffer");
  }
  void begin() { begin(cmd, true); }

  // Submits `cbs` (in order, one vkQueueSubmit) and waits.
  void submit_and_wait(const VkCommandBuffer* cbs, std::uint32_t n) {
    VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
    si.commandBufferCount = n;
    si.pCommandBuffers = cbs;
    {
      std::lock_guard<std::mutex> lock(dev->queue_mutex);
      detail::check(vkQueueSubmit(dev->queue, 1, &si, fence), "vkQueueSubmit");
    }
    pending = true;
    // Generous: lavapipe on a big mesh is slow, but a hung device must not hang the caller.
    const VkResult r = vkWaitForFences(d, 1, &fence, VK_TRUE, 600ull * 1000 * 1000 * 1000);
    if (r == VK_TIMEOUT) throw DeviceError("vulkan: vkWaitForFences timed out after 600 s (device hung?)");
    detail::check(r, "vkWaitForFences");
    pending = false;
    detail::check(vkResetFences(d, 1, &fence), "vkResetFences");
  }
  void submit_and_wait() {
    detail::check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer");
    submit_and_wait(&cmd, 1);
  }

  // Everything before is visible to everything after (compute and transfer).
  static void barrier(VkCommandBuffer cb) {
    VkMemoryBarrier mb{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    mb.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT;
    mb.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_READ_BIT |
                       VK_ACCESS_TRANSFER_WRITE_BIT;
    const VkPipelineStageFlags st = VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT;
    vkCmdPipelineBarrier(cb, st, st, 0, 1, &mb, 0, nullptr, 0, nullptr);
  }

  // Copies to read-back buffers are visible to the host once the fence signals.
  static void host_barrier(VkCommandBuffer cb) {
    VkMemoryBarrier mb{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    mb.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    mb.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
    vkCmdPipelineBarrier(cb, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &mb, 0, nullptr, 0,
                         nullptr);
  }

  void dispatch(VkCommandBuffer cb, Pipe p, std::uint32_t groups, const Push& pc) {
    vkCmdBindPipeline(cb, VK_PIPELINE_BIND_POINT_COMPUTE, pipes[p]);
    vkCmdPushConstants(cb, layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(Push), &pc);
    vkCmdDispatch(cb, groups, 1, 1);
    barrier(cb);
  }

  static void copy(VkCommandBuffer cb, const Buffer& src, const Buffer& dst, VkDeviceSize bytes,
                   VkDeviceSize src_offset = 0, VkDeviceSize dst_offset = 0) {
    if (bytes == 0) return;
    VkBufferCopy c{src_offset, dst_offset, bytes};
    vkCmdCopyBuffer(cb, src.handle(), dst.handle(), 1, &c);
  }
  void copy(const Buffer& src, const Buffer& dst, VkDeviceSize bytes) { copy(cmd, src, dst, bytes); }

  void timestamp(VkCommandBuffer cb, std::uint32_t i) {
    if (dev->timestamps) vkCmdWriteTimestamp(cb, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, queries, i);
  }

  // Binding i now names buf[i]: recorded frames referred to the old set contents.
  void bind(int i) {
    VkDescriptorBufferInfo info{buf[i].handle(), 0, VK_WHOLE_SIZE};
    VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    w.dstSet = set;
    w.dstBinding = static_cast<std::uint32_t>(i);
    w.descriptorCount = 1;
    w.descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    w.pBufferInfo = &info;
    vkUpdateDescriptorSets(d, 1, &w, 0, nullptr);
    forget_recordings();
  }

  void forget_recordings() {
    for (Recorded& r : recorded) vkFreeCommandBuffers(d, cmd_pool, 1, &r.cb);
    recorded.clear();
  }

  // Device buffer i (and its upload buffer, when given) hold at least `bytes`.
  void reserve(Buf i, Buffer* up, size_t bytes, const char* what) {
    if (buf[i].handle() && buf[i].size() >= bytes) return;
    const size_t cap = std::max<size_t>(bytes, 2 * buf[i].size());
    buf[i] = Buffer(*dev, cap, Buffer::DeviceLocal, what);
    if (up) *up = Buffer(*dev, cap, Buffer::Upload, what);
    if (set) bind(i);
  }

  // ---- set-up ------------------------------------------------------------------
  void build(const std::string& selector, Precision wanted);
  void create_pipelines(const std::array<std::int32_t, 11>& spec);

  // ---- frames (all with frame_mutex held) -----------------------------------------
  VkCommandBuffer readback() {
    if (readback_cb) return readback_cb;
    rb_X = Buffer(*dev, 12 * nv, Buffer::Readback, "vertices (read-back)");
    VkCommandBufferAllocateInfo cai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
    cai.commandPool = cmd_pool;
    cai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    cai.commandBufferCount = 1;
    detail::check(vkAllocateCommandBuffers(d, &cai, &readback_cb), "vkAllocateCommandBuffers");
    begin(readback_cb, false);
    barrier(readback_cb);
    copy(readback_cb, buf[bX], rb_X, 12 * nv);
    host_barrier(readback_cb);
    detail::check(vkEndCommandBuffer(readback_cb), "vkEndCommandBuffer");
    return readback_cb;
  }

  // #V x 3 device vertices in the input order (runs readback() alone).
  RowMatrixX3d read_vertices() {
    const VkCommandBuffer cb = readback();
    submit_and_wait(&cb, 1);
    return unpack_vertices();
  }

  // rb_X, filled by readback(), in the input order and world units.
  RowMatrixX3d unpack_vertices() const {
    const float* x = static_cast<const float*>(rb_X.mapped());
    RowMatrixX3d out(nv, 3);
    const std::vector<std::int32_t>& order = cpu->processing_order();  // device vertex i is input order[i]
    for (Index i = 0; i < nv; ++i)
      for (int a = 0; a < 3; ++a) out(order[i], a) = double(x[3 * i + a]) * scale + origin[a];
    return out;
  }

  // rb_N, filled by a frame with normals, in the input order.
  RowMatrixX3d unpack_normals() const {
    const float* x = static_cast<const float*>(rb_N.mapped());
    RowMatrixX3d out(nv, 3);
    const std::vector<std::int32_t>& order = cpu->processing_order();
    for (Index i = 0; i < nv; ++i)
      for (int a = 0; a < 3; ++a) out(order[i], a) = double(x[3 * i + a]);
    return out;
  }

  // After a frame with device steps failed: its vertices back to those before it.
  void restore_vertices() {
    begin();
    barrier(cmd);
    copy(x_good, buf[bX], 12 * nv);
    barrier(cmd);
    submit_and_wait();
  }

  // The first frame with normals: their buffers, and the rest normals uploaded (into
  // `cmd`, begun) as deformed_normals uses them (vertex_normals of the rest mesh), in
  // the device order. Returns whether `cmd` got work.
  bool prepare_normals() {
    if (normals_ready) return false;
    reserve(bNrm0, &up_n0, 12 * nv, "rest normals");
    reserve(bNrm, nullptr, 12 * nv, "normals");
    const RowMatrixX3d n0 = vertex_normals(cpu->rest_vertices(), cpu->faces());
    const std::vector<std::int32_t>& order = cpu->processing_order();
    float* p = static_cast<float*>(up_n0.mapped());
    for (Index i = 0; i < nv; ++i)
      for (int a = 0; a < 3; ++a) p[3 * i + a] = static_cast<float>(n0(order[i], a));
    copy(up_n0, buf[bNrm0], 12 * nv);
    if (!rb_N.handle()) rb_N = Buffer(*dev, 12 * nv, Buffer::Readback, "normals (read-back)");
    return true;
  }

  // Uploads the constraint block (into `cmd`, begun) when the rows or the weights changed.
  bool update_constraints(const std::vector<SparseVec>& rows, const VectorXd& inv_weight);
  const Recorded& frame_commands(const Shape& shape);
};

void VulkanDeformer::Impl::create_pipelines(const std::array<std::int32_t, 11>& spec) {
  VkDescriptorSetLayoutBinding b[kBindings];
  for (int i = 0; i < kBindings; ++i)
    b[i] = {static_cast<std::uint32_t>(i), VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
  VkDescriptorSetLayoutCreateInfo li{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  li.bindingCount = kBindings;
  li.pBindings = b;
  detail::check(vkCreateDescriptorSetLayout(d, &li, nullptr, &dsl), "vkCreateDescriptorSetLayout");
  VkPushConstantRange pr{VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(Push)};
  VkPipelineLayoutCreateInfo pli{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  pli.setLayoutCount = 1;
  pli.pSetLayouts = &dsl;
  pli.pushConstantRangeCount = 1;
  pli.pPushConstantRanges = &pr;
  detail::check(vkCreatePipelineLayout(d, &pli, nullptr, &layout), "vkCreatePipelineLayout");

  VkDescriptorPoolSize ps{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, kBindings};
  VkDescriptorPoolCreateInfo pi{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  pi.maxSets = 1;
  pi.poolSizeCount = 1;
  pi.pPoolSizes = &ps;
  detail::check(vkCreateDescriptorPool(d, &pi, nullptr, &pool), "vkCreateDescriptorPool");
  VkDescriptorSetAllocateInfo ai{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  ai.descriptorPool = pool;
  ai.descriptorSetCount = 1;
  ai.pSetLayouts = &dsl;
  detail::check(vkAllocateDescriptorSets(d, &ai, &set), "vkAllocateDescriptorSets");
  VkDescriptorBufferInfo info[kBindings];
  VkWriteDescriptorSet w[kBindings];
  for (int i = 0; i < kBindings; ++i) {
    info[i] = {buf[i].handle(), 0, VK_WHOLE_SIZE};
    w[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    w[i].dstSet = set;
    w[i].dstBinding = static_cast<std::uint32_t>(i);
    w[i].descriptorCount = 1;
    w[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    w[i].pBufferInfo = &info[i];
  }
  vkUpdateDescriptorSets(d, kBindings, w, 0, nullptr);

  VkSpecializationMapEntry entries[11];
  for (std::uint32_t i = 0; i < 11; ++i) entries[i] = {i, i * 4u, 4};
  VkSpecializationInfo si{11, entries, sizeof(spec), spec.data()};
  for (int p = 0; p < kPipes; ++p) {
    VkShaderModuleCreateInfo mi{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
    const Spv* shaders = ff ? kShadersFF : kShaders64;
    mi.codeSize = shaders[p].bytes;
    mi.pCode = shaders[p].code;
    detail::check(vkCreateShaderModule(d, &mi, nullptr, &modules[p]), "vkCreateShaderModule");
    VkComputePipelineCreateInfo ci{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
    ci.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
    ci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    ci.stage.module = modules[p];
    ci.stage.pName = "main";
    ci.stage.pSpecializationInfo = &si;
    ci.layout = layout;
    const VkResult r = vkCreateComputePipelines(d, VK_NULL_HANDLE, 1, &ci, nullptr, &pipes[p]);
    if (r != VK_SUCCESS)
      throw DeviceError(std::string("vulkan: vkCreateComputePipelines (") + kShaders64[p].name +
                        ") failed: " + detail::result_string(r));
  }
}

void VulkanDeformer::Impl::build(const std::string& selector, Precision wanted) {
  dev = detail::open_device(selector);
  d = dev->handle;
  if (wanted == Precision::Float64 && !dev->info.float64)
    throw BackendUnavailableError("vulkan: device " + dev->info.name +
                                  " has no shaderFloat64: use precision 'float-float' or 'auto'");
  precision = wanted == Precision::Auto ? (dev->info.float64 ? Precision::Float64 : Precision::FloatFloat) : wanted;
  ff = precision == Precision::FloatFloat;
  const Deformer& c = *cpu;
  const Lattice& L = c.lattice();
  const BasisTables& T = c.tables();
  // The CPU Deformer's processing order (cells), faces and adjacency: a cell's
  // vertices share their K^3 control points, which the tiles of coef.comp reduce in
  // shared memory.
  const std::vector<std::int32_t>& order = c.processing_order();
  const Embedding& E = c.processing_embedding();
  const RowMatrixX3i& Fs = c.processing_faces();
  const VertexFaces& adj = c.processing_adjacency();
  nv = c.n_vertices();
  nf = c.n_faces();
  N = c.n_control_points();
  origin = c.origin();
  {
    const double half = 0.5 * (L.box_max - L.box_min).norm();
    scale = std::isfinite(half) && half > 0 ? std::exp2(std::round(std::log2(half))) : 1.0;
  }
  const auto dims = L.dims();
  KKK = T.order[0] * T.order[1] * T.order[2];
  if (nv * 3 >= (Index(1) << 31) || nf * 3 >= (Index(1) << 31))
    throw InvalidInputError("VulkanDeformer: the mesh is too large for 32-bit device indices");

  std::vector<std::int32_t> span(3 * nv), cell(nv);
  std::vector<float> tau(3 * nv), X0(3 * nv);
  const RowMatrixX3d& V = c.rest_vertices();
  for (Index i = 0; i < nv; ++i) {
    cell[i] = vpffd::detail::cell_index(T, E, i);
    for (int a = 0; a < 3; ++a) {
      span[3 * i + a] = E.span[a][i] - T.poly[a].degree;
      tau[3 * i + a] = static_cast<float>(E.tau[a][i]);
      X0[3 * i + a] = static_cast<float>((V(order[i], a) - origin[a]) / scale);
    }
  }
  std::vector<float> poly;
  std::array<std::int32_t, 3> poly_off{};
  for (int a = 0; a < 3; ++a) {
    poly_off[a] = static_cast<std::int32_t>(poly.size());
    for (double x : T.poly[a].coef) poly.push_back(static_cast<float>(x));
  }
  // normals.comp's table in reals: the power forms, then the derivative scales
  // d tau / d y = (1 / span width) (du / dx) scale per axis and span (the shader finds
  // them from the sizes).
  std::vector<double> nrm_tab;
  {
    const Vector3d du_dx = parameter_scale(L);
    for (int a = 0; a < 3; ++a) nrm_tab.insert(nrm_tab.end(), T.poly[a].coef.begin(), T.poly[a].coef.end());
    for (int a = 0; a < 3; ++a)
      for (double w : T.poly[a].inv_width) nrm_tab.push_back(w * du_dx[a] * scale);
  }
  std::vector<double> nrm_tab_dev(nrm_tab.size());  // 8 bytes per real in either precision
  put_reals(nrm_tab_dev.data(), nrm_tab.data(), nrm_tab.size(), ff);

  // Tiles and, per control point, the partials (tile * K^3 + local) that touch it.
  std::vector<std::int32_t> tiles;
  for (Index i = 0; i < nv;) {
    Index j = i;
    while (j < nv && j - i < kTile && cell[j] == cell[i]) ++j;
    tiles.insert(tiles.end(), {static_cast<std::int32_t>(i), static_cast<std::int32_t>(j - i), cell[i], 0});
    i = j;
  }
  n_tiles = static_cast<Index>(tiles.size() / 4);
  if (n_tiles * KKK >= (Index(1) << 31))
    throw InvalidInputError("VulkanDeformer: the mesh is too large for 32-bit device indices");
  std::vector<std::int32_t> comb_ptr(N + 1, 0), comb;
  {
    auto each = [&](auto&& f) {
      for (Index t = 0; t < n_tiles; ++t) {
        const Index base = tiles[4 * t + 2];
        int o = 0;
        for (int i = 0; i < T.order[0]; ++i)
          for (int j = 0; j < T.order[1]; ++j)
            for (int k = 0; k < T.order[2]; ++k, ++o)
              f(base + (Index(i) * dims[1] + j) * dims[2] + k, static_cast<std::int32_t>(t * KKK + o));
      }
    };
    each([&](Index cp, std::int32_t) { ++comb_ptr[cp + 1]; });
    for (Index k = 0; k < N; ++k) comb_ptr[k + 1] += comb_ptr[k];
    comb.resize(comb_ptr[N]);
    std::vector<std::int32_t> fill(comb_ptr.begin(), comb_ptr.end() - 1);
    each([&](Index cp, std::int32_t idx) { comb[fill[cp]++] = idx; });
  }

  g_vert = groups_for(nv, kMaxGroups);
  g_face = groups_for(nf, kMaxGroups);
  g_cp = groups_for(N, 256);
  g_tile = static_cast<std::uint32_t>(std::min<Index>(n_tiles, 65535));

  using B = detail::Buffer;
  auto mk = [&](Buf i, size_t bytes, const char* what) { buf[i] = B(*dev, bytes, B::DeviceLocal, what); };
  mk(bP, 12 * N, "control points");
  mk(bX, 12 * nv, "vertices");
  x_good = B(*dev, 12 * nv, B::DeviceLocal, "vertices of the last good frame");
  mk(bF, 12 * nf, "faces");
  mk(bAdjPtr, 4 * adj.indptr.size(), "adjacency");
  mk(bAdj, 4 * adj.faces.size(), "adjacency");
  mk(bSpan, 4 * span.size(), "spans");
  mk(bTau, 4 * tau.size(), "parameters");
  mk(bPoly, 4 * poly.size(), "basis table");
  mk(bTiles, 4 * tiles.size(), "tiles");
  mk(bPartial, 8 * size_t(n_tiles) * KKK, "tile partials");
  mk(bTileVol, 8 * n_tiles, "tile volumes");
  mk(bCombPtr, 4 * comb_ptr.size(), "combine lists");
  mk(bComb, 4 * comb.size(), "combine lists");
  mk(bAlpha, 8 * N, "coefficients");
  mk(bInvW, 8 * N, "inverse weights");
  mk(bDelta, 32 * N, "offsets");
  mk(bStats, 8 * ST_SIZE, "frame results");
  mk(bRed, 16 * kMaxGroups, "volume partials");
  // Placeholders until a frame asks for normals (prepare_normals): 36 bytes per vertex
  // that a caller who never asks does not pay.
  mk(bNrm0, 16, "rest normals");
  mk(bNrm, 16, "normals");
  mk(bNrmTab, 8 * nrm_tab.size(), "normals basis table");
  reserve(bFrame, &up_frame, 8 * FR_RHS, "frame parameters");
  reserve(bConsI, &up_cons_i, 4 * (CI_BASE + N + 1), "constraints");
  reserve(bConsD, &up_cons_d, 8, "constraints");
  reserve(bWork, nullptr, 8 * 6, "solve scratch");
  up_P = B(*dev, 12 * N, B::Upload, "control points (upload)");
  up_invw = B(*dev, 8 * N, B::Upload, "inverse weights (upload)");
  up_delta = B(*dev, 24 * N, B::Upload, "offsets (upload)");
  rb_delta = B(*dev, 24 * N, B::Readback, "offsets (read-back)");
  rb_stats = B(*dev, 8 * ST_SIZE, B::Readback, "frame results (read-back)");
  rb_red = B(*dev, 16 * kMaxGroups, B::Readback, "volume partials (read-back)");

  VkCommandPoolCreateInfo cpi{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  cpi.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  cpi.queueFamilyIndex = dev->family;
  detail::check(vkCreateCommandPool(d, &cpi, nullptr, &cmd_pool), "vkCreateCommandPool");
  VkCommandBufferAllocateInfo cai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  cai.commandPool = cmd_pool;
  cai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  cai.commandBufferCount = 1;
  detail::check(vkAllocateCommandBuffers(d, &cai, &cmd), "vkAllocateCommandBuffers");
  VkFenceCreateInfo fi{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  detail::check(vkCreateFence(d, &fi, nullptr, &fence), "vkCreateFence");
  if (dev->timestamps) {
    VkQueryPoolCreateInfo qi{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
    qi.queryType = VK_QUERY_TYPE_TIMESTAMP;
    qi.queryCount = kQueries;
    detail::check(vkCreateQueryPool(d, &qi, nullptr, &queries), "vkCreateQueryPool");
  }

  // One-time upload through temporary staging buffers, one submission.
  std::vector<B> staging;
  begin();
  auto put = [&](Buf i, const void* data, size_t bytes) {
    if (bytes == 0) return;
    staging.emplace_back(*dev, bytes, B::Upload, "staging");
    std::memcpy(staging.back().mapped(), data, bytes);
    copy(staging.back(), buf[i], bytes);
  };
  put(bX, X0.data(), 4 * X0.size());
  put(bF, Fs.data(), 12 * size_t(nf));
  put(bAdjPtr, adj.indptr.data(), 4 * adj.indptr.size());
  put(bAdj, adj.faces.data(), 4 * adj.faces.size());
  put(bSpan, span.data(), 4 * span.size());
  put(bTau, tau.data(), 4 * tau.size());
  put(bPoly, poly.data(), 4 * poly.size());
  put(bNrmTab, nrm_tab_dev.data(), 8 * nrm_tab_dev.size());
  put(bTiles, tiles.data(), 4 * tiles.size());
  put(bCombPtr, comb_ptr.data(), 4 * comb_ptr.size());
  put(bComb, comb.data(), 4 * comb.size());
  submit_and_wait();

  const std::array<std::int32_t, 11> spec = {T.order[0], T.order[1], T.order[2],
                                              dims[0], dims[1], dims[2],
                                              static_cast<std::int32_t>(nv), static_cast<std::int32_t>(nf),
                                              static_cast<std::int32_t>(n_tiles), poly_off[1], poly_off[2]};
  create_pipelines(spec);

  // No constraints until a frame has some: every frame's solve reads the block.
  begin();
  update_constraints({}, VectorXd::Ones(N));
  submit_and_wait();
}

bool VulkanDeformer::Impl::update_constraints(const std::vector<SparseVec>& rows, const VectorXd& inv_weight) {
  const Index nc = static_cast<Index>(rows.size());
  std::vector<std::int32_t> index;
  std::vector<double> value;
  index.reserve(nc * KKK);
  value.reserve(nc * KKK);
  for (const SparseVec& r : rows) {
    index.insert(index.end(), r.index.begin(), r.index.end());
    value.insert(value.end(), r.value.begin(), r.value.end());
  }
  // Without constraints the block does not depend on the weights.
  if (cons.valid && cons.index == index && cons.value == value &&
      (nc == 0 || (cons.inv_weight.size() == inv_weight.size() && cons.inv_weight == inv_weight)))
    return false;

  // Per control point, its entries s * KKK + o among the rows (s ascending: a fixed order).
  std::vector<std::int32_t> ptr(N + 1, 0), entry(index.size());
  for (std::int32_t c : index) ++ptr[c + 1];
  for (Index c = 0; c < N; ++c) ptr[c + 1] += ptr[c];
  {
    std::vector<std::int32_t> fill(ptr.begin(), ptr.end() - 1);
    for (size_t e = 0; e < index.size(); ++e) entry[fill[index[e]]++] = static_cast<std::int32_t>(e);
  }
  // C = R W^-1 R^T through those lists: only pairs of rows that share a control point.
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(nc, nc);
  for (Index c = 0; c < N; ++c)
    for (std::int32_t p = ptr[c]; p < ptr[c + 1]; ++p)
      for (std::int32_t q = ptr[c]; q < ptr[c + 1]; ++q)
        C(entry[p] / KKK, entry[q] / KKK) += value[entry[p]] * inv_weight[c] * value[entry[q]];

  // The CPU backend's checks of the constraint rows (solve.h); the volume row's are on
  // the device. A failure here is answered by the CPU backend's own error.
  bool bad = false;
  const double max_iw = inv_weight.size() ? inv_weight.maxCoeff() : 1.0;
  for (Index s = 0; s < nc && !bad; ++s) {
    double scale = 0;
    for (int o = 0; o < KKK; ++o) scale += value[s * KKK + o] * value[s * KKK + o];
    bad = !(C(s, s) > 1e-300) || !(C(s, s) > 1e-24 * scale * max_iw);
  }
  double hi = 1.0;
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(nc, nc);
  if (!bad && nc > 0) {
    const Eigen::VectorXd dg = C.diagonal().cwiseSqrt().cwiseInverse();
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(dg.asDiagonal() * C * dg.asDiagonal());
    const double lo = eig.eigenvalues().minCoeff();
    hi = std::max(1.0, eig.eigenvalues().maxCoeff());
    bad = !(lo > 1e-12 * eig.eigenvalues().maxCoeff());
    if (!bad)
      H = dg.asDiagonal() * eig.eigenvectors() * eig.eigenvalues().cwiseInverse().asDiagonal() *
          eig.eigenvectors().transpose() * dg.asDiagonal();
  }

  const size_t ci_size = CI_BASE + nc + (N + 1) + index.size();
  const size_t cd_size = std::max<size_t>(1, value.size() + 2 * size_t(nc) * nc);
  reserve(bConsI, &up_cons_i, 4 * ci_size, "constraints");
  reserve(bConsD, &up_cons_d, 8 * cd_size, "constraints");
  reserve(bWork, nullptr, 8 * 6 * std::max<size_t>(1, nc), "solve scratch");
  std::int32_t* ci = static_cast<std::int32_t*>(up_cons_i.mapped());
  std::fill(ci, ci + CI_BASE, 0);
  ci[CI_NC] = static_cast<std::int32_t>(nc);
  ci[CI_PTR] = static_cast<std::int32_t>(CI_BASE + nc);
  ci[CI_IDX] = static_cast<std::int32_t>(CI_BASE + nc + N + 1);
  ci[CI_G] = static_cast<std::int32_t>(value.size());
  ci[CI_H] = static_cast<std::int32_t>(value.size() + size_t(nc) * nc);
  for (Index s = 0; s < nc; ++s) ci[CI_BASE + s] = index[s * KKK];
  std::copy(ptr.begin(), ptr.end(), ci + ci[CI_PTR]);
  std::copy(entry.begin(), entry.end(), ci + ci[CI_IDX]);
  std::vector<double> cd(cd_size, 0.0);
  std::copy(value.begin(), value.end(), cd.begin());
  for (Index p = 0; p < nc; ++p)
    for (Index q = 0; q < nc; ++q) {
      cd[ci[CI_G] + p * nc + q] = C(p, q);
      cd[ci[CI_H] + p * nc + q] = H(p, q);
    }
  put_reals(up_cons_d.mapped(), cd.data(), cd_size, ff);
  copy(up_cons_i, buf[bConsI], 4 * ci_size);
  copy(up_cons_d, buf[bConsD], 8 * cd_size);

  cons.valid = true;
  cons.index = std::move(index);
  cons.value = std::move(value);
  cons.inv_weight = inv_weight;
  cons.bad = bad;
  cons.hi = hi;
  return true;
}

const VulkanDeformer::Impl::Recorded& VulkanDeformer::Impl::frame_commands(const Shape& shape) {
  ++frames;
  for (Recorded& r : recorded)
    if (r.shape == shape) {
      r.last_use = frames;
      return r;
    }
  if (recorded.size() >= kMaxRecorded) {
    auto old = std::min_element(recorded.begin(), recorded.end(),
                                [](const Recorded& a, const Recorded& b) { return a.last_use < b.last_use; });
    vkFreeCommandBuffers(d, cmd_pool, 1, &old->cb);
    recorded.erase(old);
  }
  Recorded r;
  r.shape = shape;
  r.last_use = frames;
  VkCommandBufferAllocateInfo cai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  cai.commandPool = cmd_pool;
  cai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  cai.commandBufferCount = 1;
  detail::check(vkAllocateCommandBuffers(d, &cai, &r.cb), "vkAllocateCommandBuffers");
  recorded.push_back(r);  // freed with the others if recording fails
  const VkCommandBuffer cb = r.cb;
  const int k = static_cast<int>(shape.axes.size());
  const bool steps = shape.mode == Shape::DeviceSteps;
  const std::uint32_t n_steps = static_cast<std::uint32_t>(shape.mode == Shape::Plain ? 0 : k);

  begin(cb, false);
  if (dev->timestamps) vkCmdResetQueryPool(cb, queries, 0, 3 + n_steps);
  if (dev->timestamps) vkCmdWriteTimestamp(cb, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, queries, 0);
  if (steps) {
    // Only device steps can fail after the frame ran (their solve finds zero or
    // dependent rows): keep the vertices it is about to overwrite. The barrier makes
    // the last submission's writes to them visible to this copy.
    barrier(cb);
    copy(cb, buf[bX], x_good, 12 * nv);
  }
  copy(cb, up_P, buf[bP], 12 * N);
  copy(cb, up_frame, buf[bFrame], buf[bFrame].size());
  if (shape.mode == Shape::HostOffsets) copy(cb, up_delta, buf[bDelta], 24 * N);
  if (steps) vkCmdFillBuffer(cb, buf[bDelta].handle(), 0, VK_WHOLE_SIZE, 0);
  barrier(cb);
  vkCmdBindDescriptorSets(cb, VK_PIPELINE_BIND_POINT_COMPUTE, layout, 0, 1, &set, 0, nullptr);
  Push pc;
  dispatch(cb, kFfd, g_vert, pc);
  // With device steps the first one measures the plain FFD's volume.
  if (shape.measure && !steps) {
    pc.slot = 0;
    dispatch(cb, kVolume, g_face, pc);
  }
  timestamp(cb, 1);
  for (int step = 0; step < k && shape.mode != Shape::Plain; ++step) {
    Push s;
    s.axis = shape.axes[step];
    s.step = step;
    s.left = k - step;
    s.flags = shape.open ? 4 : 0;
    if (steps) {
      dispatch(cb, kCoef, g_tile, s);
      dispatch(cb, kCombine, g_cp, s);
      dispatch(cb, kSolve, 1, s);
    }
    s.slot = steps ? 3 : s.axis;  // delta row: this step's offsets, or the axis's total
    dispatch(cb, kGather, g_vert, s);
    timestamp(cb, 2 + step);
  }
  if (shape.measure && shape.mode != Shape::Plain) {
    pc.slot = 1;
    dispatch(cb, kVolume, g_face, pc);
  }
  if (shape.normals) {
    // Of the corrected control points: P plus the offsets' three totals (rows 0-2 of
    // delta: accumulated by the device steps, or uploaded with the host's offsets).
    Push np;
    np.flags = shape.mode == Shape::Plain ? 0 : 8;
    dispatch(cb, kNormals, g_vert, np);
    copy(cb, buf[bNrm], rb_N, 12 * nv);
  }
  if (steps) copy(cb, buf[bDelta], rb_delta, 24 * N);
  if (steps) copy(cb, buf[bStats], rb_stats, 8 * ST_STEP_STRIDE * k);
  if (shape.measure) {
    const VkBufferCopy regions[2] = {{0, 0, 8 * g_face}, {8 * kMaxGroups, 8 * kMaxGroups, 8 * g_face}};
    vkCmdCopyBuffer(cb, buf[bRed].handle(), rb_red.handle(), 2, regions);
  }
  host_barrier(cb);
  timestamp(cb, 2 + n_steps);
  detail::check(vkEndCommandBuffer(cb), "vkEndCommandBuffer");
  recorded.back().n_steps = n_steps;
  return recorded.back();
}

// ---- public API ----------------------------------------------------------------

VulkanDeformer::VulkanDeformer(const Eigen::Ref<const RowMatrixX3d>& V, const Eigen::Ref<const RowMatrixX3i>& F,
                               Lattice L, OutsidePolicy policy, const std::string& device,
                               Precision precision)
    : impl_(std::make_unique<Impl>()) {
  // The shaders evaluate the lattice as given; periodic ties (lattice/periodic.h) are the CPU's.
  if (L.any_periodic())
    throw BackendUnavailableError(
        "VulkanDeformer: periodic lattices run on the CPU backends only (the device has no periodic ties)");
  // The CPU Deformer validates the input exactly as the CPU backend does and keeps
  // the exact (float64) rest volume, the edge report and the embedding.
  impl_->cpu = std::make_unique<Deformer>(V, F, std::move(L), policy);
  impl_->build(device, precision);
}

VulkanDeformer::~VulkanDeformer() = default;

const Deformer& VulkanDeformer::cpu() const { return *impl_->cpu; }
const DeviceInfo& VulkanDeformer::device() const { return impl_->dev->info; }
Precision VulkanDeformer::precision() const { return impl_->precision; }
FrameTimings VulkanDeformer::last_timings() const {
  std::lock_guard<std::mutex> lock(impl_->frame_mutex);
  return impl_->timings;
}
const Vector3d& VulkanDeformer::origin() const { return impl_->origin; }
double VulkanDeformer::scale() const { return impl_->scale; }
std::uint64_t VulkanDeformer::vertex_buffer_handle() const {
  return reinterpret_cast<std::uint64_t>(impl_->buf[Impl::bX].handle());
}
std::uint64_t VulkanDeformer::index_buffer_handle() const {
  return reinterpret_cast<std::uint64_t>(impl_->buf[Impl::bF].handle());
}
const std::vector<std::int32_t>& VulkanDeformer::vertex_order() const { return impl_->cpu->processing_order(); }

RowMatrixX3d VulkanDeformer::vertices() const {
  std::lock_guard<std::mutex> lock(impl_->frame_mutex);
  return impl_->read_vertices();
}

DeformResult VulkanDeformer::deform(const Eigen::Ref<const RowMatrixX3d>& P, const CorrectionOptions& opt,
                                    bool read_vertices, RowMatrixX3d* normals) {
  static const char axis_name[3] = {'x', 'y', 'z'};
  const auto t_start = std::chrono::steady_clock::now();
  Impl& m = *impl_;
  const Deformer& cpu = *m.cpu;
  const Index N = m.N;

  // --- options: the CPU backend's own checks (the free control points and the
  // method included), so both refuse the same input ----------------------------------
  const FramePlan pl = cpu.plan(P, opt);
  const bool correcting = pl.correcting;
  const bool measure = pl.measure;
  const double target = pl.target;
  // The device works with inverse weights scaled to a largest value of 1, as
  // solve_axis_offsets does on the CPU: the minimiser does not change, and the
  // sums stay in range whatever the units of the weights.
  const double wmax = pl.inv_weight.size() ? pl.inv_weight.maxCoeff() : 1.0;
  const VectorXd inv_weight = wmax > 0 ? VectorXd(pl.inv_weight / wmax) : pl.inv_weight;
  const size_t nc = opt.constraints.size();
  const std::vector<SparseVec>& rows = pl.rows;

  // --- what the device runs ---------------------------------------------------------
  const int naxes = static_cast<int>(opt.axes.size());
  const int k = correcting ? naxes * opt.rounds : 0;
  Shape shape;
  shape.measure = measure;
  shape.open = !cpu.is_closed();
  shape.normals = normals != nullptr;
  DeformResult res;
  res.offsets = RowMatrixX3d::Zero(N, 3);
  if (opt.preserve_volume) {
    shape.mode = Shape::DeviceSteps;
    for (int step = 0; step < k; ++step) shape.axes.push_back(opt.axes[step % naxes]);
  } else if (correcting) {
    // Constraints alone do not depend on the mesh: the CPU backend's own steps, on the
    // host (same offsets, same errors); the device applies each axis's total once.
    shape.mode = Shape::HostOffsets;
    constraint_steps(pl, P, opt, res);
    shape.axes = opt.axes;
  }

  // --- frame data ------------------------------------------------------------------------
  std::unique_lock<std::mutex> lock(m.frame_mutex);
  m.begin();  // one-time uploads, submitted just before the frame
  bool aux = false;
  if (shape.mode == Shape::DeviceSteps) {
    aux = m.update_constraints(rows, inv_weight);
    if (m.cons.bad) {
      // A constraint row that cannot move, or dependent rows: the CPU backend says which.
      detail::check(vkEndCommandBuffer(m.cmd), "vkEndCommandBuffer");
      m.submit_and_wait(&m.cmd, 1);  // the block is consistent with `cons` again
      lock.unlock();
      cpu.deform(P, opt);
      throw SolverError(vpffd::detail::concat("correction along ", axis_name[opt.axes[0]],
                                              ": the volume and point constraints are linearly dependent"));
    }
  }
  if (normals && m.prepare_normals()) aux = true;  // before frame_commands: it may rebind
  const bool new_invw = m.invw_uploaded.size() != N || m.invw_uploaded != inv_weight;
  if (new_invw && shape.mode == Shape::DeviceSteps) {
    put_reals(m.up_invw.mapped(), inv_weight.data(), N, m.ff);
    m.copy(m.up_invw, m.buf[Impl::bInvW], 8 * N);
    aux = true;
  }
  {
    float* p = static_cast<float*>(m.up_P.mapped());
    for (Index c = 0; c < N; ++c)
      for (int a = 0; a < 3; ++a) p[3 * c + a] = static_cast<float>((P(c, a) - m.origin[a]) / m.scale);
  }
  m.reserve(Impl::bFrame, &m.up_frame, 8 * (FR_RHS + 3 * nc), "frame parameters");
  {
    std::vector<double> fr(FR_RHS + 3 * nc, 0.0);
    // Volumes on the device are relative to the origin, like the CPU's; lengths in scale units.
    const double s = m.scale, s3 = s * s * s;
    fr[FR_TARGET] = target / s3;
    fr[FR_MAX_INVW] = inv_weight.maxCoeff();
    fr[FR_HI] = m.cons.hi;
    for (int a = 0; a < 3; ++a) {
      const std::vector<double> rhs = constraint_rhs(rows, opt.constraints, a, P.col(a));
      for (size_t i = 0; i < nc; ++i) fr[FR_RHS + a * nc + i] = rhs[i] / s;
    }
    put_reals(m.up_frame.mapped(), fr.data(), fr.size(), m.ff);
  }
  if (shape.mode == Shape::HostOffsets) {
    std::vector<double> dl(3 * N);
    for (int a = 0; a < 3; ++a)
      for (Index c = 0; c < N; ++c) dl[a * N + c] = res.offsets(c, a) / m.scale;
    put_reals(m.up_delta.mapped(), dl.data(), dl.size(), m.ff);
  }

  // --- submit: [uploads,] the recorded frame ---------------------------------------------
  const Impl::Recorded& rec = m.frame_commands(shape);
  detail::check(vkEndCommandBuffer(m.cmd), "vkEndCommandBuffer");
  VkCommandBuffer cbs[3];
  std::uint32_t n_cbs = 0;
  if (aux) cbs[n_cbs++] = m.cmd;
  cbs[n_cbs++] = rec.cb;
  if (read_vertices) cbs[n_cbs++] = m.readback();
  m.submit_and_wait(cbs, n_cbs);
  if (new_invw && shape.mode == Shape::DeviceSteps) m.invw_uploaded = inv_weight;
  if (normals && !m.normals_ready) {
    m.normals_ready = true;
    m.up_n0 = Impl::Buffer();
  }

  FrameTimings tm;
  const std::uint32_t ns = rec.n_steps;
  if (m.dev->timestamps) {
    std::uint64_t ts[kQueries] = {};
    detail::check(vkGetQueryPoolResults(m.d, m.queries, 0, 3 + ns, sizeof(std::uint64_t) * (3 + ns), ts,
                                        sizeof(std::uint64_t), VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
                  "vkGetQueryPoolResults");
    const double p = m.dev->timestamp_period_ns * 1e-6;
    tm.has_timestamps = true;
    tm.gpu_total = double(ts[2 + ns] - ts[0]) * p;
    tm.gpu_ffd = double(ts[1] - ts[0]) * p;
    for (std::uint32_t s = 0; s < ns; ++s) tm.gpu_steps.push_back(double(ts[2 + s] - ts[1 + s]) * p);
    tm.gpu_final = double(ts[2 + ns] - ts[1 + ns]) * p;
  }

  // --- results -------------------------------------------------------------------------
  // Step results: volume_before, share, sum_squares, max_offset, status, detail.
  // (in device units: lengths / scale, volumes / scale^3, sum_squares / scale^4)
  auto stat = [&](int step, int i) {
    return get_real(m.rb_stats.mapped(), ST_STEP + step * ST_STEP_STRIDE + i, m.ff);
  };
  const double s1 = m.scale, s3 = s1 * s1 * s1, s4 = s3 * s1;
  if (shape.mode == Shape::DeviceSteps) {
    for (int step = 0; step < k; ++step) {
      const char ax = axis_name[shape.axes[step]];
      const int status = static_cast<int>(stat(step, 4));
      if (status == 0) continue;
      // The frame ran but has no correction: its vertices must not outlive it.
      m.timings = tm;
      m.timings.host_total = ms_since(t_start);
      m.restore_vertices();
      if (status == 1)
        throw SolverError(vpffd::detail::concat("correction along ", ax,
                                                ": the volume coefficients of the free control points are all zero "
                                                "(the mesh is flat along this axis, or every control point that "
                                                "influences it is fixed)"));
      if (status == 3) {
        const double cond = stat(step, 5);  // < 0: infinite
        // The volume row depends on the constraints: the CPU backend gives its exact
        // message (its condition number); should its test pass, ours still stands.
        lock.unlock();
        cpu.deform(P, opt);
        throw SolverError(vpffd::detail::concat(
            "correction along ", ax, ": the volume and point constraints are linearly dependent (condition number ",
            cond < 0 ? std::numeric_limits<double>::infinity() : cond,
            "); two constraints on the same point, or a constraint the volume row already fixes?"));
      }
      throw DeviceError(vpffd::detail::concat("vulkan: the solve of step ", step, " reported status ", status));
    }
  }
  res.target_volume = opt.preserve_volume ? target : std::numeric_limits<double>::quiet_NaN();
  if (shape.mode == Shape::DeviceSteps) {
    for (int a = 0; a < 3; ++a)
      for (Index c = 0; c < N; ++c) res.offsets(c, a) = get_real(m.rb_delta.mapped(), a * N + c, m.ff) * s1;
    for (int step = 0; step < k; ++step) {
      AxisStep info;
      info.axis = shape.axes[step];
      info.volume_before = stat(step, 0) * s3;
      info.share = stat(step, 1) * s3;
      info.sum_squares = stat(step, 2) * wmax * s4;  // in the caller's weights
      info.max_offset = stat(step, 3) * s1;
      res.steps.push_back(info);
    }
  }
  res.control_points = P + res.offsets;
  if (measure) {
    // The volume passes' per-workgroup partials, added in a fixed order.
    double before = 0, after = 0;
    for (std::uint32_t g = 0; g < m.g_face; ++g) before += get_real(m.rb_red.mapped(), g, m.ff);
    for (std::uint32_t g = 0; g < m.g_face; ++g) after += get_real(m.rb_red.mapped(), kMaxGroups + g, m.ff);
    before *= s3;
    after *= s3;
    if (shape.mode == Shape::DeviceSteps && k > 0) before = stat(0, 0) * s3;
    if (shape.mode == Shape::Plain) after = before;
    res.volume_before = before;
    res.volume = after;
  }
  res.constraint_error = constraint_error(rows, res.control_points, opt.constraints);
  // Under the frame's lock: another thread's frame would overwrite rb_X.
  if (read_vertices) res.vertices = m.unpack_vertices();
  if (normals) *normals = m.unpack_normals();
  tm.host_total = ms_since(t_start);
  m.timings = std::move(tm);
  return res;
}

}  // namespace vpffd::vulkan
