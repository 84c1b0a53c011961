#include "device.hpp"

#include <algorithm>
#include <atomic>
#include <cctype>
#include <limits>

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define RUTD_LEAK_CHECKED 1
#endif
#elif defined(__SANITIZE_ADDRESS__)
#define RUTD_LEAK_CHECKED 1
#endif
#ifdef RUTD_LEAK_CHECKED
#include <sanitizer/lsan_interface.h>
#endif

namespace rutd::gpu {
namespace vk {
namespace {

const char* type_name(VkPhysicalDeviceType t) {
  switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return "discrete";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return "integrated";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return "virtual";
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return "cpu";
    default: return "other";
  }
}

int type_rank(VkPhysicalDeviceType t) {
  switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return 0;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return 1;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return 3;
    default: return 4;
  }
}

// Sanitizer builds only: LeakSanitizer ignores what the driver allocates while the devices are enumerated.
// Mesa's lavapipe (Debian 12's 22.3) detects the CPU on its first enumeration and, on AMD Zen, keeps a
// 128-byte affinity mask per L3 cache in a process-wide table it never frees; the loader unloads the
// driver at vkDestroyInstance, so the report names no module that a suppression file could match.
// Only the driver's call is in the scope: rutd's own allocations are checked as everywhere else.
class DriverAllocationsUnchecked {
 public:
#ifdef RUTD_LEAK_CHECKED
  DriverAllocationsUnchecked() { __lsan_disable(); }
  ~DriverAllocationsUnchecked() { __lsan_enable(); }
#else
  DriverAllocationsUnchecked() = default;
#endif
  DriverAllocationsUnchecked(const DriverAllocationsUnchecked&) = delete;
  DriverAllocationsUnchecked& operator=(const DriverAllocationsUnchecked&) = delete;
};

VkResult enumerate_physical_devices(VkInstance instance, std::uint32_t& n, VkPhysicalDevice* devices) {
  [[maybe_unused]] const DriverAllocationsUnchecked unchecked;  // an empty object without a sanitizer
  return vkEnumeratePhysicalDevices(instance, &n, devices);
}

std::atomic<std::uint64_t> devices_opened{0};

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// "llvmpipe Mesa 22.3.6 (LLVM 15.0.6)", "NVIDIA 580.159.04": the driver's own name and version where the
// device has Vulkan 1.2 (VkPhysicalDeviceDriverProperties), else its raw version number.
std::string driver_of(VkPhysicalDevice pd, const VkPhysicalDeviceProperties& p) {
  if (p.apiVersion >= VK_API_VERSION_1_2) {
    auto driver = info_struct<VkPhysicalDeviceDriverProperties>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES);
    auto props = info_struct<VkPhysicalDeviceProperties2>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2);
    props.pNext = &driver;
    vkGetPhysicalDeviceProperties2(pd, &props);
    std::string s = driver.driverName;
    if (driver.driverInfo[0] != '\0') s += std::string(s.empty() ? "" : " ") + driver.driverInfo;
    if (!s.empty()) return s;
  }
  return "driver version " + std::to_string(p.driverVersion);
}

}  // namespace

VkResult injected(VulkanFaults* faults, VulkanCall call) {
  if (faults == nullptr) return VK_SUCCESS;
  switch (faults->check(call)) {
    case VulkanFault::None: return VK_SUCCESS;
    case VulkanFault::DeviceLost: return VK_ERROR_DEVICE_LOST;
    case VulkanFault::OutOfDeviceMemory: return VK_ERROR_OUT_OF_DEVICE_MEMORY;
    case VulkanFault::InitializationFailed: return VK_ERROR_INITIALIZATION_FAILED;
  }
  return VK_SUCCESS;
}

std::string result_name(VkResult r) {
  switch (r) {
    case VK_SUCCESS: return "VK_SUCCESS";
    case VK_TIMEOUT: return "VK_TIMEOUT";
    case VK_ERROR_OUT_OF_HOST_MEMORY: return "VK_ERROR_OUT_OF_HOST_MEMORY";
    case VK_ERROR_OUT_OF_DEVICE_MEMORY: return "VK_ERROR_OUT_OF_DEVICE_MEMORY";
    case VK_ERROR_INITIALIZATION_FAILED: return "VK_ERROR_INITIALIZATION_FAILED";
    case VK_ERROR_DEVICE_LOST: return "VK_ERROR_DEVICE_LOST";
    case VK_ERROR_MEMORY_MAP_FAILED: return "VK_ERROR_MEMORY_MAP_FAILED";
    case VK_ERROR_LAYER_NOT_PRESENT: return "VK_ERROR_LAYER_NOT_PRESENT";
    case VK_ERROR_EXTENSION_NOT_PRESENT: return "VK_ERROR_EXTENSION_NOT_PRESENT";
    case VK_ERROR_FEATURE_NOT_PRESENT: return "VK_ERROR_FEATURE_NOT_PRESENT";
    case VK_ERROR_INCOMPATIBLE_DRIVER: return "VK_ERROR_INCOMPATIBLE_DRIVER";
    case VK_ERROR_TOO_MANY_OBJECTS: return "VK_ERROR_TOO_MANY_OBJECTS";
    default: return "VkResult " + std::to_string(static_cast<int>(r));
  }
}

void check(VkResult r, const char* call) {
  if (r != VK_SUCCESS) throw GpuError(std::string(call) + ": " + result_name(r));
}

GpuStatus status_of(VkResult r) {
  switch (r) {
    case VK_SUCCESS: return GpuStatus::Ok;
    case VK_TIMEOUT: return GpuStatus::Timeout;
    case VK_ERROR_OUT_OF_HOST_MEMORY:
    case VK_ERROR_OUT_OF_DEVICE_MEMORY: return GpuStatus::OutOfMemory;
    case VK_ERROR_DEVICE_LOST: return GpuStatus::DeviceLost;
    default: return GpuStatus::Failed;
  }
}

VkInstance make_instance() {
  auto app = info_struct<VkApplicationInfo>(VK_STRUCTURE_TYPE_APPLICATION_INFO);
  app.pApplicationName = "rutd";
  // 1.2: the driver's name and version (driver_of()); the matcher itself needs only 1.1.
  app.apiVersion = VK_API_VERSION_1_2;
  auto ci = info_struct<VkInstanceCreateInfo>(VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO);
  ci.pApplicationInfo = &app;
  VkInstance instance = VK_NULL_HANDLE;
  check(vkCreateInstance(&ci, nullptr, &instance), "vkCreateInstance");
  return instance;
}

std::vector<VkPhysicalDevice> physical_devices(VkInstance instance) {
  std::uint32_t n = 0;
  check(enumerate_physical_devices(instance, n, nullptr), "vkEnumeratePhysicalDevices");
  std::vector<VkPhysicalDevice> devices(n);
  check(enumerate_physical_devices(instance, n, devices.data()), "vkEnumeratePhysicalDevices");
  devices.resize(n);
  return devices;
}

GpuDeviceInfo describe(VkPhysicalDevice pd, int index) {
  auto sub = info_struct<VkPhysicalDeviceSubgroupProperties>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES);
  auto props = info_struct<VkPhysicalDeviceProperties2>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2);
  props.pNext = &sub;
  vkGetPhysicalDeviceProperties2(pd, &props);
  GpuDeviceInfo info;
  info.index = index;
  info.name = props.properties.deviceName;
  info.type = type_name(props.properties.deviceType);
  info.subgroup_size = sub.subgroupSize;
  info.driver = driver_of(pd, props.properties);
  VkPhysicalDeviceMemoryProperties memory;
  vkGetPhysicalDeviceMemoryProperties(pd, &memory);
  constexpr VkMemoryPropertyFlags cached =
      VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT | VK_MEMORY_PROPERTY_HOST_CACHED_BIT;
  for (std::uint32_t i = 0; i < memory.memoryTypeCount; ++i)
    if ((memory.memoryTypes[i].propertyFlags & cached) == cached) info.host_cached = true;
  const VkSubgroupFeatureFlags need = VK_SUBGROUP_FEATURE_BASIC_BIT | VK_SUBGROUP_FEATURE_ARITHMETIC_BIT |
                                      VK_SUBGROUP_FEATURE_SHUFFLE_BIT | VK_SUBGROUP_FEATURE_SHUFFLE_RELATIVE_BIT;
  // 16-bit storage: the downloaded disparity (DisparityView) is written 16 bits a pixel.
  auto storage16 =
      info_struct<VkPhysicalDevice16BitStorageFeatures>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_16BIT_STORAGE_FEATURES);
  auto float16 = info_struct<VkPhysicalDeviceShaderFloat16Int8Features>(
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SHADER_FLOAT16_INT8_FEATURES);
  auto features = info_struct<VkPhysicalDeviceFeatures2>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2);
  features.pNext = &storage16;
  if (props.properties.apiVersion >= VK_API_VERSION_1_2) storage16.pNext = &float16;  // core in 1.2
  vkGetPhysicalDeviceFeatures2(pd, &features);
  info.half = float16.shaderFloat16 == VK_TRUE;
  info.usable = props.properties.apiVersion >= VK_API_VERSION_1_1 && (sub.supportedOperations & need) == need &&
                features.features.shaderStorageBufferArrayDynamicIndexing && storage16.storageBuffer16BitAccess &&
                (sub.supportedStages & VK_SHADER_STAGE_COMPUTE_BIT) != 0;
  return info;
}

Device::Device(const std::string& wanted, VulkanFaults* faults) : faults_(faults) {
  instance_ = make_instance();
  try {
    select(wanted);
    try {
      make_device();
    } catch (const GpuError& e) {
      throw GpuError(info_.name + ": " + e.what());
    }
  } catch (...) {
    if (device_) vkDestroyDevice(device_, nullptr);
    vkDestroyInstance(instance_, nullptr);
    throw;
  }
}

Device::~Device() {
  if (device_) vkDestroyDevice(device_, nullptr);
  if (instance_) vkDestroyInstance(instance_, nullptr);
}

void Device::select(const std::string& wanted) {
  const auto devices = physical_devices(instance_);
  std::vector<GpuDeviceInfo> infos;
  for (std::size_t i = 0; i < devices.size(); ++i) infos.push_back(describe(devices[i], static_cast<int>(i)));
  std::string listing;
  for (const auto& d : infos)
    listing +=
        (listing.empty() ? "" : ", ") + std::to_string(d.index) + ": " + d.name + (d.usable ? "" : " (unusable)");
  if (listing.empty()) listing = "none";
  int chosen = -1;
  const bool numeric = !wanted.empty() && std::all_of(wanted.begin(), wanted.end(), [](char c) {
    return std::isdigit(static_cast<unsigned char>(c));
  });
  if (numeric) {
    const int i = std::stoi(wanted);
    if (i < static_cast<int>(infos.size()) && infos[static_cast<std::size_t>(i)].usable) chosen = i;
  } else {
    int best_rank = std::numeric_limits<int>::max();
    for (const auto& d : infos) {
      if (!d.usable) continue;
      if (!wanted.empty()) {
        if (lower(d.name).find(lower(wanted)) == std::string::npos) continue;
        chosen = d.index;
        break;
      }
      VkPhysicalDeviceProperties p;
      vkGetPhysicalDeviceProperties(devices[static_cast<std::size_t>(d.index)], &p);
      if (type_rank(p.deviceType) < best_rank) {
        best_rank = type_rank(p.deviceType);
        chosen = d.index;
      }
    }
  }
  if (chosen < 0)
    throw GpuError("no usable Vulkan device" + (wanted.empty() ? std::string() : " matching '" + wanted + "'") +
                   " (devices: " + listing + ")");
  physical_ = devices[static_cast<std::size_t>(chosen)];
  info_ = infos[static_cast<std::size_t>(chosen)];
}

void Device::make_device() {
  std::uint32_t n = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(physical_, &n, nullptr);
  std::vector<VkQueueFamilyProperties> families(n);
  vkGetPhysicalDeviceQueueFamilyProperties(physical_, &n, families.data());
  bool found = false;
  for (std::uint32_t i = 0; i < n && !found; ++i) {
    if (families[i].queueFlags & VK_QUEUE_COMPUTE_BIT) {
      family_ = i;
      found = true;
    }
  }
  if (!found) throw GpuError("no compute queue");
  const float priority = 1.0f;
  auto qi = info_struct<VkDeviceQueueCreateInfo>(VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO);
  qi.queueFamilyIndex = family_;
  qi.queueCount = 1;
  qi.pQueuePriorities = &priority;
  auto di = info_struct<VkDeviceCreateInfo>(VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO);
  di.queueCreateInfoCount = 1;
  di.pQueueCreateInfos = &qi;
  VkPhysicalDeviceFeatures features{};
  features.shaderStorageBufferArrayDynamicIndexing = VK_TRUE;  // the directions' cost volumes (describe())
  di.pEnabledFeatures = &features;
  auto storage16 =
      info_struct<VkPhysicalDevice16BitStorageFeatures>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_16BIT_STORAGE_FEATURES);
  storage16.storageBuffer16BitAccess = VK_TRUE;  // the downloaded disparity (describe())
  di.pNext = &storage16;
  auto float16 = info_struct<VkPhysicalDeviceShaderFloat16Int8Features>(
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SHADER_FLOAT16_INT8_FEATURES);
  float16.shaderFloat16 = info_.half ? VK_TRUE : VK_FALSE;  // VulkanSgmOptions::aggregate_half
  if (info_.half) storage16.pNext = &float16;
  VkResult r = injected(VulkanCall::CreateDevice);
  if (r == VK_SUCCESS) r = vkCreateDevice(physical_, &di, nullptr, &device_);
  check(r, "vkCreateDevice");
  devices_opened.fetch_add(1, std::memory_order_relaxed);
  vkGetDeviceQueue(device_, family_, 0, &queue_);
  vkGetPhysicalDeviceMemoryProperties(physical_, &memory_);
  VkPhysicalDeviceProperties p;
  vkGetPhysicalDeviceProperties(physical_, &p);
  limits_ = p.limits;
  if (families[family_].timestampValidBits > 0) timestamp_ns_ = p.limits.timestampPeriod;
}

}  // namespace vk

std::vector<GpuDeviceInfo> list_gpu_devices() {
  VkInstance instance = vk::make_instance();
  std::vector<GpuDeviceInfo> out;
  try {
    const auto devices = vk::physical_devices(instance);
    for (std::size_t i = 0; i < devices.size(); ++i) out.push_back(vk::describe(devices[i], static_cast<int>(i)));
  } catch (...) {
    vkDestroyInstance(instance, nullptr);
    throw;
  }
  vkDestroyInstance(instance, nullptr);
  return out;
}

std::uint64_t gpu_devices_opened() { return vk::devices_opened.load(std::memory_order_relaxed); }

std::string describe(const GpuDeviceInfo& info) {
  return info.name + " (" + info.type + ", driver " + info.driver + ", subgroup " + std::to_string(info.subgroup_size) +
         ")";
}

std::string_view to_string(GpuStatus status) {
  switch (status) {
    case GpuStatus::Ok: return "ok";
    case GpuStatus::InvalidInput: return "invalid input";
    case GpuStatus::Timeout: return "timeout";
    case GpuStatus::OutOfMemory: return "out of memory";
    case GpuStatus::DeviceLost: return "device lost";
    case GpuStatus::Failed: return "failed";
  }
  return "unknown";
}

}  // namespace rutd::gpu
