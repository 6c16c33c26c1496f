#include "pipelines.h"

#include <string>

namespace vpffd::vulkan::detail {

void create_compute_pipelines(VkDevice d, const Buffer* buffers, std::uint32_t n_buffers, std::uint32_t push_bytes,
                              const std::int32_t* spec, std::uint32_t n_spec, const Spv* shaders,
                              std::uint32_t n_shaders, ComputePipelines& out) {
  std::vector<VkDescriptorSetLayoutBinding> b(n_buffers);
  for (std::uint32_t i = 0; i < n_buffers; ++i)
    b[i] = {i, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
  VkDescriptorSetLayoutCreateInfo li{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  li.bindingCount = n_buffers;
  li.pBindings = b.data();
  VkDescriptorSetLayout dsl = VK_NULL_HANDLE;
  check(vkCreateDescriptorSetLayout(d, &li, nullptr, &dsl), "vkCreateDescriptorSetLayout");
  out.dsl.adopt(d, dsl, vkDestroyDescriptorSetLayout);

  const VkPushConstantRange pr{VK_SHADER_STAGE_COMPUTE_BIT, 0, push_bytes};
  VkPipelineLayoutCreateInfo pli{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  pli.setLayoutCount = 1;
  pli.pSetLayouts = &out.dsl.get();
  pli.pushConstantRangeCount = push_bytes > 0 ? 1 : 0;
  pli.pPushConstantRanges = push_bytes > 0 ? &pr : nullptr;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  check(vkCreatePipelineLayout(d, &pli, nullptr, &layout), "vkCreatePipelineLayout");
  out.layout.adopt(d, layout, vkDestroyPipelineLayout);

  const VkDescriptorPoolSize ps{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, n_buffers};
  VkDescriptorPoolCreateInfo pi{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  pi.maxSets = 1;
  pi.poolSizeCount = 1;
  pi.pPoolSizes = &ps;
  VkDescriptorPool pool = VK_NULL_HANDLE;
  check(vkCreateDescriptorPool(d, &pi, nullptr, &pool), "vkCreateDescriptorPool");
  out.pool.adopt(d, pool, vkDestroyDescriptorPool);
  VkDescriptorSetAllocateInfo ai{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  ai.descriptorPool = out.pool.get();
  ai.descriptorSetCount = 1;
  ai.pSetLayouts = &out.dsl.get();
  check(vkAllocateDescriptorSets(d, &ai, &out.set), "vkAllocateDescriptorSets");
  std::vector<VkDescriptorBufferInfo> info(n_buffers);
  std::vector<VkWriteDescriptorSet> w(n_buffers);
  for (std::uint32_t i = 0; i < n_buffers; ++i) {
    info[i] = {buffers[i].handle(), 0, VK_WHOLE_SIZE};
    w[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    w[i].dstSet = out.set;
    w[i].dstBinding = i;
    w[i].descriptorCount = 1;
    w[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    w[i].pBufferInfo = &info[i];
  }
  vkUpdateDescriptorSets(d, n_buffers, w.data(), 0, nullptr);

  std::vector<VkSpecializationMapEntry> entries(n_spec);
  for (std::uint32_t i = 0; i < n_spec; ++i) entries[i] = {i, i * 4u, 4};
  const VkSpecializationInfo si{n_spec, entries.data(), 4 * size_t(n_spec), spec};
  out.modules.clear();
  out.pipes.clear();
  out.modules.resize(n_shaders);
  out.pipes.resize(n_shaders);
  for (std::uint32_t p = 0; p < n_shaders; ++p) {
    VkShaderModuleCreateInfo mi{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
    mi.codeSize = shaders[p].bytes;
    mi.pCode = shaders[p].code;
    VkShaderModule module = VK_NULL_HANDLE;
    check(vkCreateShaderModule(d, &mi, nullptr, &module), "vkCreateShaderModule");
    out.modules[p].adopt(d, module, vkDestroyShaderModule);
    VkComputePipelineCreateInfo ci{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
    ci.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
    ci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    ci.stage.module = module;
    ci.stage.pName = "main";
    ci.stage.pSpecializationInfo = &si;
    ci.layout = out.layout.get();
    VkPipeline pipe = VK_NULL_HANDLE;
    const VkResult r = vkCreateComputePipelines(d, VK_NULL_HANDLE, 1, &ci, nullptr, &pipe);
    if (r != VK_SUCCESS)
      throw DeviceError(std::string("vulkan: vkCreateComputePipelines (") + shaders[p].name +
                        ") failed: " + result_string(r));
    out.pipes[p].adopt(d, pipe, vkDestroyPipeline);
  }
}

namespace {
constexpr std::uint64_t kWaitNs = 600ull * 1000 * 1000 * 1000;
}

Owned<VkCommandPool> create_command_pool(const Device& dev) {
  VkCommandPoolCreateInfo cpi{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  cpi.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  cpi.queueFamilyIndex = dev.family;
  VkCommandPool h = VK_NULL_HANDLE;
  check(vkCreateCommandPool(dev.handle, &cpi, nullptr, &h), "vkCreateCommandPool");
  Owned<VkCommandPool> pool;
  pool.adopt(dev.handle, h, vkDestroyCommandPool);
  return pool;
}

Owned<VkFence> create_fence(VkDevice d) {
  VkFenceCreateInfo fi{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  VkFence h = VK_NULL_HANDLE;
  check(vkCreateFence(d, &fi, nullptr, &h), "vkCreateFence");
  Owned<VkFence> fence;
  fence.adopt(d, h, vkDestroyFence);
  return fence;
}

Owned<VkQueryPool> create_timestamp_queries(const Device& dev, std::uint32_t n_queries) {
  Owned<VkQueryPool> queries;
  if (!dev.timestamps) return queries;
  VkQueryPoolCreateInfo qi{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
  qi.queryType = VK_QUERY_TYPE_TIMESTAMP;
  qi.queryCount = n_queries;
  VkQueryPool h = VK_NULL_HANDLE;
  check(vkCreateQueryPool(dev.handle, &qi, nullptr, &h), "vkCreateQueryPool");
  queries.adopt(dev.handle, h, vkDestroyQueryPool);
  return queries;
}

void settle(VkDevice d, VkFence fence, bool& pending) {
  if (!pending) return;
  const VkResult r = vkWaitForFences(d, 1, &fence, VK_TRUE, kWaitNs);
  if (r == VK_TIMEOUT) throw DeviceError("vulkan: an earlier submission is still running after 600 s (device hung?)");
  check(r, "vkWaitForFences");
  pending = false;
  check(vkResetFences(d, 1, &fence), "vkResetFences");
}

void submit_and_wait(Device& dev, VkFence fence, bool& pending, const VkCommandBuffer* cbs, std::uint32_t n) {
  settle(dev.handle, fence, pending);
  VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
  si.commandBufferCount = n;
  si.pCommandBuffers = cbs;
  {
    std::lock_guard<std::mutex> lock(dev.queue_mutex);
    check(vkQueueSubmit(dev.queue, 1, &si, fence), "vkQueueSubmit");
  }
  pending = true;
  const VkResult r = vkWaitForFences(dev.handle, 1, &fence, VK_TRUE, kWaitNs);
  if (r == VK_TIMEOUT) throw DeviceError("vulkan: vkWaitForFences timed out after 600 s (device hung?)");
  check(r, "vkWaitForFences");
  pending = false;
  check(vkResetFences(dev.handle, 1, &fence), "vkResetFences");
}

}  // namespace vpffd::vulkan::detail
