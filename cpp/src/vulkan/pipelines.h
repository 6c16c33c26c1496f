#pragma once
// What every device class of the backend (VulkanDeformer, VulkanMultires) builds and
// runs the same way: compute pipelines over one descriptor set of storage buffers,
// and a submission waited for on a fence.

#include <cstdint>
#include <vector>

#include "context.h"
#include "vk_handle.h"
#include "vpffd/shaders/spv.h"

namespace vpffd::vulkan::detail {

/// One descriptor set of storage buffers (binding i = buffer i), its layout and pool,
/// and one pipeline per shader, all owned (destroyed in reverse: pipelines first).
struct ComputePipelines {
  Owned<VkDescriptorSetLayout> dsl;
  Owned<VkPipelineLayout> layout;
  Owned<VkDescriptorPool> pool;
  VkDescriptorSet set = VK_NULL_HANDLE;  // freed with the pool
  std::vector<Owned<VkShaderModule>> modules;
  std::vector<Owned<VkPipeline>> pipes;
};

/// Builds `out` for `n_buffers` storage buffers (bound now), `push_bytes` of push
/// constants (0: none), the 4-byte specialisation constants `spec[0..n_spec)` and the
/// shaders `shaders[0..n_shaders)`. @throws DeviceError naming the failing shader.
void create_compute_pipelines(VkDevice d, const Buffer* buffers, std::uint32_t n_buffers, std::uint32_t push_bytes,
                              const std::int32_t* spec, std::uint32_t n_spec, const Spv* shaders,
                              std::uint32_t n_shaders, ComputePipelines& out);

/// The objects every submitting class owns: a command pool on the device's queue family
/// whose buffers can be reset one by one, a fence, and a pool of `n_queries` timestamp
/// queries (empty when the device has no timestamps).
Owned<VkCommandPool> create_command_pool(const Device& dev);
Owned<VkFence> create_fence(VkDevice d);
Owned<VkQueryPool> create_timestamp_queries(const Device& dev, std::uint32_t n_queries);

/// Waits for a submission whose earlier wait failed (`pending`), so that its command
/// buffers and `fence` may be reused. @throws DeviceError after 600 s.
void settle(VkDevice d, VkFence fence, bool& pending);

/// Submits `cbs` in order (one vkQueueSubmit, the device's queue lock held) and waits
/// for `fence`, generously (lavapipe on a big mesh is slow, a hung device must not
/// hang the caller). `pending` stays true if the wait fails.
void submit_and_wait(Device& dev, VkFence fence, bool& pending, const VkCommandBuffer* cbs, std::uint32_t n);

}  // namespace vpffd::vulkan::detail
