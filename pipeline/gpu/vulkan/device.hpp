#pragma once
// The Vulkan instance and the device the matcher runs on: which physical device, its queue, memory types
// and timestamp period, and how Vulkan results become errors (start-up: GpuError) or statuses (per frame:
// GpuStatus). Private to rutd_gpu.
#include <vulkan/vulkan.h>

#include <cstdint>
#include <string>
#include <vector>

#include "gpu/vulkan_sgm.hpp"

namespace rutd::gpu::vk {

// A Vulkan info structure: zeroed, its type set.
template <class T>
T info_struct(VkStructureType type) {
  T v{};
  v.sType = type;
  return v;
}

std::string result_name(VkResult r);
// Start-up: throws GpuError("call: result") unless r is VK_SUCCESS.
void check(VkResult r, const char* call);
// Per frame: the status a caller acts on.
GpuStatus status_of(VkResult r);

// The result a Vulkan call would return instead of being made (the fault hook, vulkan_faults.hpp), or
// VK_SUCCESS: make the call. faults may be nullptr.
VkResult injected(VulkanFaults* faults, VulkanCall call);

VkInstance make_instance();
std::vector<VkPhysicalDevice> physical_devices(VkInstance instance);
GpuDeviceInfo describe(VkPhysicalDevice pd, int index);

// One logical device with one compute queue. Owns the instance and the device; not copyable.
class Device {
 public:
  // wanted: as VulkanSgm's constructor; faults: VulkanSgmOptions::faults. Throws GpuError naming the device
  // and the failing call.
  Device(const std::string& wanted, VulkanFaults* faults);
  ~Device();
  Device(const Device&) = delete;
  Device& operator=(const Device&) = delete;

  VkDevice handle() const { return device_; }
  VkPhysicalDevice physical() const { return physical_; }
  VkQueue queue() const { return queue_; }
  std::uint32_t family() const { return family_; }
  const VkPhysicalDeviceMemoryProperties& memory() const { return memory_; }
  const VkPhysicalDeviceLimits& limits() const { return limits_; }
  const GpuDeviceInfo& info() const { return info_; }
  double timestamp_ns() const { return timestamp_ns_; }  // per tick; 0: no timestamps on the queue
  std::uint32_t subgroup_size() const { return info_.subgroup_size > 0 ? info_.subgroup_size : 1; }
  // The fault hook at this device's calls: VK_SUCCESS, or the result `call` is to return instead.
  VkResult injected(VulkanCall call) const { return vk::injected(faults_, call); }

 private:
  void select(const std::string& wanted);
  void make_device();

  VkInstance instance_ = VK_NULL_HANDLE;
  VkPhysicalDevice physical_ = VK_NULL_HANDLE;
  VkDevice device_ = VK_NULL_HANDLE;
  // One queue: the slots' frames follow each other on the device (a second queue of the same family was
  // measured slower on an H100: the frames did not overlap, and each paid a switch).
  VkQueue queue_ = VK_NULL_HANDLE;
  std::uint32_t family_ = 0;
  VkPhysicalDeviceMemoryProperties memory_{};
  VkPhysicalDeviceLimits limits_{};
  GpuDeviceInfo info_;
  double timestamp_ns_ = 0;
  VulkanFaults* faults_ = nullptr;
};

}  // namespace rutd::gpu::vk
