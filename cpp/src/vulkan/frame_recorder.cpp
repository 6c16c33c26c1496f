// A frame's command buffer, recorded once per options shape (Shape) and submitted
// again while only the data in the buffers changes.

#include "deformer_impl.h"

namespace vpffd::vulkan {

using detail::get_real;
using detail::groups_for;
using detail::ms_since;
using detail::put_reals;

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
    vkFreeCommandBuffers(d, cmd_pool.get(), 1, &old->cb);
    recorded.erase(old);
  }
  Recorded r;
  r.shape = shape;
  r.last_use = frames;
  r.cb = detail::allocate_command_buffer(d, cmd_pool.get());
  recorded.push_back(r);  // freed with the others if recording fails
  const VkCommandBuffer cb = r.cb;
  const int k = static_cast<int>(shape.axes.size());
  const bool steps = shape.mode == Shape::DeviceSteps;
  const std::uint32_t n_steps = static_cast<std::uint32_t>(shape.mode == Shape::Plain ? 0 : k);

  begin(cb, false);
  if (dev->timestamps) vkCmdResetQueryPool(cb, queries.get(), 0, 3 + n_steps);
  if (dev->timestamps) vkCmdWriteTimestamp(cb, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, queries.get(), 0);
  if (steps) {
    // Only device steps can fail after the frame ran (their solve finds zero or
    // dependent rows): keep the vertices it is about to overwrite. The barrier makes
    // the last submission's writes to them visible to this copy.
    barrier(cb);
    copy(cb, buf[bX], x_good, 12 * nv);
  }
  copy(cb, up_P, buf[bP], 12 * NE);  // the extended lattice's (setup.cpp)
  copy(cb, up_frame, buf[bFrame], buf[bFrame].size());
  if (shape.mode == Shape::HostOffsets) copy(cb, up_delta, buf[bDelta], 24 * N);
  if (steps) vkCmdFillBuffer(cb, buf[bDelta].handle(), 0, VK_WHOLE_SIZE, 0);
  barrier(cb);
  vkCmdBindDescriptorSets(cb, VK_PIPELINE_BIND_POINT_COMPUTE, pl.layout.get(), 0, 1, &pl.set, 0, nullptr);
  Push pc;
  dispatch(cb, kFfd, g_vert, pc);
  // A volume pass into region `slot` of red: with parts, g_part workgroups per part.
  auto volume = [&](int slot) {
    Push v;
    v.slot = slot;
    v.count = static_cast<std::int32_t>(g_part);
    dispatch(cb, kVolume, red_groups(), v);
  };
  // With device steps the first one measures the plain FFD's volume (each part's,
  // stats[ST_PART_BEFORE..]).
  if (shape.measure && !steps) volume(0);
  timestamp(cb, 1);
  for (int step = 0; step < k && shape.mode != Shape::Plain; ++step) {
    Push s;
    s.axis = shape.axes[step];
    s.step = step;
    s.left = k - step;
    s.flags = shape.open ? 4 : 0;
    if (steps) {
      dispatch(cb, kCoef, g_tile, s);
      dispatch(cb, kCombine, g_rows, s);
      dispatch(cb, kSolve, 1, s);
    }
    s.slot = steps ? 3 : s.axis;  // delta row: this step's offsets, or the axis's total
    dispatch(cb, kGather, g_vert, s);
    timestamp(cb, 2 + step);
  }
  if (shape.measure && shape.mode != Shape::Plain) volume(1);
  if (shape.normals) {
    // Of the corrected control points: P plus the offsets' three totals (rows 0-2 of
    // delta: accumulated by the device steps, or uploaded with the host's offsets).
    Push np;
    np.flags = shape.mode == Shape::Plain ? 0 : 8;
    dispatch(cb, kNormals, g_vert, np);
    if (place_on_device) {
      Push pn;
      pn.slot = 1;  // the normals, into the second region
      dispatch(cb, kPlace, g_vert, pn);
      const VkDeviceSize bytes = 3 * placed_real() * nv;
      copy(cb, buf[bPlaced], rb_N, bytes, bytes, 0);
    } else {
      copy(cb, buf[bNrm], rb_N, 12 * nv);
    }
  }
  if (steps) copy(cb, buf[bDelta], rb_delta, 24 * N);
  if (steps) copy(cb, buf[bStats], rb_stats, 8 * (ST_STEP + ST_STEP_STRIDE * k));
  if (shape.measure) {
    const VkBufferCopy regions[2] = {{0, 0, 8 * red_groups()}, {8 * kMaxGroups, 8 * kMaxGroups, 8 * red_groups()}};
    vkCmdCopyBuffer(cb, buf[bRed].handle(), rb_red.handle(), 2, regions);
  }
  host_barrier(cb);
  timestamp(cb, 2 + n_steps);
  detail::check(vkEndCommandBuffer(cb), "vkEndCommandBuffer");
  recorded.back().n_steps = n_steps;
  return recorded.back();
}

}  // namespace vpffd::vulkan
