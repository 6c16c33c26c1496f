#pragma once
// Vulkan plumbing of the vpffd::vulkan backend: the run-time loader (volk), the
// process-wide instance, one shared logical device per physical device, buffers.
// Private to the backend; the public API is vpffd/backend/vulkan.h.

#include <volk.h>

#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "vpffd/backend/vulkan.h"
#include "vpffd/core/exceptions.h"

namespace vpffd::vulkan::detail {

/// Storage buffers of the pipeline layout (the bindings of shaders/common.glsl).
constexpr std::uint32_t kBindings = 31;
/// Most shared memory a shader declares (solve.comp: 3 x 256 reals = 6 KiB), rounded
/// up to the 16 KiB every Vulkan device has.
constexpr std::uint32_t kSharedBytes = 16 * 1024;

/// "VK_ERROR_OUT_OF_DEVICE_MEMORY (-2)".
std::string result_string(VkResult r);

/// Throws DeviceError "vulkan: <call> failed: <result>" unless r is VK_SUCCESS.
void check(VkResult r, const char* call);

/// One primary command buffer from `pool` (freed by vkFreeCommandBuffers or with the pool).
inline VkCommandBuffer allocate_command_buffer(VkDevice d, VkCommandPool pool) {
  VkCommandBufferAllocateInfo cai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  cai.commandPool = pool;
  cai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  cai.commandBufferCount = 1;
  VkCommandBuffer cb = VK_NULL_HANDLE;
  check(vkAllocateCommandBuffers(d, &cai, &cb), "vkAllocateCommandBuffers");
  return cb;
}

/// The instance, shared by every device and deformer; made once per process, never destroyed.
struct Instance {
  VkInstance handle = VK_NULL_HANDLE;
  ~Instance();
};

/// Loads Vulkan and creates (or shares) the instance.
/// @throws BackendUnavailableError without a loader or a driver.
std::shared_ptr<Instance> instance();

/// A logical device with one compute queue; deformers on the same physical device
/// share it (queue submissions are serialised by `queue_mutex`).
struct Device {
  std::shared_ptr<Instance> inst;
  VkPhysicalDevice phys = VK_NULL_HANDLE;
  DeviceInfo info;
  VkDevice handle = VK_NULL_HANDLE;
  VkQueue queue = VK_NULL_HANDLE;
  std::uint32_t family = 0;
  VkPhysicalDeviceMemoryProperties mem{};
  VkPhysicalDeviceLimits limits{};
  double timestamp_period_ns = 1.0;
  bool timestamps = false;
  std::mutex queue_mutex;
  ~Device();
};

/// The device `selector` names ("" = first suitable, hardware first; an index; or
/// part of the name). @throws BackendUnavailableError saying why there is none.
std::shared_ptr<Device> open_device(const std::string& selector);

/// A buffer with its own memory. Host buffers are mapped for their whole life.
class Buffer {
 public:
  enum Kind { DeviceLocal, Upload, Readback };
  Buffer() = default;
  Buffer(Device& d, VkDeviceSize size, Kind kind, const char* what);
  ~Buffer() { release(); }
  Buffer(Buffer&& o) noexcept { *this = std::move(o); }
  Buffer& operator=(Buffer&& o) noexcept;
  Buffer(const Buffer&) = delete;
  Buffer& operator=(const Buffer&) = delete;

  VkBuffer handle() const { return buf_; }
  VkDeviceSize size() const { return size_; }
  void* mapped() const { return map_; }

 private:
  void release();
  VkDevice dev_ = VK_NULL_HANDLE;
  VkBuffer buf_ = VK_NULL_HANDLE;
  VkDeviceMemory mem_ = VK_NULL_HANDLE;
  VkDeviceSize size_ = 0;
  void* map_ = nullptr;
};

}  // namespace vpffd::vulkan::detail
