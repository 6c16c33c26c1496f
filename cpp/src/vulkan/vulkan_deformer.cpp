// VulkanDeformer: one frame of volume-preserving FFD as one command buffer.
//
// Device data (all in the device's vertex order, vertices sorted by lattice cell):
//   X (3V float, positions minus the origin), F (3F int), vertex-face adjacency,
//   per vertex the first control point index and the local parameter per axis,
//   the per-span power-form basis table, the tiles (runs of <= 64 vertices of one
//   cell) and, per control point, the list of tile partials that touch it.
// A frame records: upload copies -> FFD -> volume -> per axis step [coefficients ->
// combine -> solve -> offsets -> max |offset| -> vertex update] -> volume -> copies
// of the offsets and the scalars to the host. See shaders/common.glsl for the
// precision and determinism rules.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <numeric>

#include "context.h"
#include "vpffd/backend/vulkan.h"
#include "vpffd/ffd/basis_matrix.h"

namespace vpffd::vulkan {

namespace {

const std::uint32_t kSpvFfd[] =
#include "vpffd/shaders/ffd.spv.inc"
    ;
const std::uint32_t kSpvCoef[] =
#include "vpffd/shaders/coef.spv.inc"
    ;
const std::uint32_t kSpvCombine[] =
#include "vpffd/shaders/combine.spv.inc"
    ;
const std::uint32_t kSpvSolve[] =
#include "vpffd/shaders/solve.spv.inc"
    ;
const std::uint32_t kSpvOffsets[] =
#include "vpffd/shaders/offsets.spv.inc"
    ;
const std::uint32_t kSpvGather[] =
#include "vpffd/shaders/gather.spv.inc"
    ;
const std::uint32_t kSpvVolume[] =
#include "vpffd/shaders/volume.spv.inc"
    ;
const std::uint32_t kSpvReduce[] =
#include "vpffd/shaders/reduce.spv.inc"
    ;

enum Pipe { kFfd, kCoef, kCombine, kSolve, kOffsets, kGather, kVolume, kReduce, kPipes };
struct Spv {
  const std::uint32_t* code;
  size_t bytes;
  const char* name;
};
const Spv kShaders[kPipes] = {
    {kSpvFfd, sizeof(kSpvFfd), "ffd"},           {kSpvCoef, sizeof(kSpvCoef), "coef"},
    {kSpvCombine, sizeof(kSpvCombine), "combine"}, {kSpvSolve, sizeof(kSpvSolve), "solve"},
    {kSpvOffsets, sizeof(kSpvOffsets), "offsets"}, {kSpvGather, sizeof(kSpvGather), "gather"},
    {kSpvVolume, sizeof(kSpvVolume), "volume"},  {kSpvReduce, sizeof(kSpvReduce), "reduce"},
};

// Frame parameter and stats layout: mirrors shaders/common.glsl.
constexpr int KMAX = 6;
constexpr int PD_TARGET = 0, PD_MAX_INVW = 1, PD_CONS = 8, PD_CONS_STRIDE = 3 * KMAX + 4;
constexpr int PD_GCC = PD_CONS + 32 * PD_CONS_STRIDE, PD_SIZE = PD_GCC + 32 * 32;
constexpr int PI_NC = 0, PI_CONS = 4, PI_SIZE = PI_CONS + 3 * 32;
constexpr int ST_VOL_BEFORE = 0, ST_VOL = 1, ST_STEP = 8, ST_STEP_STRIDE = 8, ST_LAMBDA = 64,
              ST_LAMBDA_STRIDE = 32, ST_SIZE = ST_LAMBDA + 3 * ST_LAMBDA_STRIDE;
constexpr int kTile = 64;        // vertices per tile = coef.comp's workgroup size
constexpr int kGroup = 256;      // workgroup size of the other passes
constexpr std::uint32_t kMaxGroups = 1024;  // grid-stride passes: fixed reduction shape
constexpr int kBindings = 20;
constexpr std::uint32_t kQueries = 8;

struct Push {
  std::int32_t axis = 0, step = 0, left = 1, flags = 0, slot = 0, count = 0;
};

std::uint32_t groups_for(std::int64_t n, std::uint32_t cap) {
  return static_cast<std::uint32_t>(std::clamp<std::int64_t>((n + kGroup - 1) / kGroup, 1, cap));
}

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

struct VulkanDeformer::Impl {
  using Buffer = detail::Buffer;
  std::shared_ptr<detail::Device> dev;  // first: destroyed last
  std::unique_ptr<Deformer> cpu;
  VkDevice d = VK_NULL_HANDLE;

  Index nv = 0, nf = 0, N = 0, n_tiles = 0;
  int KKK = 0;
  std::uint32_t g_vert = 1, g_face = 1, g_cp = 1, g_tile = 1;
  std::vector<std::int32_t> order;  // device vertex i is input vertex order[i]
  Vector3d origin;

  enum Buf {
    bP, bX, bF, bAdjPtr, bAdj, bSpan, bTau, bPoly, bTiles, bPartial, bTileVol, bCombPtr, bComb, bAlpha, bInvW,
    bDelta, bParD, bParI, bStats, bRed, kNumBuf
  };
  Buffer buf[kNumBuf];
  Buffer up_P, up_invw, up_par_d, up_par_i, rb_delta, rb_stats, rb_X;

  VkDescriptorSetLayout dsl = VK_NULL_HANDLE;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkDescriptorPool pool = VK_NULL_HANDLE;
  VkDescriptorSet set = VK_NULL_HANDLE;
  VkShaderModule modules[kPipes] = {};
  VkPipeline pipes[kPipes] = {};
  VkCommandPool cmd_pool = VK_NULL_HANDLE;
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  VkFence fence = VK_NULL_HANDLE;
  VkQueryPool queries = VK_NULL_HANDLE;

  std::mutex frame_mutex;  // one frame or read-back at a time per deformer (shared command buffer)
  bool pending = false;    // a submission whose fence was not waited for (after an error)
  VectorXd invw_uploaded;  // inverse weights on the device (empty: none yet)
  FrameTimings timings;

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
  void begin() {
    detail::check(vkResetCommandBuffer(cmd, 0), "vkResetCommandBuffer");
    VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    detail::check(vkBeginCommandBuffer(cmd, &bi), "vkBeginCommandBuffer");
  }

  void submit_and_wait() {
    detail::check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer");
    VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
    si.commandBufferCount = 1;
    si.pCommandBuffers = &cmd;
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

  // Everything before is visible to everything after (compute and transfer).
  void barrier() {
    VkMemoryBarrier mb{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    mb.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT;
    mb.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_READ_BIT |
                       VK_ACCESS_TRANSFER_WRITE_BIT;
    const VkPipelineStageFlags st = VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT;
    vkCmdPipelineBarrier(cmd, st, st, 0, 1, &mb, 0, nullptr, 0, nullptr);
  }

  void dispatch(Pipe p, std::uint32_t groups, const Push& pc) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipes[p]);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout, 0, 1, &set, 0, nullptr);
    vkCmdPushConstants(cmd, layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(Push), &pc);
    vkCmdDispatch(cmd, groups, 1, 1);
    barrier();
  }

  void copy(const Buffer& src, const Buffer& dst, VkDeviceSize bytes) {
    if (bytes == 0) return;
    VkBufferCopy c{0, 0, bytes};
    vkCmdCopyBuffer(cmd, src.handle(), dst.handle(), 1, &c);
  }

  void timestamp(std::uint32_t i) {
    if (dev->timestamps) vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, queries, i);
  }

  // ---- set-up ------------------------------------------------------------------
  void build(const std::string& selector);
  void create_pipelines(const std::array<std::int32_t, 12>& spec);
};

void VulkanDeformer::Impl::create_pipelines(const std::array<std::int32_t, 12>& spec) {
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

  VkSpecializationMapEntry entries[12];
  for (std::uint32_t i = 0; i < 12; ++i) entries[i] = {i, i * 4u, 4};
  VkSpecializationInfo si{12, entries, sizeof(spec), spec.data()};
  for (int p = 0; p < kPipes; ++p) {
    VkShaderModuleCreateInfo mi{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
    mi.codeSize = kShaders[p].bytes;
    mi.pCode = kShaders[p].code;
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
      throw DeviceError(std::string("vulkan: vkCreateComputePipelines (") + kShaders[p].name +
                        ") failed: " + detail::result_string(r));
  }
}

void VulkanDeformer::Impl::build(const std::string& selector) {
  dev = detail::open_device(selector);
  d = dev->handle;
  const Deformer& c = *cpu;
  const Lattice& L = c.lattice();
  const BasisTables& T = c.tables();
  const Embedding& E = c.embedding();
  nv = c.n_vertices();
  nf = c.n_faces();
  N = c.n_control_points();
  origin = c.origin();
  const auto dims = L.dims();
  KKK = T.order[0] * T.order[1] * T.order[2];
  if (nv * 3 >= (Index(1) << 31) || nf * 3 >= (Index(1) << 31))
    throw InvalidInputError("VulkanDeformer: the mesh is too large for 32-bit device indices");

  // Vertices sorted by cell (stable counting sort): a cell's vertices share their
  // K^3 control points, which the tiles of coef.comp reduce in shared memory.
  std::vector<std::int32_t> cell(nv);
  for (Index v = 0; v < nv; ++v) {
    const int i0 = E.span[0][v] - T.poly[0].degree, j0 = E.span[1][v] - T.poly[1].degree,
              k0 = E.span[2][v] - T.poly[2].degree;
    cell[v] = static_cast<std::int32_t>((Index(i0) * dims[1] + j0) * dims[2] + k0);
  }
  {
    std::vector<Index> count(N + 1, 0);
    for (Index v = 0; v < nv; ++v) ++count[cell[v] + 1];
    for (Index k = 0; k < N; ++k) count[k + 1] += count[k];
    order.resize(nv);
    for (Index v = 0; v < nv; ++v) order[count[cell[v]]++] = static_cast<std::int32_t>(v);
  }
  std::vector<std::int32_t> rank(nv);
  for (Index i = 0; i < nv; ++i) rank[order[i]] = static_cast<std::int32_t>(i);

  // Faces renumbered, then ordered by their lowest vertex for locality.
  const RowMatrixX3i& F0 = c.faces();
  std::vector<std::int32_t> forder(nf);
  std::vector<std::int32_t> fkey(nf);
  for (Index f = 0; f < nf; ++f) {
    fkey[f] = std::min({rank[F0(f, 0)], rank[F0(f, 1)], rank[F0(f, 2)]});
    forder[f] = static_cast<std::int32_t>(f);
  }
  std::stable_sort(forder.begin(), forder.end(), [&](std::int32_t a, std::int32_t b) { return fkey[a] < fkey[b]; });
  RowMatrixX3i Fs(nf, 3);
  for (Index f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) Fs(f, k) = rank[F0(forder[f], k)];
  const VertexFaces adj = vertex_faces(Fs, nv);

  std::vector<std::int32_t> span(3 * nv);
  std::vector<float> tau(3 * nv), X0(3 * nv);
  const RowMatrixX3d& V = c.rest_vertices();
  for (Index i = 0; i < nv; ++i) {
    const Index v = order[i];
    for (int a = 0; a < 3; ++a) {
      span[3 * i + a] = E.span[a][v] - T.poly[a].degree;
      tau[3 * i + a] = static_cast<float>(E.tau[a][v]);
      X0[3 * i + a] = static_cast<float>(V(v, a) - origin[a]);
    }
  }
  std::vector<float> poly;
  std::array<std::int32_t, 3> poly_off{};
  for (int a = 0; a < 3; ++a) {
    poly_off[a] = static_cast<std::int32_t>(poly.size());
    for (double x : T.poly[a].coef) poly.push_back(static_cast<float>(x));
  }

  // Tiles and, per control point, the partials (tile * K^3 + local) that touch it.
  std::vector<std::int32_t> tiles;
  for (Index i = 0; i < nv;) {
    Index j = i;
    while (j < nv && j - i < kTile && cell[order[j]] == cell[order[i]]) ++j;
    tiles.insert(tiles.end(), {static_cast<std::int32_t>(i), static_cast<std::int32_t>(j - i), cell[order[i]], 0});
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
  mk(bDelta, 24 * N, "offsets");
  mk(bParD, 8 * PD_SIZE, "frame parameters");
  mk(bParI, 4 * PI_SIZE, "frame parameters");
  mk(bStats, 8 * ST_SIZE, "frame results");
  mk(bRed, 8 * std::max<std::uint32_t>({g_face, g_cp, 1u}), "reductions");
  up_P = B(*dev, 12 * N, B::Upload, "control points (upload)");
  up_invw = B(*dev, 8 * N, B::Upload, "inverse weights (upload)");
  up_par_d = B(*dev, 8 * PD_SIZE, B::Upload, "frame parameters (upload)");
  up_par_i = B(*dev, 4 * PI_SIZE, B::Upload, "frame parameters (upload)");
  rb_delta = B(*dev, 24 * N, B::Readback, "offsets (read-back)");
  rb_stats = B(*dev, 8 * ST_SIZE, B::Readback, "frame results (read-back)");

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
  put(bTiles, tiles.data(), 4 * tiles.size());
  put(bCombPtr, comb_ptr.data(), 4 * comb_ptr.size());
  put(bComb, comb.data(), 4 * comb.size());
  submit_and_wait();

  const std::array<std::int32_t, 12> spec = {T.order[0], T.order[1], T.order[2],
                                              dims[0], dims[1], dims[2],
                                              static_cast<std::int32_t>(nv), static_cast<std::int32_t>(nf),
                                              static_cast<std::int32_t>(n_tiles), poly_off[1], poly_off[2],
                                              max_constraints};
  create_pipelines(spec);
}

// ---- public API ----------------------------------------------------------------

VulkanDeformer::VulkanDeformer(const Eigen::Ref<const RowMatrixX3d>& V, const Eigen::Ref<const RowMatrixX3i>& F,
                               Lattice L, OutsidePolicy policy, const std::string& device)
    : impl_(std::make_unique<Impl>()) {
  // The CPU Deformer validates the input exactly as the CPU backend does and keeps
  // the exact (float64) rest volume, the edge report and the embedding.
  impl_->cpu = std::make_unique<Deformer>(V, F, std::move(L), policy);
  impl_->build(device);
}

VulkanDeformer::~VulkanDeformer() = default;

const Deformer& VulkanDeformer::cpu() const { return *impl_->cpu; }
const DeviceInfo& VulkanDeformer::device() const { return impl_->dev->info; }
const FrameTimings& VulkanDeformer::last_timings() const { return impl_->timings; }
const Vector3d& VulkanDeformer::origin() const { return impl_->origin; }
std::uint64_t VulkanDeformer::vertex_buffer_handle() const {
  return reinterpret_cast<std::uint64_t>(impl_->buf[Impl::bX].handle());
}
std::uint64_t VulkanDeformer::index_buffer_handle() const {
  return reinterpret_cast<std::uint64_t>(impl_->buf[Impl::bF].handle());
}
const std::vector<std::int32_t>& VulkanDeformer::vertex_order() const { return impl_->order; }

RowMatrixX3d VulkanDeformer::vertices() const {
  Impl& m = *impl_;
  std::lock_guard<std::mutex> lock(m.frame_mutex);
  if (!m.rb_X.handle()) m.rb_X = detail::Buffer(*m.dev, 12 * m.nv, detail::Buffer::Readback, "vertices (read-back)");
  m.begin();
  m.copy(m.buf[Impl::bX], m.rb_X, 12 * m.nv);
  m.submit_and_wait();
  const float* x = static_cast<const float*>(m.rb_X.mapped());
  RowMatrixX3d out(m.nv, 3);
  for (Index i = 0; i < m.nv; ++i)
    for (int a = 0; a < 3; ++a) out(m.order[i], a) = double(x[3 * i + a]) + m.origin[a];
  return out;
}

DeformResult VulkanDeformer::deform(const Eigen::Ref<const RowMatrixX3d>& P, const CorrectionOptions& opt,
                                    bool read_vertices) {
  static const char axis_name[3] = {'x', 'y', 'z'};
  const auto t_start = std::chrono::steady_clock::now();
  Impl& m = *impl_;
  const Deformer& cpu = *m.cpu;
  const Lattice& L = cpu.lattice();
  const BasisTables& T = cpu.tables();
  const Index N = m.N;

  // --- options: the same checks and messages as Deformer::deform ----------------
  VPFFD_CHECK(P.rows() == N, "deform", ": ", P.rows(), " control points, the lattice has ", N);
  VPFFD_CHECK(P.allFinite(), "deform", ": control points contain NaN or Inf");
  VPFFD_CHECK(opt.rounds == 1, "deform: rounds is ", opt.rounds,
              "; the vulkan backend runs the paper's single round (rounds=1)");
  const bool correcting = opt.preserve_volume || !opt.constraints.empty();
  if (correcting) VPFFD_CHECK(!opt.axes.empty(), "deform: axes is empty; name at least one of x, y, z");
  for (int a : opt.axes) VPFFD_CHECK(a >= 0 && a < 3, "deform: axis ", a, " not in 0..2");
  VectorXd inv_weight = VectorXd::Ones(N);
  if (opt.weights.size() > 0) {
    VPFFD_CHECK(opt.weights.size() == N, "deform: ", opt.weights.size(), " weights, expected one per control point (",
                N, ")");
    for (Index c = 0; c < N; ++c)
      VPFFD_CHECK(std::isfinite(opt.weights[c]) && opt.weights[c] > 0, "deform: weight ", c, " is ", opt.weights[c],
                  "; weights must be finite and positive (use fixed= to pin control points)");
    inv_weight = opt.weights.cwiseInverse();
  }
  if (!opt.fixed.empty()) {
    VPFFD_CHECK(Index(opt.fixed.size()) == N, "deform: fixed has ", opt.fixed.size(),
                " entries, expected one per control point (", N, ")");
    for (Index c = 0; c < N; ++c)
      if (opt.fixed[c]) inv_weight[c] = 0.0;
  }
  if (opt.preserve_volume && !opt.allow_open) require_closed(cpu.edges(), "deform(preserve_volume=True)");
  const bool measure = cpu.is_closed() || opt.allow_open;
  const double target = std::isnan(opt.target_volume) ? cpu.rest_volume(true) : opt.target_volume;
  VPFFD_CHECK(std::isfinite(target), "deform: target_volume is ", target, "; expected a finite number");

  const size_t nc = opt.constraints.size();
  std::vector<SparseVec> rows(nc);
  Embedding Ec;
  {
    RowMatrixX3d pts(static_cast<Index>(nc), 3);
    for (size_t s = 0; s < nc; ++s) {
      const PointConstraint& pc = opt.constraints[s];
      VPFFD_CHECK(pc.target.allFinite(), "deform: constraint ", s, " has a non-finite target");
      if (pc.vertex >= 0) {
        VPFFD_CHECK(pc.vertex < cpu.n_vertices(), "deform: constraint ", s, " names vertex ", pc.vertex,
                    ", but there are ", cpu.n_vertices(), " vertices");
        pts.row(s) = cpu.rest_vertices().row(pc.vertex);
      } else {
        VPFFD_CHECK(pc.point.allFinite(), "deform: constraint ", s, " has a non-finite source point");
        pts.row(s) = pc.point.transpose();
      }
    }
    Ec = embed(L, pts, cpu.outside_policy(), 1, "constraint point");
    const int per = T.order[0] * T.order[1] * T.order[2];
    for (size_t s = 0; s < nc; ++s) {
      rows[s].index.resize(per);
      rows[s].value.resize(per);
      point_basis_entries(T, Ec, static_cast<Index>(s), rows[s].index.data(), rows[s].value.data());
    }
  }
  VPFFD_CHECK(nc <= size_t(max_constraints), "deform: the vulkan backend takes at most ", max_constraints,
              " point constraints per frame, got ", nc, "; use backend='cpu' for more");
  auto row_dot = [&](const SparseVec& r, const Eigen::Ref<const VectorXd>& x) {
    double s = 0;
    for (size_t q = 0; q < r.index.size(); ++q) s += r.value[q] * x[r.index[q]];
    return s;
  };
  std::vector<bool> corrected(3, false);
  for (int a : opt.axes) corrected[a] = correcting;
  const double diag = (L.box_max - L.box_min).norm();
  for (size_t s = 0; s < nc; ++s)
    for (int a = 0; a < 3; ++a)
      if (!corrected[a]) {
        const double S = row_dot(rows[s], P.col(a));
        VPFFD_CHECK(std::abs(S - opt.constraints[s].target[a]) <= 1e-9 * diag, "deform: constraint ", s,
                    " moves its point along ", axis_name[a], " (from ", S, " to ", opt.constraints[s].target[a],
                    "), but ", axis_name[a], " is not among the corrected axes");
      }
  if (opt.preserve_volume && !cpu.is_closed())
    VPFFD_CHECK(opt.method == CoefficientMethod::Traversal,
                "deform: method='csr' needs a closed mesh; use method='traversal' with allow_open");
  if (correcting) {
    const int nrows = (opt.preserve_volume ? 1 : 0) + static_cast<int>(nc);
    Index free_points = 0;
    for (Index c = 0; c < N; ++c) free_points += inv_weight[c] > 0;
    if (nrows > free_points)
      throw SolverError(vpffd::detail::concat("correction along ", axis_name[opt.axes[0]], ": ", nrows, " conditions (",
                                       opt.preserve_volume ? "volume + " : "", nc, " point constraints) but only ",
                                       free_points, " free control points"));
  }

  // --- frame parameters ------------------------------------------------------------
  std::unique_lock<std::mutex> lock(m.frame_mutex);
  {
    float* p = static_cast<float*>(m.up_P.mapped());
    for (Index c = 0; c < N; ++c)
      for (int a = 0; a < 3; ++a) p[3 * c + a] = static_cast<float>(P(c, a) - m.origin[a]);
  }
  const bool new_invw = m.invw_uploaded.size() != N || m.invw_uploaded != inv_weight;
  if (new_invw) std::memcpy(m.up_invw.mapped(), inv_weight.data(), 8 * N);
  {
    double* pd = static_cast<double*>(m.up_par_d.mapped());
    std::int32_t* pi = static_cast<std::int32_t*>(m.up_par_i.mapped());
    std::fill(pd, pd + PD_SIZE, 0.0);
    std::fill(pi, pi + PI_SIZE, 0);
    // Volumes on the device are relative to the origin, like the CPU's.
    pd[PD_TARGET] = target;
    pd[PD_MAX_INVW] = inv_weight.maxCoeff();
    pi[PI_NC] = static_cast<std::int32_t>(nc);
    std::vector<double> dense(N, 0.0);
    for (size_t s = 0; s < nc; ++s) {
      double* o = pd + PD_CONS + s * PD_CONS_STRIDE;
      for (int a = 0; a < 3; ++a) {
        const int sp = Ec.span[a][s];
        double vals[KMAX] = {};
        eval_span(T.poly[a].span_coef(sp), T.order[a], Ec.tau[a][s], vals);
        for (int r = 0; r < T.order[a]; ++r) o[a * KMAX + r] = vals[r];
        pi[PI_CONS + 3 * s + a] = sp - T.poly[a].degree;
        o[3 * KMAX + a] = opt.constraints[s].target[a] - row_dot(rows[s], P.col(a));
      }
      double n2 = 0;
      for (double v : rows[s].value) n2 += v * v;
      o[3 * KMAX + 3] = n2;
    }
    // The constraint block of G = R W^-1 R^T does not depend on the frame's mesh.
    for (size_t t = 0; t < nc; ++t) {
      for (size_t q = 0; q < rows[t].index.size(); ++q) dense[rows[t].index[q]] += rows[t].value[q];
      for (size_t s = 0; s < nc; ++s) {
        double g = 0;
        for (size_t q = 0; q < rows[s].index.size(); ++q)
          g += rows[s].value[q] * inv_weight[rows[s].index[q]] * dense[rows[s].index[q]];
        pd[PD_GCC + s * nc + t] = g;
      }
      for (size_t q = 0; q < rows[t].index.size(); ++q) dense[rows[t].index[q]] = 0.0;
    }
  }

  // --- record and submit ---------------------------------------------------------------
  const int k = correcting ? static_cast<int>(opt.axes.size()) : 0;
  m.begin();
  if (m.dev->timestamps) vkCmdResetQueryPool(m.cmd, m.queries, 0, kQueries);
  if (m.dev->timestamps) vkCmdWriteTimestamp(m.cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, m.queries, 0);
  m.copy(m.up_P, m.buf[Impl::bP], 12 * N);
  if (new_invw) m.copy(m.up_invw, m.buf[Impl::bInvW], 8 * N);
  m.copy(m.up_par_d, m.buf[Impl::bParD], 8 * PD_SIZE);
  m.copy(m.up_par_i, m.buf[Impl::bParI], 4 * PI_SIZE);
  vkCmdFillBuffer(m.cmd, m.buf[Impl::bDelta].handle(), 0, VK_WHOLE_SIZE, 0);
  vkCmdFillBuffer(m.cmd, m.buf[Impl::bStats].handle(), 0, VK_WHOLE_SIZE, 0);
  m.barrier();
  Push pc;
  m.dispatch(kFfd, m.g_vert, pc);
  // With a volume correction the first axis step measures the plain FFD's volume.
  const bool step_measures = opt.preserve_volume && k > 0;
  if (measure && !step_measures) {
    m.dispatch(kVolume, m.g_face, pc);
    Push r;
    r.slot = ST_VOL_BEFORE;
    r.count = static_cast<std::int32_t>(m.g_face);
    m.dispatch(kReduce, 1, r);
  }
  m.timestamp(1);
  for (int step = 0; step < k; ++step) {
    Push s;
    s.axis = opt.axes[step];
    s.step = step;
    s.left = k - step;
    s.flags = (opt.preserve_volume ? 1 : 0) | (cpu.is_closed() ? 0 : 4);
    if (opt.preserve_volume) {
      m.dispatch(kCoef, m.g_tile, s);
      m.dispatch(kCombine, m.g_cp, s);
    }
    m.dispatch(kSolve, 1, s);
    m.dispatch(kOffsets, m.g_cp, s);
    Push r;
    r.flags = 2;
    r.slot = ST_STEP + step * ST_STEP_STRIDE + 3;
    r.count = static_cast<std::int32_t>(m.g_cp);
    m.dispatch(kReduce, 1, r);
    m.dispatch(kGather, m.g_vert, s);
    m.timestamp(2 + step);
  }
  if (measure) {
    m.dispatch(kVolume, m.g_face, pc);
    Push r;
    r.slot = ST_VOL;
    r.count = static_cast<std::int32_t>(m.g_face);
    m.dispatch(kReduce, 1, r);
  }
  m.copy(m.buf[Impl::bDelta], m.rb_delta, 24 * N);
  m.copy(m.buf[Impl::bStats], m.rb_stats, 8 * ST_SIZE);
  m.barrier();
  m.timestamp(5);
  m.submit_and_wait();
  if (new_invw) m.invw_uploaded = inv_weight;

  FrameTimings& tm = m.timings;
  tm = FrameTimings{};
  if (m.dev->timestamps) {
    std::uint64_t ts[kQueries] = {};
    // Only the written queries: 0, 1, 2..1+k, 5.
    detail::check(vkGetQueryPoolResults(m.d, m.queries, 0, 2 + k, sizeof(std::uint64_t) * (2 + k), ts,
                                        sizeof(std::uint64_t), VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
                  "vkGetQueryPoolResults");
    detail::check(vkGetQueryPoolResults(m.d, m.queries, 5, 1, sizeof(std::uint64_t), ts + 5, sizeof(std::uint64_t),
                                        VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
                  "vkGetQueryPoolResults");
    const double p = m.dev->timestamp_period_ns * 1e-6;
    tm.has_timestamps = true;
    tm.gpu_total = double(ts[5] - ts[0]) * p;
    tm.gpu_ffd = double(ts[1] - ts[0]) * p;
    for (int s = 0; s < k; ++s) tm.gpu_steps.push_back(double(ts[2 + s] - ts[1 + s]) * p);
    tm.gpu_final = double(ts[5] - ts[1 + k]) * p;
  }

  // --- results -------------------------------------------------------------------------
  const double* st = static_cast<const double*>(m.rb_stats.mapped());
  for (int step = 0; step < k; ++step) {
    const double* q = st + ST_STEP + step * ST_STEP_STRIDE;
    const char ax = axis_name[opt.axes[step]];
    const int status = static_cast<int>(q[4]);
    if (status == 1)
      throw SolverError(vpffd::detail::concat("correction along ", ax,
                                       ": the volume coefficients of the free control points are all zero "
                                       "(the mesh is flat along this axis, or every control point that "
                                       "influences it is fixed)"));
    if (status == 2)
      throw SolverError(vpffd::detail::concat("correction along ", ax, ": point constraint ", static_cast<int>(q[5]),
                                       " cannot move: every control point that influences it is fixed"));
    if (status == 3)
      throw SolverError(vpffd::detail::concat("correction along ", ax, ": the ",
                                       opt.preserve_volume ? "volume and point" : "point",
                                       " constraints are linearly dependent (condition number ", q[5],
                                       "); two constraints on the same point, or a constraint the volume row "
                                       "already fixes?"));
  }
  DeformResult res;
  res.target_volume = opt.preserve_volume ? target : std::numeric_limits<double>::quiet_NaN();
  res.offsets = RowMatrixX3d::Zero(N, 3);
  const double* dl = static_cast<const double*>(m.rb_delta.mapped());
  for (int a = 0; a < 3; ++a)
    for (Index c = 0; c < N; ++c) res.offsets(c, a) = dl[a * N + c];
  res.control_points = P + res.offsets;
  if (measure) {
    res.volume_before = step_measures ? st[ST_STEP] : st[ST_VOL_BEFORE];
    res.volume = st[ST_VOL];
  }
  for (int step = 0; step < k; ++step) {
    const double* q = st + ST_STEP + step * ST_STEP_STRIDE;
    AxisStep info;
    info.axis = opt.axes[step];
    if (opt.preserve_volume) {
      info.volume_before = q[0];
      info.share = q[1];
      info.sum_squares = q[2];
    }
    info.max_offset = q[3];
    res.steps.push_back(info);
  }
  for (size_t s = 0; s < nc; ++s)
    for (int a = 0; a < 3; ++a)
      res.constraint_error = std::max(res.constraint_error, std::abs(row_dot(rows[s], res.control_points.col(a)) -
                                                                     opt.constraints[s].target[a]));
  lock.unlock();
  if (read_vertices) res.vertices = vertices();
  tm.host_total = ms_since(t_start);
  return res;
}

}  // namespace vpffd::vulkan
