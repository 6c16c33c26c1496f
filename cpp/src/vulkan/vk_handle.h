#pragma once
// Owned<H>: one Vulkan object of a device with its destroy function, released when the
// owner goes (or is reset), so that no error path leaks a pipeline, layout or pool.

#include <volk.h>

#include <utility>

namespace vpffd::vulkan {

template <class H>
class Owned {
 public:
  using Destroy = void(VKAPI_PTR*)(VkDevice, H, const VkAllocationCallbacks*);

  Owned() = default;
  ~Owned() { reset(); }
  Owned(Owned&& o) noexcept { *this = std::move(o); }
  Owned& operator=(Owned&& o) noexcept {
    if (this != &o) {
      reset();
      std::swap(d_, o.d_);
      std::swap(h_, o.h_);
      std::swap(destroy_, o.destroy_);
    }
    return *this;
  }
  Owned(const Owned&) = delete;
  Owned& operator=(const Owned&) = delete;

  /// Takes `h`, created on `d`; `destroy` (volk's function pointer, read now) releases it.
  void adopt(VkDevice d, H h, Destroy destroy) {
    reset();
    d_ = d;
    h_ = h;
    destroy_ = destroy;
  }
  const H& get() const { return h_; }
  explicit operator bool() const { return h_ != VK_NULL_HANDLE; }
  void reset() {
    if (h_ != VK_NULL_HANDLE && destroy_) destroy_(d_, h_, nullptr);
    h_ = VK_NULL_HANDLE;
  }

 private:
  VkDevice d_ = VK_NULL_HANDLE;
  H h_ = VK_NULL_HANDLE;
  Destroy destroy_ = nullptr;
};

}  // namespace vpffd::vulkan
