// Loader, instance, device selection and buffers of the Vulkan backend.

#include "context.h"

#include <algorithm>
#include <cctype>
#include <cstring>
#include <map>
#include <sstream>

#include "vpffd/core/check.h"

namespace vpffd::vulkan::detail {

std::string result_string(VkResult r) {
  const char* name = "VK_ERROR_UNKNOWN";
  switch (r) {
#define VPFFD_VK_CASE(x) \
  case x:                \
    name = #x;           \
    break;
    VPFFD_VK_CASE(VK_SUCCESS)
    VPFFD_VK_CASE(VK_NOT_READY)
    VPFFD_VK_CASE(VK_TIMEOUT)
    VPFFD_VK_CASE(VK_INCOMPLETE)
    VPFFD_VK_CASE(VK_ERROR_OUT_OF_HOST_MEMORY)
    VPFFD_VK_CASE(VK_ERROR_OUT_OF_DEVICE_MEMORY)
    VPFFD_VK_CASE(VK_ERROR_INITIALIZATION_FAILED)
    VPFFD_VK_CASE(VK_ERROR_DEVICE_LOST)
    VPFFD_VK_CASE(VK_ERROR_MEMORY_MAP_FAILED)
    VPFFD_VK_CASE(VK_ERROR_LAYER_NOT_PRESENT)
    VPFFD_VK_CASE(VK_ERROR_EXTENSION_NOT_PRESENT)
    VPFFD_VK_CASE(VK_ERROR_FEATURE_NOT_PRESENT)
    VPFFD_VK_CASE(VK_ERROR_INCOMPATIBLE_DRIVER)
    VPFFD_VK_CASE(VK_ERROR_TOO_MANY_OBJECTS)
    VPFFD_VK_CASE(VK_ERROR_FORMAT_NOT_SUPPORTED)
    VPFFD_VK_CASE(VK_ERROR_FRAGMENTED_POOL)
    VPFFD_VK_CASE(VK_ERROR_OUT_OF_POOL_MEMORY)
    VPFFD_VK_CASE(VK_ERROR_INVALID_SHADER_NV)
#undef VPFFD_VK_CASE
    default:
      break;
  }
  return vpffd::detail::concat(name, " (", static_cast<int>(r), ")");
}

void check(VkResult r, const char* call) {
  if (r != VK_SUCCESS) throw DeviceError(vpffd::detail::concat("vulkan: ", call, " failed: ", result_string(r)));
}

// ---- loader and instance -----------------------------------------------------

namespace {

std::mutex g_mutex;  // guards the instance and device caches

VkResult load_vulkan() {
  static std::once_flag once;
  static VkResult result = VK_ERROR_INITIALIZATION_FAILED;
  std::call_once(once, [] { result = volkInitialize(); });
  return result;
}

// The instance and the devices live as long as the process once made, and are never
// destroyed: NVIDIA's driver (580, H100) refuses vkCreateInstance with
// VK_ERROR_INCOMPATIBLE_DRIVER after about 27 create/destroy cycles in one process, and
// a cycle with its device costs ~300 ms there. Destroying them from a static destructor
// could run after the driver's own teardown, so they are left to the process's exit.
std::shared_ptr<Instance> instance_locked() {
  static auto* cache = new std::shared_ptr<Instance>();
  if (*cache) return *cache;
  if (load_vulkan() != VK_SUCCESS)
    throw BackendUnavailableError(
        "vulkan: no Vulkan loader (libvulkan.so.1) could be loaded; install libvulkan1 and a driver "
        "(mesa-vulkan-drivers provides the software device lavapipe)");
  VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
  app.pApplicationName = "vpffd";
  app.pEngineName = "vpffd";
  app.apiVersion = VK_API_VERSION_1_1;
  VkInstanceCreateInfo ci{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  ci.pApplicationInfo = &app;
  auto inst = std::make_shared<Instance>();
  const VkResult r = vkCreateInstance(&ci, nullptr, &inst->handle);
  if (r == VK_ERROR_INCOMPATIBLE_DRIVER)
    throw BackendUnavailableError(
        "vulkan: vkCreateInstance found no Vulkan driver (VK_ERROR_INCOMPATIBLE_DRIVER); install a GPU driver or "
        "mesa-vulkan-drivers (lavapipe)");
  if (r != VK_SUCCESS)
    throw BackendUnavailableError("vulkan: vkCreateInstance failed: " + result_string(r));
  // Device functions through the loader trampolines (not volkLoadDevice): they
  // dispatch on the VkDevice, so several devices can be used at once.
  volkLoadInstance(inst->handle);
  *cache = inst;
  return inst;
}

std::string type_name(VkPhysicalDeviceType t) {
  switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return "discrete";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return "integrated";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return "virtual";
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return "cpu";
    default: return "other";
  }
}

// Hardware first, the software rasteriser last: the order of "first suitable".
int type_rank(const std::string& t) {
  if (t == "discrete") return 0;
  if (t == "integrated") return 1;
  if (t == "virtual") return 2;
  if (t == "other") return 3;
  return 4;
}

std::vector<VkPhysicalDevice> physical_devices(const Instance& inst) {
  std::uint32_t n = 0;
  VkResult r = vkEnumeratePhysicalDevices(inst.handle, &n, nullptr);
  if (r == VK_ERROR_INITIALIZATION_FAILED)
    throw BackendUnavailableError(
        "vulkan: vkEnumeratePhysicalDevices found no usable driver (VK_ERROR_INITIALIZATION_FAILED): the drivers "
        "failed to load or were filtered out (VK_DRIVER_FILES, VK_ICD_FILENAMES, VK_LOADER_DRIVERS_SELECT)");
  check(r, "vkEnumeratePhysicalDevices");
  std::vector<VkPhysicalDevice> out(n);
  if (n) check(vkEnumeratePhysicalDevices(inst.handle, &n, out.data()), "vkEnumeratePhysicalDevices");
  out.resize(n);
  return out;
}

// Limits the shaders rely on (see shaders/common.glsl).
constexpr std::uint32_t kInvocations = 256;

DeviceInfo describe(VkPhysicalDevice p, int index) {
  VkPhysicalDeviceProperties props;
  vkGetPhysicalDeviceProperties(p, &props);
  VkPhysicalDeviceFeatures feats;
  vkGetPhysicalDeviceFeatures(p, &feats);
  VkPhysicalDeviceMemoryProperties mem;
  vkGetPhysicalDeviceMemoryProperties(p, &mem);
  DeviceInfo d;
  d.index = index;
  d.name = props.deviceName;
  d.type = type_name(props.deviceType);
  for (std::uint32_t h = 0; h < mem.memoryHeapCount; ++h)
    if (mem.memoryHeaps[h].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT)
      d.memory_bytes = std::max<std::uint64_t>(d.memory_bytes, mem.memoryHeaps[h].size);
  d.api_version = vpffd::detail::concat(VK_API_VERSION_MAJOR(props.apiVersion), ".",
                                        VK_API_VERSION_MINOR(props.apiVersion), ".",
                                        VK_API_VERSION_PATCH(props.apiVersion));
  if (props.apiVersion >= VK_API_VERSION_1_2) {
    VkPhysicalDeviceDriverProperties drv{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES};
    VkPhysicalDeviceProperties2 p2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
    p2.pNext = &drv;
    vkGetPhysicalDeviceProperties2(p, &p2);
    d.driver = std::string(drv.driverName) + (drv.driverInfo[0] ? std::string(" ") + drv.driverInfo : "");
  }
  d.float64 = feats.shaderFloat64 == VK_TRUE;
  std::uint32_t nq = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(p, &nq, nullptr);
  std::vector<VkQueueFamilyProperties> q(nq);
  vkGetPhysicalDeviceQueueFamilyProperties(p, &nq, q.data());
  bool compute = false;
  for (const auto& f : q) compute |= (f.queueFlags & VK_QUEUE_COMPUTE_BIT) != 0;
  const VkPhysicalDeviceLimits& L = props.limits;
  if (props.apiVersion < VK_API_VERSION_1_1) d.reason = "Vulkan " + d.api_version + " < 1.1";
  else if (!compute) d.reason = "no compute queue";
  else if (L.maxPerStageDescriptorStorageBuffers < kBindings)
    d.reason = vpffd::detail::concat("maxPerStageDescriptorStorageBuffers ", L.maxPerStageDescriptorStorageBuffers,
                                     " < ", kBindings);
  else if (L.maxComputeSharedMemorySize < kSharedBytes)
    d.reason = vpffd::detail::concat("maxComputeSharedMemorySize ", L.maxComputeSharedMemorySize, " < ", kSharedBytes);
  else if (L.maxComputeWorkGroupInvocations < kInvocations || L.maxComputeWorkGroupSize[0] < kInvocations)
    d.reason = vpffd::detail::concat("compute workgroups of ", kInvocations, " invocations are not supported");
  d.suitable = d.reason.empty();
  return d;
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string list_devices(const std::vector<DeviceInfo>& ds) {
  std::ostringstream os;
  for (size_t i = 0; i < ds.size(); ++i) {
    if (i) os << "; ";
    os << ds[i].index << ": " << ds[i].name << " (" << ds[i].type << ")";
    if (!ds[i].suitable) os << " unsuitable: " << ds[i].reason;
  }
  return os.str();
}

}  // namespace

Instance::~Instance() {
  if (handle) vkDestroyInstance(handle, nullptr);
}

std::shared_ptr<Instance> instance() {
  std::lock_guard<std::mutex> lock(g_mutex);
  return instance_locked();
}

Device::~Device() {
  if (handle) {
    vkDeviceWaitIdle(handle);
    vkDestroyDevice(handle, nullptr);
  }
}

std::shared_ptr<Device> open_device(const std::string& selector) {
  std::lock_guard<std::mutex> lock(g_mutex);
  auto inst = instance_locked();
  const std::vector<VkPhysicalDevice> phys = physical_devices(*inst);
  std::vector<DeviceInfo> infos;
  for (size_t i = 0; i < phys.size(); ++i) infos.push_back(describe(phys[i], static_cast<int>(i)));
  if (infos.empty()) throw BackendUnavailableError("vulkan: the Vulkan loader reports no devices");

  int chosen = -1;
  const bool is_index = !selector.empty() && std::all_of(selector.begin(), selector.end(), [](char c) {
    return std::isdigit(static_cast<unsigned char>(c));
  });
  if (selector.empty()) {
    std::vector<int> order(infos.size());
    for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
    std::stable_sort(order.begin(), order.end(),
                     [&](int a, int b) { return type_rank(infos[a].type) < type_rank(infos[b].type); });
    for (int i : order)
      if (infos[i].suitable) {
        chosen = i;
        break;
      }
    if (chosen < 0)
      throw BackendUnavailableError("vulkan: no suitable device; the devices are: " + list_devices(infos));
  } else if (is_index) {
    const long idx = std::strtol(selector.c_str(), nullptr, 10);
    if (idx < 0 || idx >= static_cast<long>(infos.size()))
      throw BackendUnavailableError(vpffd::detail::concat("vulkan: device index ", selector, " out of range; the ",
                                                          infos.size(), " devices are: ", list_devices(infos)));
    chosen = static_cast<int>(idx);
    if (!infos[chosen].suitable)
      throw BackendUnavailableError("vulkan: device " + selector + " (" + infos[chosen].name +
                                    ") is unsuitable: " + infos[chosen].reason);
  } else {
    const std::string want = lower(selector);
    bool matched = false;
    for (const auto& d : infos)
      if (lower(d.name).find(want) != std::string::npos) {
        matched = true;
        if (d.suitable) {
          chosen = d.index;
          break;
        }
      }
    if (chosen < 0)
      throw BackendUnavailableError(vpffd::detail::concat("vulkan: ", matched ? "no suitable device" : "no device",
                                                          " matches '", selector,
                                                          "'; the devices are: ", list_devices(infos)));
  }

  static auto* cache = new std::map<int, std::shared_ptr<Device>>();  // see instance_locked
  if (auto d = (*cache)[chosen]) return d;

  auto dev = std::make_shared<Device>();
  dev->inst = inst;
  dev->phys = phys[chosen];
  dev->info = infos[chosen];
  std::uint32_t nq = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(dev->phys, &nq, nullptr);
  std::vector<VkQueueFamilyProperties> q(nq);
  vkGetPhysicalDeviceQueueFamilyProperties(dev->phys, &nq, q.data());
  // A compute-only family, when there is one, does not compete with graphics work.
  int family = -1;
  for (std::uint32_t i = 0; i < nq; ++i)
    if ((q[i].queueFlags & VK_QUEUE_COMPUTE_BIT) && !(q[i].queueFlags & VK_QUEUE_GRAPHICS_BIT)) {
      family = static_cast<int>(i);
      break;
    }
  if (family < 0)
    for (std::uint32_t i = 0; i < nq; ++i)
      if (q[i].queueFlags & VK_QUEUE_COMPUTE_BIT) {
        family = static_cast<int>(i);
        break;
      }
  dev->family = static_cast<std::uint32_t>(family);
  VkPhysicalDeviceProperties props;
  vkGetPhysicalDeviceProperties(dev->phys, &props);
  dev->limits = props.limits;
  dev->timestamp_period_ns = props.limits.timestampPeriod;
  dev->timestamps = q[family].timestampValidBits > 0 && props.limits.timestampPeriod > 0;
  vkGetPhysicalDeviceMemoryProperties(dev->phys, &dev->mem);

  const float priority = 1.0f;
  VkDeviceQueueCreateInfo qi{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  qi.queueFamilyIndex = dev->family;
  qi.queueCount = 1;
  qi.pQueuePriorities = &priority;
  // float64 only where it exists: the float-float shaders need no optional feature.
  VkPhysicalDeviceFeatures feats{};
  feats.shaderFloat64 = dev->info.float64 ? VK_TRUE : VK_FALSE;
  VkDeviceCreateInfo ci{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
  ci.queueCreateInfoCount = 1;
  ci.pQueueCreateInfos = &qi;
  ci.pEnabledFeatures = &feats;
  check(vkCreateDevice(dev->phys, &ci, nullptr, &dev->handle), "vkCreateDevice");
  vkGetDeviceQueue(dev->handle, dev->family, 0, &dev->queue);
  (*cache)[chosen] = dev;
  return dev;
}

}  // namespace vpffd::vulkan::detail

namespace vpffd::vulkan {

std::vector<DeviceInfo> devices(std::string* why) {
  using namespace detail;
  std::vector<DeviceInfo> out;
  try {
    std::lock_guard<std::mutex> lock(g_mutex);
    auto inst = instance_locked();
    const auto phys = physical_devices(*inst);
    for (size_t i = 0; i < phys.size(); ++i) out.push_back(describe(phys[i], static_cast<int>(i)));
    if (out.empty() && why) *why = "vulkan: the Vulkan loader reports no devices";
  } catch (const std::exception& e) {
    if (why) *why = e.what();
  }
  return out;
}

const char* precision_name(Precision p) {
  switch (p) {
    case Precision::Float64: return "float64";
    case Precision::FloatFloat: return "float-float";
    default: return "auto";
  }
}

Precision parse_precision(const std::string& name) {
  for (Precision p : {Precision::Auto, Precision::Float64, Precision::FloatFloat})
    if (name == precision_name(p)) return p;
  throw InvalidInputError("precision: expected 'auto', 'float64' or 'float-float', got '" + name + "'");
}

}  // namespace vpffd::vulkan

namespace vpffd::vulkan::detail {

// ---- buffers -----------------------------------------------------------------

Buffer::Buffer(Device& d, VkDeviceSize size, Kind kind, const char* what) : dev_(d.handle), size_(size) {
  // Zero-sized buffers are invalid in Vulkan; empty arrays still need a binding.
  const VkDeviceSize bytes = std::max<VkDeviceSize>(size, 16);
  if (bytes > d.limits.maxStorageBufferRange && kind == DeviceLocal)
    throw DeviceError(vpffd::detail::concat("vulkan: buffer '", what, "' needs ", bytes,
                                            " bytes, more than the device's maxStorageBufferRange (",
                                            d.limits.maxStorageBufferRange, ")"));
  VkBufferCreateInfo bi{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  bi.size = bytes;
  bi.usage = VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
             (kind == DeviceLocal ? VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_VERTEX_BUFFER_BIT |
                                        VK_BUFFER_USAGE_INDEX_BUFFER_BIT
                                  : 0);
  bi.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  check(vkCreateBuffer(dev_, &bi, nullptr, &buf_), "vkCreateBuffer");
  VkMemoryRequirements req;
  vkGetBufferMemoryRequirements(dev_, buf_, &req);
  VkMemoryPropertyFlags want = 0, prefer = 0;
  if (kind == DeviceLocal) {
    prefer = VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT;
  } else {
    want = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
    if (kind == Readback) prefer = VK_MEMORY_PROPERTY_HOST_CACHED_BIT;
  }
  int type = -1;
  for (int pass = 0; pass < 2 && type < 0; ++pass)
    for (std::uint32_t t = 0; t < d.mem.memoryTypeCount; ++t) {
      const VkMemoryPropertyFlags f = d.mem.memoryTypes[t].propertyFlags;
      if (!(req.memoryTypeBits & (1u << t)) || (f & want) != want) continue;
      if (pass == 0 && (f & prefer) != prefer) continue;
      type = static_cast<int>(t);
      break;
    }
  if (type < 0) {
    release();
    throw DeviceError(vpffd::detail::concat("vulkan: no memory type for buffer '", what, "'"));
  }
  VkMemoryAllocateInfo ai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  ai.allocationSize = req.size;
  ai.memoryTypeIndex = static_cast<std::uint32_t>(type);
  VkResult r = vkAllocateMemory(dev_, &ai, nullptr, &mem_);
  if (r != VK_SUCCESS) {
    release();
    throw DeviceError(vpffd::detail::concat("vulkan: vkAllocateMemory of ", req.size, " bytes for buffer '", what,
                                            "' failed: ", result_string(r)));
  }
  r = vkBindBufferMemory(dev_, buf_, mem_, 0);
  if (r == VK_SUCCESS && kind != DeviceLocal) r = vkMapMemory(dev_, mem_, 0, VK_WHOLE_SIZE, 0, &map_);
  if (r != VK_SUCCESS) {
    release();
    check(r, "vkBindBufferMemory/vkMapMemory");
  }
}

Buffer& Buffer::operator=(Buffer&& o) noexcept {
  if (this != &o) {
    release();
    dev_ = o.dev_;
    buf_ = o.buf_;
    mem_ = o.mem_;
    size_ = o.size_;
    map_ = o.map_;
    o.buf_ = VK_NULL_HANDLE;
    o.mem_ = VK_NULL_HANDLE;
    o.map_ = nullptr;
  }
  return *this;
}

void Buffer::release() {
  if (!dev_) return;
  if (map_) vkUnmapMemory(dev_, mem_);
  if (buf_) vkDestroyBuffer(dev_, buf_, nullptr);
  if (mem_) vkFreeMemory(dev_, mem_, nullptr);
  buf_ = VK_NULL_HANDLE;
  mem_ = VK_NULL_HANDLE;
  map_ = nullptr;
}

}  // namespace vpffd::vulkan::detail
