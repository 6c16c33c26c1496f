#pragma once
// The state of a VulkanDeformer (private to the backend): the device buffers, the
// pipelines, the recorded frames and the command helpers every part of the backend
// uses. The parts: setup.cpp (buffers, uploads, pipelines), rest_embedding.cpp (the
// rest positions and their embedding on the device, set_rest_vertices),
// constraint_block.cpp (the point constraints' block), frame_recorder.cpp (a frame's
// command buffer) and vulkan_deformer.cpp (the public API and a frame's host side).

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <vector>

#include "context.h"
#include "pipelines.h"
#include "shaders/layout.h"
#include "vk_handle.h"
#include "vpffd/backend/vulkan.h"
#include "vpffd/core/parallel.h"
#include "vpffd/shaders/pipes.h"

namespace vpffd::vulkan {

namespace detail {

// Device reals (shaders/real.glsl): a double, or a float pair (hi, lo) with value
// hi + lo, in the same 8 bytes.
inline void put_reals(void* dst, const double* src, size_t n, bool ff) {
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
inline double get_real(const void* src, size_t i, bool ff) {
  if (!ff) return static_cast<const double*>(src)[i];
  const float* f = static_cast<const float*>(src);
  return double(f[2 * i]) + double(f[2 * i + 1]);
}

constexpr int kMaxSteps = 3 * kMaxRounds;  // distinct axes (Deformer::plan checks) x rounds
constexpr int ST_SIZE = ST_STEP + kMaxSteps * ST_STEP_STRIDE;
constexpr int kTile = VPFFD_TILE;
constexpr int kGroup = VPFFD_GROUP;
constexpr std::uint32_t kMaxGroups = VPFFD_RED_STRIDE;
constexpr std::uint32_t kQueries = 3 + kMaxSteps;
// After the frame's queries: the start and end of a move's device embedding (embed_cb),
// then those of the read back (readback_cb).
constexpr std::uint32_t kMoveQuery = kQueries;
constexpr std::uint32_t kReadbackQuery = kQueries + 2;
constexpr size_t kMaxRecorded = 4;  // frame command buffers kept, one per options shape

// The push constants: the `Push` block of shaders/common.glsl, field by field.
struct Push {
  std::int32_t axis = 0, step = 0, left = 1, flags = 0, slot = 0, count = 0;
};
static_assert(sizeof(Push) == 6 * 4, "Push mirrors the push_constant block of common.glsl");

inline std::uint32_t groups_for(std::int64_t n, std::uint32_t cap) {
  return static_cast<std::uint32_t>(std::clamp<std::int64_t>((n + kGroup - 1) / kGroup, 1, cap));
}

inline double ms_since(std::chrono::steady_clock::time_point t0) {
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

// Commands of another device class (VulkanMultires) that run after a VulkanDeformer's
// frame in the same vkQueueSubmit and read what the frame left in the device buffers:
// no host round trip between the correction and what follows it.
struct FrameTail {
  // Called with the frame's lock held, after its data are staged, before the submission;
  // `corrected`: delta's rows 0-2 hold the frame's offsets (else P alone drives it).
  std::function<VkCommandBuffer(bool corrected)> record;
  // Called after the wait, with the lock still held (the frame's results are final).
  std::function<void()> finish;
};

}  // namespace detail

using detail::kBindings;
using detail::Push;
using detail::Shape;
using detail::kGroup;
using detail::kMaxGroups;
using detail::kMaxRecorded;
using detail::kMaxSteps;
using detail::kMoveQuery;
using detail::kQueries;
using detail::kReadbackQuery;
using detail::kTile;
using detail::ST_SIZE;

struct VulkanDeformer::Impl {
  using Buffer = detail::Buffer;
  std::shared_ptr<detail::Device> dev;  // first: destroyed last
  // What no move changes (lattice, faces, parts, tables), and the construction's rest
  // state (frame/rest_state.h): the device's set-up reads it, and frames plan against it
  // (after a move with vertex constraints as points: plan_options). Shared with the host
  // Deformer that synced_cpu() makes: one embedding of the first rest mesh in all.
  std::shared_ptr<const FrameTopology> topo;
  std::shared_ptr<const RestState> plan_state;
  std::unique_ptr<Deformer> host;  // cpu(): made on first use, follows moves lazily
  VkDevice d = VK_NULL_HANDLE;
  Precision precision = Precision::Float64;
  bool ff = false;  // float-float reals on the device

  // N: control points a frame takes (the distinct ones of a periodic lattice); NE: those
  // the spline evaluates (the extended lattice; N without periodic axes).
  Index nv = 0, nf = 0, N = 0, NE = 0, n_tiles = 0;  // n_tiles: NTILE, an upper bound of the real tiles
  int KKK = 0;
  // Parts (each keeping its own volume; 1 without parts or with one part): the device
  // sorts each part's slots into one range (the sort key is part * NE + cell), combine
  // writes one coefficient row per part, solve.comp takes one volume row per part and
  // volume.comp sums each part's faces (grouped by part, part_face_start) in its own
  // g_part workgroups. The host's rest part volumes after a move sum the CPU
  // Deformer's part_faces() (fixed at construction), as its own moves do.
  int K = 1;
  std::uint32_t g_part = 1;
  std::uint32_t g_vert = 1, g_face = 1, g_cp = 1, g_tile = 1;
  // combine.comp: invocations per coefficient row (its LANES) and workgroups.
  int row_lanes = 1;
  std::uint32_t g_rows = 1;
  // Workgroups of a volume pass, and so its partials in `red` (per part: g_part each).
  std::uint32_t red_groups() const { return K > 1 ? std::uint32_t(K) * g_part : g_face; }
  Vector3d origin;
  double scale = 1.0;  // device lengths = world lengths / scale (a power of two)

  // The rest mesh (rest_embedding.cpp). Device vertex slot i is input vertex slot[i]
  // for the deformer's life (the construction's cell order): faces and adjacency
  // never change; a move re-embeds and re-sorts the slots on the device.
  std::vector<std::int32_t> slot;
  mutable RowMatrixX3d rest;  // input order, world units (stale after set_rest_offsets: rest_positions())
  RowMatrixX3d spare_rest;   // stage_rest's copy of the next rest positions (swapped in on success)
  // The rest volume (cone volume from the origin, as Deformer::rest_volume(true)) and,
  // with parts, each part's (the default targets): summed from `rest` on first use.
  // Replaced, not reset, by a move (under frame_mutex, as every read).
  std::shared_ptr<const Lazy<RestVolumes>> rest_vols = std::make_shared<Lazy<RestVolumes>>();
  bool moved = false;        // set_rest_vertices ran: `host` may lag behind (cpu_stale)
  bool cpu_stale = false;    // `host` is of an older rest mesh (synced_cpu() re-embeds it)
  std::mutex cpu_mutex;
  std::uint32_t sort_blocks = 1, sort_passes = 2;
  VkCommandBuffer embed_cb = VK_NULL_HANDLE;  // upload of up_rest and the device embedding
  // set_rest_offsets' (rest_embedding.cpp): upload of up_offsets and the embedding of the
  // base positions (rest[] on the device) plus each part's offset.
  VkCommandBuffer offset_cb = VK_NULL_HANDLE;
  bool embed_pending = false;  // a move's embed_cb waits for the next submission (rest_embedding.cpp)
  bool offsets_pending = false;  // ... and it is offset_cb
  // set_rest_offsets' state on the host. base: the positions the offsets move from (those
  // of construction or of the last set_rest_vertices; empty before the first offset move),
  // base_box: each part's bounding box in them (K x 6: low x y z, high x y z), offsets: the
  // last move's (K x 3). `rest` becomes base + offsets when first read (rest_positions()).
  RowMatrixX3d base;
  Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor> base_box;
  RowMatrixX3d offsets;
  mutable bool rest_stale = false;  // `rest` is older than base + offsets
  mutable std::mutex rest_mutex;
  bool volumes_of_base = false;     // rest_vols are the base's (translations keep them)
  Index offsets_at = 0;             // the first offset's real in rest[] (layout.h)

  // The device buffers, by their binding numbers (shaders/layout.h).
  enum Buf {
    bP = VPFFD_B_P, bX = VPFFD_B_X, bF = VPFFD_B_F, bAdjPtr = VPFFD_B_ADJ_PTR, bAdj = VPFFD_B_ADJ,
    bSpan = VPFFD_B_SPAN, bTau = VPFFD_B_TAU, bPoly = VPFFD_B_POLY, bTiles = VPFFD_B_TILES,
    bPartial = VPFFD_B_PARTIAL, bTileVol = VPFFD_B_TILE_VOL, bScan = VPFFD_B_SCAN, bRest = VPFFD_B_REST,
    bAlpha = VPFFD_B_ALPHA, bInvW = VPFFD_B_INV_W, bDelta = VPFFD_B_DELTA, bFrame = VPFFD_B_FRAME,
    bConsI = VPFFD_B_CONS_I, bStats = VPFFD_B_STATS, bRed = VPFFD_B_RED, bConsD = VPFFD_B_CONS_D,
    bWork = VPFFD_B_WORK, bNrm0 = VPFFD_B_NRM0, bNrm = VPFFD_B_NRM, bNrmTab = VPFFD_B_NRM_TAB,
    bSort = VPFFD_B_SORT, bTies = VPFFD_B_TIES, bSeam = VPFFD_B_SEAM, bParts = VPFFD_B_PARTS,
    bSlotVertex = VPFFD_B_SLOT_VERTEX, bPlaced = VPFFD_B_PLACED, kNumBuf = VPFFD_B_COUNT
  };
  static_assert(kNumBuf == int(kBindings), "one binding per device buffer");
  Buffer buf[kNumBuf];
  Buffer up_P, up_invw, up_frame, up_delta, up_cons_i, up_cons_d, rb_delta, rb_stats, rb_red, rb_X, rb_N;
  Buffer up_rest;  // staging of the rest positions (3V reals)
  Buffer up_offsets;  // staging of set_rest_offsets' translations (3K reals)
  bool normals_ready = false;  // the rest normals are on the device (a submission ran)
  // Frames read back their vertices and normals already in the caller's order
  // (place.comp: the host copies in order, no reorder), unless VPFFD_VULKAN_READBACK=host
  // asks for the device's order reordered on the host (the reference the tests compare
  // with, bit for bit, and the benchmarks' A/B).
  bool place_on_device = true;
  // Bytes of one placed value: world coordinates in double, or float32 in float-float
  // builds (whose shaders may not use doubles), which the host widens.
  size_t placed_real() const { return ff ? 4 : 8; }
  // place.comp's units in the frame parameters (fr: at least FR_RHS reals).
  void put_units(double* fr) const {
    fr[FR_SCALE] = scale;
    for (int a = 0; a < 3; ++a) fr[FR_ORIGIN + a] = origin[a];
  }
  // The vertices before the frame now running: a frame whose failure is only known
  // after it ran (see deform) puts them back, so a failed frame never becomes visible.
  Buffer x_good;

  // Declared after `dev` and destroyed before it, in reverse order; the destructor
  // first waits for a submission still running.
  detail::ComputePipelines pl;  // the descriptor set and one pipeline per Pipe
  Owned<VkCommandPool> cmd_pool;  // frees the command buffers below
  VkCommandBuffer cmd = VK_NULL_HANDLE;  // one-time work: uploads, restores
  // Copies the device vertices to rb_X; recorded once, submitted after a frame in the
  // same vkQueueSubmit (no second wait per frame) or alone by vertices().
  VkCommandBuffer readback_cb = VK_NULL_HANDLE;
  // The memory of frames' results handed out as shared pointers (deform with a shared
  // pointer): placed float64 vertices are read back straight into `rb`, the result
  // itself (no copy); otherwise (float-float, VPFFD_VULKAN_READBACK=host) they are
  // unpacked from rb_X into `host`. One is reused once nobody else holds it, so frames
  // do not fault fresh pages in. The device outlives every buffer (each holds it), so a
  // result may outlive the deformer.
  struct HostFrame {
    std::shared_ptr<detail::Device> dev;  // first: destroyed last
    Buffer rb;
    RowMatrixX3d host;
    const double* data() const { return rb.handle() ? static_cast<const double*>(rb.mapped()) : host.data(); }
  };
  struct SharedReadback {
    std::shared_ptr<HostFrame> frame;
    VkCommandBuffer cb = VK_NULL_HANDLE;  // its readback (recorded again after forget_recordings)
  };
  std::vector<SharedReadback> shared_rb;
  static constexpr size_t kMaxSharedReadbacks = 3;
  Owned<VkFence> fence;
  Owned<VkQueryPool> queries;

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
    // The handles go with the members; a submission must not outlive them.
    if (d && pending) vkWaitForFences(d, 1, &fence.get(), VK_TRUE, UINT64_MAX);
  }

  // ---- command helpers --------------------------------------------------------
  // A submission whose wait failed may still run: its command buffers and the fence
  // must not be reused before it ends.
  void settle() { detail::settle(d, fence.get(), pending); }

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
    detail::submit_and_wait(*dev, fence.get(), pending, cbs, n);
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
    vkCmdBindPipeline(cb, VK_PIPELINE_BIND_POINT_COMPUTE, pl.pipes[p].get());
    vkCmdPushConstants(cb, pl.layout.get(), VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(Push), &pc);
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
    if (dev->timestamps) vkCmdWriteTimestamp(cb, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, queries.get(), i);
  }

  // Binding i now names buf[i]: recorded frames referred to the old set contents.
  void bind(int i) {
    VkDescriptorBufferInfo info{buf[i].handle(), 0, VK_WHOLE_SIZE};
    VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    w.dstSet = pl.set;
    w.dstBinding = static_cast<std::uint32_t>(i);
    w.descriptorCount = 1;
    w.descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    w.pBufferInfo = &info;
    vkUpdateDescriptorSets(d, 1, &w, 0, nullptr);
    forget_recordings();
  }

  void forget_recordings() {
    for (Recorded& r : recorded) vkFreeCommandBuffers(d, cmd_pool.get(), 1, &r.cb);
    recorded.clear();
    for (VkCommandBuffer* cb : {&embed_cb, &offset_cb, &readback_cb}) {
      if (*cb) vkFreeCommandBuffers(d, cmd_pool.get(), 1, cb);
      *cb = VK_NULL_HANDLE;  // recorded again when a move needs it
    }
    for (SharedReadback& s : shared_rb) {
      if (s.cb) vkFreeCommandBuffers(d, cmd_pool.get(), 1, &s.cb);
      s.cb = VK_NULL_HANDLE;
    }
  }

  // Device buffer i (and its upload buffer, when given) hold at least `bytes`.
  void reserve(Buf i, Buffer* up, size_t bytes, const char* what) {
    if (buf[i].handle() && buf[i].size() >= bytes) return;
    const size_t cap = std::max<size_t>(bytes, 2 * buf[i].size());
    buf[i] = Buffer(*dev, cap, Buffer::DeviceLocal, what);
    if (up) *up = Buffer(*dev, cap, Buffer::Upload, what);
    if (pl.set) bind(i);
  }

  // Reals of solve.comp's scratch with nc point constraints (its two layouts).
  size_t work_size(size_t nc) const {
    const size_t k = size_t(K);
    return std::max<size_t>(6 * std::max<size_t>(1, nc), 2 * k * nc + 5 * nc + 3 * k * k + 7 * k);
  }

  // ---- set-up ------------------------------------------------------------------
  void build(const std::string& selector, Precision wanted);
  // rest_embedding.cpp
  void stage_rest(const Eigen::Ref<const RowMatrixX3d>& X, const char* where);
  // Throws the CPU's message for the rest positions X that stage_rest refused.
  void refuse_rest(const Eigen::Ref<const RowMatrixX3d>& X, const char* where) const;
  // embed_cb, or with `offsets` offset_cb.
  void record_embedding(bool offsets = false);
  // Stages X and its rest volume; the device embedding runs now, or with the next
  // frame when `defer` (embed_pending).
  void embed_rest(const Eigen::Ref<const RowMatrixX3d>& X, const char* where, bool defer);
  // set_rest_offsets: checks O (K x 3) against the base's part boxes, stages it; the
  // device embedding runs with the next frame.
  void offset_rest(const Eigen::Ref<const RowMatrixX3d>& O, const char* where);
  // The positions base + offsets of `part` rows (or all, without parts).
  RowMatrixX3d offset_positions(const Eigen::Ref<const RowMatrixX3d>& O) const;
  // The current rest positions: `rest`, made base + offsets first if a move left it stale.
  const RowMatrixX3d& rest_positions() const;
  // The waiting move's command buffer, re-recorded after a rebinding (forget_recordings).
  VkCommandBuffer pending_embedding() {
    if (!embed_pending) return VK_NULL_HANDLE;
    VkCommandBuffer& cb = offsets_pending ? offset_cb : embed_cb;
    if (!cb) record_embedding(offsets_pending);
    return cb;
  }
  // A waiting move's embedding submitted alone (before anything reads the device
  // outside a frame).
  void flush_embedding() {
    if (const VkCommandBuffer cb = pending_embedding()) {
      submit_and_wait(&cb, 1);
      embed_pending = false;
    }
  }
  const Deformer& synced_cpu();
  // The volumes of rest positions X: with parts (K > 1) each part's over the
  // topology's part_faces and their sum, else signed_volume over its faces.
  RestVolumes measure_rest(const Eigen::Ref<const RowMatrixX3d>& X, const char* where) const {
    return measure_rest_volumes(X, topo->faces, K > 1 ? &topo->part_faces : nullptr, topo->face_start, origin, 0,
                                where);
  }
  const RestVolumes& rest_volumes() const {
    return rest_vols->get([&] { return measure_rest(volumes_of_base ? base : rest_positions(), "rest_volume"); });
  }
  const CorrectionOptions& plan_options(const CorrectionOptions& opt, CorrectionOptions& storage) const;
  void create_pipelines(const std::array<std::int32_t, 16>& spec);

  // ---- frames (all with frame_mutex held) -----------------------------------------
  // Copies the frame's vertices to rb_X: placed in the caller's order (place.comp) or,
  // with !place_on_device, as the device's slots hold them. Recorded again after a
  // rebinding (forget_recordings).
  VkCommandBuffer readback() {
    if (readback_cb) return readback_cb;
    const VkDeviceSize bytes = readback_bytes();
    if (!rb_X.handle() || rb_X.size() < bytes) rb_X = Buffer(*dev, bytes, Buffer::Readback, "vertices (read-back)");
    readback_cb = record_readback(rb_X);
    return readback_cb;
  }
  VkDeviceSize readback_bytes() const { return place_on_device ? 3 * placed_real() * nv : 12 * nv; }
  VkCommandBuffer record_readback(const Buffer& dst) {
    const VkCommandBuffer cb = detail::allocate_command_buffer(d, cmd_pool.get());
    begin(cb, false);
    if (dev->timestamps) {
      vkCmdResetQueryPool(cb, queries.get(), kReadbackQuery, 2);
      vkCmdWriteTimestamp(cb, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, queries.get(), kReadbackQuery);
    }
    barrier(cb);
    if (place_on_device) {
      vkCmdBindDescriptorSets(cb, VK_PIPELINE_BIND_POINT_COMPUTE, pl.layout.get(), 0, 1, &pl.set, 0, nullptr);
      dispatch(cb, kPlace, g_vert, Push{});
      copy(cb, buf[bPlaced], dst, readback_bytes());
    } else {
      copy(cb, buf[bX], dst, readback_bytes());
    }
    host_barrier(cb);
    timestamp(cb, kReadbackQuery + 1);
    detail::check(vkEndCommandBuffer(cb), "vkEndCommandBuffer");
    return cb;
  }
  // A shared result nobody else holds (made when fewer than kMaxSharedReadbacks
  // exist), or null: the frame then copies into new memory.
  SharedReadback* free_shared_readback() {
    SharedReadback* s = nullptr;
    for (SharedReadback& x : shared_rb)
      if (x.frame.use_count() == 1) {  // only here: no result holds it (a count only we raise)
        s = &x;
        break;
      }
    if (!s && shared_rb.size() < kMaxSharedReadbacks) {
      auto f = std::make_shared<HostFrame>();
      f->dev = dev;
      if (direct_readback())
        f->rb = Buffer(*dev, readback_bytes(), Buffer::Readback, "vertices (read-back, shared)");
      else
        f->host.resize(nv, 3);
      shared_rb.push_back({std::move(f), VK_NULL_HANDLE});
      s = &shared_rb.back();
    }
    if (s && direct_readback() && !s->cb) s->cb = record_readback(s->frame->rb);
    return s;
  }
  // Whether read-back memory holds the caller's float64 vertices as they are.
  bool direct_readback() const { return place_on_device && !ff; }
  // The read back of a frame whose vertices go to `s` (or, null, to rb_X).
  VkCommandBuffer readback_into(SharedReadback* s) { return s && s->cb ? s->cb : readback(); }

  // #V x 3 device vertices in the input order (runs readback() alone).
  RowMatrixX3d read_vertices() {
    flush_embedding();  // before a frame the device vertices are the rest positions
    const VkCommandBuffer cb = readback();
    submit_and_wait(&cb, 1);
    return unpack_vertices();
  }

  // rb_X, filled by readback(), in the input order and world units.
  RowMatrixX3d unpack_vertices() const { return unpack(rb_X, scale, origin); }

  // rb_N, filled by a frame with normals, in the input order.
  RowMatrixX3d unpack_normals() const { return unpack(rb_N, 1.0, Vector3d::Zero()); }

  // The #V x 3 values of read-back buffer `rb` in the input order, times `s` plus `o`.
  RowMatrixX3d unpack(const Buffer& rb, double s, const Vector3d& o) const {
    RowMatrixX3d out(nv, 3);
    unpack(rb, s, o, out.data());
    return out;
  }
  // The same into the caller's #V x 3 row-major array. Placed values are in the
  // caller's order already: streams in order on all cores (float64: a copy; float32:
  // widened with the arithmetic place.comp's float64 build uses). Else device slot i's
  // float32 triple goes to input vertex slot[i], scattered: on an H100 a 2.6 M-vertex
  // frame took 80 ms end to end against 1.6 ms on the device, most of it here.
  void unpack(const Buffer& rb, double s, const Vector3d& o, double* out) const {
    if (place_on_device && !ff) {
      const double* x = static_cast<const double*>(rb.mapped());
      parallel_range(3 * nv, 0, [&](Index b, Index e) { std::memcpy(out + b, x + b, 8 * size_t(e - b)); });
      return;
    }
    const float* x = static_cast<const float*>(rb.mapped());
    if (place_on_device) {
      parallel_range(nv, 0, [&](Index b, Index e) {
        for (Index i = b; i < e; ++i)
          for (int a = 0; a < 3; ++a) out[3 * i + a] = double(x[3 * i + a]) * s + o[a];
      });
      return;
    }
    parallel_range(nv, 0, [&](Index b, Index e) {
      for (Index i = b; i < e; ++i)
        for (int a = 0; a < 3; ++a) out[3 * Index(slot[i]) + a] = double(x[3 * i + a]) * s + o[a];
    });
  }

  // After a frame with device steps failed: its vertices back to those before it.
  void restore_vertices() {
    begin();
    barrier(cmd);
    copy(x_good, buf[bX], 12 * nv);
    barrier(cmd);
    submit_and_wait();
  }

  // The first frame with normals after construction or a move: their buffers, and the
  // rest normals computed on the device (rest_normals.comp, into `cmd`, begun; after a
  // move's embedding, which writes the rest positions, in the same submission).
  // Returns whether `cmd` got work.
  bool prepare_normals() {
    if (normals_ready) return false;
    reserve(bNrm0, nullptr, 12 * nv, "rest normals");
    reserve(bNrm, nullptr, 12 * nv, "normals");
    if (place_on_device) reserve(bPlaced, nullptr, 6 * placed_real() * nv, "vertices and normals (caller's order)");
    barrier(cmd);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pl.layout.get(), 0, 1, &pl.set, 0, nullptr);
    dispatch(cmd, kRestNormals, g_vert, Push{});
    if (!rb_N.handle())
      rb_N = Buffer(*dev, (place_on_device ? 3 * placed_real() : 12) * nv, Buffer::Readback, "normals (read-back)");
    return true;
  }

  // One frame (VulkanDeformer::deform); `tail`, when given, runs after it in the same
  // submission (see FrameTail).
  // `out_vertices` / `out_normals` (#V x 3 row-major, or null): the caller's arrays,
  // filled instead of the result's vertices / *normals (a frame with out_normals
  // computes normals).
  DeformResult run_frame(const Eigen::Ref<const RowMatrixX3d>& P, const CorrectionOptions& opt, bool read_vertices,
                         RowMatrixX3d* normals, const detail::FrameTail* tail, double* out_vertices = nullptr,
                         double* out_normals = nullptr, std::shared_ptr<const double>* shared_vertices = nullptr);

  // Into `cb` (a caller's, begun; frame_mutex held): the plain FFD of the control points
  // in buf[bP] and the copy of the vertices to rb_X as readback() leaves them (it must
  // have run).
  void record_ffd_readback(VkCommandBuffer cb) {
    barrier(cb);
    vkCmdBindDescriptorSets(cb, VK_PIPELINE_BIND_POINT_COMPUTE, pl.layout.get(), 0, 1, &pl.set, 0, nullptr);
    dispatch(cb, kFfd, g_vert, Push{});
    if (place_on_device) {
      dispatch(cb, kPlace, g_vert, Push{});
      copy(cb, buf[bPlaced], rb_X, 3 * placed_real() * nv);
    } else {
      copy(cb, buf[bX], rb_X, 12 * nv);
    }
  }

  // Uploads the constraint block (into `cmd`, begun) when the rows or the weights changed.
  bool update_constraints(const std::vector<SparseVec>& rows, const VectorXd& inv_weight);
  const Recorded& frame_commands(const Shape& shape);
};

}  // namespace vpffd::vulkan
