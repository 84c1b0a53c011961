#include "gpu/vulkan_sgm.hpp"

#include <vulkan/vulkan.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <tuple>

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
namespace {

// SPIR-V of shaders/*.comp, compiled by glslc at build time (pipeline/gpu/CMakeLists.txt).
const std::uint32_t kCensusSpv[] =
#include "census.comp.inc"
    ;
const std::uint32_t kCostSpv[] =
#include "cost.comp.inc"
    ;
const std::uint32_t kAggregateSpv[] =
#include "aggregate.comp.inc"
    ;
const std::uint32_t kWtaSpv[] =
#include "wta.comp.inc"
    ;
const std::uint32_t kLrMedianSpv[] =
#include "lr_median.comp.inc"
    ;
const std::uint32_t kBsplineSpv[] =
#include "bspline.comp.inc"
    ;
const std::uint32_t kDicSpv[] =
#include "dic.comp.inc"
    ;
const std::uint32_t kRectifySpv[] =
#include "rectify.comp.inc"
    ;
const std::uint32_t kDownsampleSpv[] =
#include "downsample.comp.inc"
    ;

// start, after upload, rectify, census, aggregate, wta, lr/median, dic, download
constexpr std::uint32_t kTimestamps = 9;

// A Vulkan info structure: zeroed, its type set.
template <class T>
T info_struct(VkStructureType type) {
  T v{};
  v.sType = type;
  return v;
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

// Start-up: any failure throws.
void check(VkResult r, const char* call) {
  if (r != VK_SUCCESS) throw GpuError(std::string(call) + ": " + result_name(r));
}

// Per frame: a status the caller acts on.
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

VkInstance make_instance() {
  auto app = info_struct<VkApplicationInfo>(VK_STRUCTURE_TYPE_APPLICATION_INFO);
  app.pApplicationName = "rutd";
  app.apiVersion = VK_API_VERSION_1_1;
  auto ci = info_struct<VkInstanceCreateInfo>(VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO);
  ci.pApplicationInfo = &app;
  VkInstance instance = VK_NULL_HANDLE;
  check(vkCreateInstance(&ci, nullptr, &instance), "vkCreateInstance");
  return instance;
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
  const VkSubgroupFeatureFlags need = VK_SUBGROUP_FEATURE_BASIC_BIT | VK_SUBGROUP_FEATURE_ARITHMETIC_BIT;
  VkPhysicalDeviceFeatures features;
  vkGetPhysicalDeviceFeatures(pd, &features);
  info.usable = props.properties.apiVersion >= VK_API_VERSION_1_1 && (sub.supportedOperations & need) == need &&
                features.shaderStorageBufferArrayDynamicIndexing &&
                (sub.supportedStages & VK_SHADER_STAGE_COMPUTE_BIT) != 0;
  return info;
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

struct Buffer {
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkDeviceSize size = 0;
  void* mapped = nullptr;  // host-visible buffers stay mapped
};

// Every buffer one frame's work uses on the device. Each slot has its own, so that two frames in flight
// share nothing and the device may overlap them.
struct FrameBuffers {
  // match_cost: cost.comp's byte costs; costs: aggregate.comp's, one buffer per direction; right_key: the
  // right view as wta.comp's keys.
  Buffer image_left, image_right, census_left, census_right, match_cost, disp_left, right_key, disparity;
  std::array<Buffer, 8> costs;
  Buffer spline_left, spline_right, refined;  // DIC
  Buffer raw_left, raw_right;                 // raw images to rectify (set_rectification)
};

constexpr int kSlots = 2;

struct Kernel {
  VkDescriptorSetLayout set_layout = VK_NULL_HANDLE;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkPipeline pipeline = VK_NULL_HANDLE;
  std::array<VkDescriptorSet, kSlots> sets{};  // a slot's FrameBuffers
};

// The buffers of each binding of a kernel (several: an array of descriptors), from a slot's FrameBuffers.
using Bindings = std::vector<std::vector<const Buffer*>>;

// words: 32-bit words of byte costs per pixel and direction (aggregate.comp).
struct CostPush {
  std::int32_t width, height, min_disparity, num_disparities, words;
};
struct AggregatePush {
  std::int32_t width, height, num_disparities, p1, p2, words, segment, run_in;
};
struct WtaPush {
  std::int32_t width, height, min_disparity, num_disparities, uniqueness, paths, words;
};
struct LrMedianPush {
  std::int32_t width, height, max_diff, median, min_disparity;
};
struct CensusPush {
  std::int32_t width, height, words_per_row;
};
struct DownsamplePush {
  std::int32_t width, height, words_per_row, coarse_width, coarse_height, coarse_words_per_row, scale, row_factor;
};
struct RectifyPush {
  std::int32_t width, height, words_per_row, raw_width, raw_height, raw_words_per_row, raw_row0;
};
struct DicPush {
  std::int32_t width, height, words_per_row, h, hh, max_iterations, step, row_step, first_row, columns, first_order;
  float tolerance, max_shift, max_gradient, min_gradient, min_zncc, max_sigma;
  std::int32_t rows, blocks;  // column windows
};

std::uint32_t groups(int n, int size) { return static_cast<std::uint32_t>((n + size - 1) / size); }

// `rows` rows of `row_bytes` bytes each, from rows `src_stride` bytes apart to rows `dst_stride` bytes apart.
void copy_rows(void* dst, std::size_t dst_stride, const void* src, std::size_t src_stride, std::size_t row_bytes,
               int rows) {
  auto* d = static_cast<std::uint8_t*>(dst);
  const auto* s = static_cast<const std::uint8_t*>(src);
  for (std::size_t y = 0; y < static_cast<std::size_t>(rows); ++y)
    std::memcpy(d + y * dst_stride, s + y * src_stride, row_bytes);
}

constexpr int kPathsMax = 8;                     // FrameBuffers::costs
constexpr int kWtaSegment = 16;                  // pixels per workgroup of wta.comp
constexpr std::uint32_t kNoMatch = 0xFFFFFFFFu;  // right_key: no disparity
constexpr std::uint32_t kNanBits = 0x7FC00000u;  // a quiet NaN, float bits
// Words of four byte costs per pixel: a multiple of 4, so that wta.comp reads them 16 bytes at a time.
int cost_words(int disparities) { return (disparities + 15) / 16 * 4; }

}  // namespace

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

std::vector<GpuDeviceInfo> list_gpu_devices() {
  VkInstance instance = make_instance();
  std::vector<GpuDeviceInfo> out;
  try {
    const auto devices = physical_devices(instance);
    for (std::size_t i = 0; i < devices.size(); ++i) out.push_back(describe(devices[i], static_cast<int>(i)));
  } catch (...) {
    vkDestroyInstance(instance, nullptr);
    throw;
  }
  vkDestroyInstance(instance, nullptr);
  return out;
}

// What a frame's command buffer starts from: packed rectified strips, or raw images rectified on the
// device and then matched, or only rectified, or rectified and matched coarse (the band estimate).
enum class Input { Rectified, Raw, RawOnly, RawCoarse };

struct VulkanSgm::Impl {
  int width = 0, height = 0, max_disparities = 0, words_per_row = 0;
  VkDeviceSize image_bytes = 0;  // one packed strip
  // set_rectification: the raw size; the raw rows the maps reach, the only ones uploaded; one packed
  // image's bytes of them; and the maps (shared by both slots).
  int raw_width = 0, raw_height = 0, raw_words_per_row = 0, raw_row0 = 0, raw_rows = 0;
  VkDeviceSize raw_bytes = 0;
  Buffer map_left, map_right;
  VkDeviceSize upload_half = 0;  // offset of the right image in a slot's upload buffer
  std::uint64_t timeout_ns = 0;
  GpuDeviceInfo info;
  VkInstance instance = VK_NULL_HANDLE;
  VkPhysicalDevice physical = VK_NULL_HANDLE;
  VkDevice device = VK_NULL_HANDLE;
  // One queue: the slots' frames follow each other on the device (a second queue of the same family
  // was measured slower on an H100: the frames did not overlap, and each paid a switch).
  VkQueue queue = VK_NULL_HANDLE;
  std::uint32_t family = 0;
  VkPhysicalDeviceMemoryProperties memory{};
  double timestamp_ns = 0;  // per tick; 0: no timestamps on this queue
  VkCommandPool pool = VK_NULL_HANDLE;
  VkDescriptorPool descriptors = VK_NULL_HANDLE;
  VkQueryPool queries = VK_NULL_HANDLE;
  std::uint32_t subgroup_size = 1;
  int aggregate_threads = 0;  // 0: subgroup_size
  // What a slot's command buffer was recorded for: the same frame parameters submit it again unrecorded.
  struct Recorded {
    bool valid = false, dic = false;
    Input input = Input::Rectified;
    int coarse_scale = 0;  // RawCoarse
    SgmBand band;
    SgmConfig params;
    DicKernelConfig dic_params;
    bool operator==(const Recorded& o) const {
      const auto tie_sgm = [](const Recorded& r) {
        return std::tie(r.band.min_disparity, r.band.num_disparities, r.params.paths, r.params.p1, r.params.p2,
                        r.params.uniqueness, r.params.lr_max_diff, r.params.median, r.params.segment,
                        r.params.segment_run_in);
      };
      const auto tie_dic = [](const DicKernelConfig& d) {
        return std::tie(d.half_window, d.half_height, d.max_iterations, d.tolerance_px, d.step, d.row_step, d.row_begin,
                        d.row_end, d.first_order, d.max_shift_px, d.max_gradient, d.min_gradient, d.min_zncc,
                        d.max_sigma_px, d.column_windows, d.column_block_rows);
      };
      if (!valid || !o.valid || input != o.input || coarse_scale != o.coarse_scale) return false;
      if (input == Input::RawOnly) return true;
      return dic == o.dic && tie_sgm(*this) == tie_sgm(o) && (!dic || tie_dic(dic_params) == tie_dic(o.dic_params));
    }
  };
  struct Slot {
    FrameBuffers dev;
    Recorded recorded;
    Buffer upload;                   // host-visible: left image at 0, right at upload_half, packed words
    Buffer download;                 // host-visible: the disparity (floats), then both packed strips (raw input)
    Input input = Input::Rectified;  // of the frame in flight
    CoarseGrid grid;                 // RawCoarse: of the frame in flight
    VkCommandBuffer commands = VK_NULL_HANDLE;
    VkFence fence = VK_NULL_HANDLE;
    bool busy = false;
  };
  std::array<Slot, kSlots> slots;
  int next_slot = 0;
  Kernel census, cost, aggregate, wta, lr_median, bspline, dic, dic_columns;  // dic.comp in its two modes
  Kernel rectify, downsample;                                                 // set_rectification
  bool lost = false;

  ~Impl() {
    if (device) {
      vkDeviceWaitIdle(device);
      for (Kernel* k :
           {&census, &cost, &aggregate, &wta, &lr_median, &bspline, &dic, &dic_columns, &rectify, &downsample}) {
        vkDestroyPipeline(device, k->pipeline, nullptr);
        vkDestroyPipelineLayout(device, k->layout, nullptr);
        vkDestroyDescriptorSetLayout(device, k->set_layout, nullptr);
      }
      for (Slot& s : slots) {
        FrameBuffers& f = s.dev;
        for (Buffer* b :
             {&f.image_left, &f.image_right, &f.census_left, &f.census_right, &f.match_cost, &f.disp_left, &f.right_key,
              &f.disparity, &f.spline_left, &f.spline_right, &f.refined, &f.raw_left, &f.raw_right})
          destroy(*b);
        for (Buffer& b : f.costs) destroy(b);
        destroy(s.upload);
        destroy(s.download);
        vkDestroyFence(device, s.fence, nullptr);
      }
      destroy(map_left);
      destroy(map_right);
      vkDestroyQueryPool(device, queries, nullptr);
      vkDestroyDescriptorPool(device, descriptors, nullptr);
      vkDestroyCommandPool(device, pool, nullptr);
      vkDestroyDevice(device, nullptr);
    }
    if (instance) vkDestroyInstance(instance, nullptr);
  }

  void destroy(Buffer& b) {
    if (b.mapped) vkUnmapMemory(device, b.memory);
    vkDestroyBuffer(device, b.buffer, nullptr);
    vkFreeMemory(device, b.memory, nullptr);
    b = Buffer{};
  }

  void select(const std::string& wanted) {
    const auto devices = physical_devices(instance);
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
    physical = devices[static_cast<std::size_t>(chosen)];
    info = infos[static_cast<std::size_t>(chosen)];
  }

  void make_device() {
    std::uint32_t n = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(physical, &n, nullptr);
    std::vector<VkQueueFamilyProperties> families(n);
    vkGetPhysicalDeviceQueueFamilyProperties(physical, &n, families.data());
    bool found = false;
    for (std::uint32_t i = 0; i < n && !found; ++i) {
      if (families[i].queueFlags & VK_QUEUE_COMPUTE_BIT) {
        family = i;
        found = true;
      }
    }
    if (!found) throw GpuError(info.name + ": no compute queue");
    const float priority = 1.0f;
    auto qi = info_struct<VkDeviceQueueCreateInfo>(VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO);
    qi.queueFamilyIndex = family;
    qi.queueCount = 1;
    qi.pQueuePriorities = &priority;
    auto di = info_struct<VkDeviceCreateInfo>(VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO);
    di.queueCreateInfoCount = 1;
    di.pQueueCreateInfos = &qi;
    VkPhysicalDeviceFeatures features{};
    features.shaderStorageBufferArrayDynamicIndexing = VK_TRUE;  // the directions' cost volumes (describe())
    di.pEnabledFeatures = &features;
    check(vkCreateDevice(physical, &di, nullptr, &device), "vkCreateDevice");
    vkGetDeviceQueue(device, family, 0, &queue);
    vkGetPhysicalDeviceMemoryProperties(physical, &memory);
    VkPhysicalDeviceProperties p;
    vkGetPhysicalDeviceProperties(physical, &p);
    if (families[family].timestampValidBits > 0) timestamp_ns = p.limits.timestampPeriod;
  }

  Buffer make_buffer(VkDeviceSize size, VkBufferUsageFlags usage, bool host) {
    Buffer b;
    b.size = std::max<VkDeviceSize>(size, 4);
    auto bi = info_struct<VkBufferCreateInfo>(VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO);
    bi.size = b.size;
    bi.usage = usage;
    bi.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    check(vkCreateBuffer(device, &bi, nullptr, &b.buffer), "vkCreateBuffer");
    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(device, b.buffer, &req);
    // Host buffers: coherent, cached if possible (the download is read by the CPU). Device buffers: local.
    const VkMemoryPropertyFlags want =
        host ? (VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT)
             : VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT;
    std::uint32_t type = std::numeric_limits<std::uint32_t>::max();
    for (int pass = 0; pass < 2 && type == std::numeric_limits<std::uint32_t>::max(); ++pass) {
      for (std::uint32_t i = 0; i < memory.memoryTypeCount; ++i) {
        const VkMemoryPropertyFlags f = memory.memoryTypes[i].propertyFlags;
        const bool cached = (f & VK_MEMORY_PROPERTY_HOST_CACHED_BIT) != 0;
        if ((req.memoryTypeBits & (1u << i)) && (f & want) == want && (pass == 1 || !host || cached)) {
          type = i;
          break;
        }
      }
    }
    if (type == std::numeric_limits<std::uint32_t>::max()) throw GpuError(info.name + ": no suitable memory type");
    auto ai = info_struct<VkMemoryAllocateInfo>(VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO);
    ai.allocationSize = req.size;
    ai.memoryTypeIndex = type;
    check(vkAllocateMemory(device, &ai, nullptr, &b.memory), "vkAllocateMemory");
    check(vkBindBufferMemory(device, b.buffer, b.memory, 0), "vkBindBufferMemory");
    if (host) check(vkMapMemory(device, b.memory, 0, VK_WHOLE_SIZE, 0, &b.mapped), "vkMapMemory");
    return b;
  }

  // bindings[i]: the buffers of binding i, an array of descriptors where there are several.
  // bindings: of each slot's FrameBuffers. spec: the values of the shader's specialization constants 0, 1,
  // ..., where it has them.
  template <class BindingsOf>
  Kernel make_kernel(const std::uint32_t* spv, std::size_t bytes, std::uint32_t push_bytes, BindingsOf bindings_of,
                     const std::vector<std::int32_t>& spec = {}, VkPipelineCreateFlags flags = 0) {
    const Bindings bindings = bindings_of(slots[0].dev);
    Kernel k;
    std::vector<VkDescriptorSetLayoutBinding> lb(bindings.size());
    for (std::size_t i = 0; i < lb.size(); ++i) {
      lb[i] = VkDescriptorSetLayoutBinding{static_cast<std::uint32_t>(i), VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                                           static_cast<std::uint32_t>(bindings[i].size()), VK_SHADER_STAGE_COMPUTE_BIT,
                                           nullptr};
    }
    auto li = info_struct<VkDescriptorSetLayoutCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO);
    li.bindingCount = static_cast<std::uint32_t>(lb.size());
    li.pBindings = lb.data();
    check(vkCreateDescriptorSetLayout(device, &li, nullptr, &k.set_layout), "vkCreateDescriptorSetLayout");
    const VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, push_bytes};
    auto pli = info_struct<VkPipelineLayoutCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO);
    pli.setLayoutCount = 1;
    pli.pSetLayouts = &k.set_layout;
    pli.pushConstantRangeCount = 1;
    pli.pPushConstantRanges = &range;
    check(vkCreatePipelineLayout(device, &pli, nullptr, &k.layout), "vkCreatePipelineLayout");
    auto mi = info_struct<VkShaderModuleCreateInfo>(VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO);
    mi.codeSize = bytes;
    mi.pCode = spv;
    VkShaderModule module = VK_NULL_HANDLE;
    check(vkCreateShaderModule(device, &mi, nullptr, &module), "vkCreateShaderModule");
    auto ci = info_struct<VkComputePipelineCreateInfo>(VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO);
    ci.stage = info_struct<VkPipelineShaderStageCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO);
    ci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    ci.stage.module = module;
    ci.stage.pName = "main";
    std::vector<VkSpecializationMapEntry> entries;
    for (std::uint32_t i = 0; i < spec.size(); ++i)
      entries.push_back(VkSpecializationMapEntry{i, i * 4, sizeof(std::int32_t)});
    const VkSpecializationInfo spec_info{static_cast<std::uint32_t>(entries.size()), entries.data(),
                                         spec.size() * sizeof(std::int32_t), spec.data()};
    if (!spec.empty()) ci.stage.pSpecializationInfo = &spec_info;
    ci.layout = k.layout;
    ci.flags = flags;
    const VkResult r = vkCreateComputePipelines(device, VK_NULL_HANDLE, 1, &ci, nullptr, &k.pipeline);
    vkDestroyShaderModule(device, module, nullptr);
    check(r, "vkCreateComputePipelines");
    auto ai = info_struct<VkDescriptorSetAllocateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO);
    ai.descriptorPool = descriptors;
    ai.descriptorSetCount = 1;
    ai.pSetLayouts = &k.set_layout;
    for (int slot = 0; slot < kSlots; ++slot) {
      VkDescriptorSet& set = k.sets[static_cast<std::size_t>(slot)];
      check(vkAllocateDescriptorSets(device, &ai, &set), "vkAllocateDescriptorSets");
      write_set(set, bindings_of(slots[static_cast<std::size_t>(slot)].dev));
    }
    return k;
  }

  void write_set(VkDescriptorSet set, const Bindings& bindings) {
    std::vector<std::vector<VkDescriptorBufferInfo>> bi(bindings.size());
    std::vector<VkWriteDescriptorSet> w(bindings.size());
    for (std::size_t i = 0; i < bindings.size(); ++i) {
      for (const Buffer* b : bindings[i]) bi[i].push_back(VkDescriptorBufferInfo{b->buffer, 0, VK_WHOLE_SIZE});
      w[i] = info_struct<VkWriteDescriptorSet>(VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET);
      w[i].dstSet = set;
      w[i].dstBinding = static_cast<std::uint32_t>(i);
      w[i].descriptorCount = static_cast<std::uint32_t>(bi[i].size());
      w[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
      w[i].pBufferInfo = bi[i].data();
    }
    vkUpdateDescriptorSets(device, static_cast<std::uint32_t>(w.size()), w.data(), 0, nullptr);
  }

  void setup() {
    words_per_row = (width + 3) / 4;
    const auto pixels = static_cast<VkDeviceSize>(width) * static_cast<VkDeviceSize>(height);
    image_bytes = static_cast<VkDeviceSize>(words_per_row) * static_cast<VkDeviceSize>(height) * 4;
    upload_half = image_bytes;
    const VkBufferUsageFlags storage =
        VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    // One volume per direction, so that each stays within the device's range for one storage buffer.
    const VkDeviceSize cost_bytes = pixels * static_cast<VkDeviceSize>(cost_words(max_disparities)) * 4;
    VkPhysicalDeviceProperties props;
    vkGetPhysicalDeviceProperties(physical, &props);
    if (cost_bytes > props.limits.maxStorageBufferRange)
      throw GpuError("the path costs of " + std::to_string(width) + "x" + std::to_string(height) + " px and " +
                     std::to_string(max_disparities) + " disparities need " + std::to_string(cost_bytes) +
                     " bytes a direction, over maxStorageBufferRange " +
                     std::to_string(props.limits.maxStorageBufferRange));
    subgroup_size = std::max<std::uint32_t>(info.subgroup_size, 1);
    for (Slot& s : slots) {
      FrameBuffers& f = s.dev;
      f.image_left = make_buffer(image_bytes, storage, false);
      f.image_right = make_buffer(image_bytes, storage, false);
      f.census_left = make_buffer(pixels * 8, storage, false);
      f.census_right = make_buffer(pixels * 8, storage, false);
      f.match_cost = make_buffer(cost_bytes, storage, false);
      for (Buffer& b : f.costs) b = make_buffer(cost_bytes, storage, false);
      for (Buffer* b : {&f.disp_left, &f.right_key, &f.disparity, &f.spline_left, &f.spline_right, &f.refined})
        *b = make_buffer(pixels * 4, storage, false);
    }

    auto pi = info_struct<VkCommandPoolCreateInfo>(VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO);
    pi.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
    pi.queueFamilyIndex = family;
    check(vkCreateCommandPool(device, &pi, nullptr, &pool), "vkCreateCommandPool");
    for (Slot& s : slots) {
      s.upload = make_buffer(image_bytes * 2, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, true);
      // The disparity, both strips, and (band estimate) the coarse left image.
      s.download = make_buffer(pixels * 4 + 3 * image_bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT, true);
      auto ai = info_struct<VkCommandBufferAllocateInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO);
      ai.commandPool = pool;
      ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
      ai.commandBufferCount = 1;
      check(vkAllocateCommandBuffers(device, &ai, &s.commands), "vkAllocateCommandBuffers");
      auto fi = info_struct<VkFenceCreateInfo>(VK_STRUCTURE_TYPE_FENCE_CREATE_INFO);
      check(vkCreateFence(device, &fi, nullptr, &s.fence), "vkCreateFence");
    }
    if (timestamp_ns > 0) {
      auto qi = info_struct<VkQueryPoolCreateInfo>(VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO);
      qi.queryType = VK_QUERY_TYPE_TIMESTAMP;
      qi.queryCount = kTimestamps * kSlots;
      check(vkCreateQueryPool(device, &qi, nullptr, &queries), "vkCreateQueryPool");
    }
    // Room for every kernel's sets, set_rectification's included.
    const VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 64 * kSlots};
    auto dpi = info_struct<VkDescriptorPoolCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO);
    dpi.maxSets = 12 * kSlots;
    dpi.poolSizeCount = 1;
    dpi.pPoolSizes = &size;
    check(vkCreateDescriptorPool(device, &dpi, nullptr, &descriptors), "vkCreateDescriptorPool");
    const auto all_costs = [](const FrameBuffers& f) {
      std::vector<const Buffer*> v;
      for (const Buffer& b : f.costs) v.push_back(&b);
      return v;
    };
    census = make_kernel(kCensusSpv, sizeof kCensusSpv, sizeof(CensusPush), [](const FrameBuffers& f) -> Bindings {
      return {{&f.image_left}, {&f.image_right}, {&f.census_left}, {&f.census_right}};
    });
    cost = make_kernel(kCostSpv, sizeof kCostSpv, sizeof(CostPush), [](const FrameBuffers& f) -> Bindings {
      return {{&f.census_left}, {&f.census_right}, {&f.match_cost}};
    });
    // aggregate.comp: a workgroup of one subgroup as the device reports it, each invocation a block of
    // words of four disparities, enough for max_disparities.
    const auto threads = aggregate_threads > 0
                             ? aggregate_threads
                             : static_cast<std::int32_t>(std::clamp<std::uint32_t>(subgroup_size, 4, 128));
    const std::int32_t words_each = (cost_words(max_disparities) + threads - 1) / threads;
    aggregate = make_kernel(
        kAggregateSpv, sizeof kAggregateSpv, sizeof(AggregatePush),
        [&](const FrameBuffers& f) -> Bindings {
          return {{&f.match_cost}, all_costs(f)};
        },
        {threads, words_each}, VK_PIPELINE_CREATE_DISPATCH_BASE_BIT);
    wta = make_kernel(kWtaSpv, sizeof kWtaSpv, sizeof(WtaPush), [&](const FrameBuffers& f) -> Bindings {
      return {all_costs(f), {&f.disp_left}, {&f.right_key}};
    });
    lr_median =
        make_kernel(kLrMedianSpv, sizeof kLrMedianSpv, sizeof(LrMedianPush), [](const FrameBuffers& f) -> Bindings {
          return {{&f.disp_left}, {&f.right_key}, {&f.disparity}};
        });
    bspline = make_kernel(kBsplineSpv, sizeof kBsplineSpv, sizeof(CensusPush), [](const FrameBuffers& f) -> Bindings {
      return {{&f.image_left}, {&f.image_right}, {&f.spline_left}, {&f.spline_right}};
    });
    const auto dic_bindings = [](const FrameBuffers& f) -> Bindings {
      return {{&f.image_left}, {&f.spline_left}, {&f.spline_right}, {&f.disparity}, {&f.refined}};
    };
    dic = make_kernel(kDicSpv, sizeof kDicSpv, sizeof(DicPush), dic_bindings, {0});
    dic_columns = make_kernel(kDicSpv, sizeof kDicSpv, sizeof(DicPush), dic_bindings, {1});
  }

  void barrier(VkCommandBuffer cb, VkPipelineStageFlags src, VkPipelineStageFlags dst) {
    auto mb = info_struct<VkMemoryBarrier>(VK_STRUCTURE_TYPE_MEMORY_BARRIER);
    mb.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT;
    mb.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_READ_BIT |
                       VK_ACCESS_TRANSFER_WRITE_BIT | VK_ACCESS_HOST_READ_BIT;
    vkCmdPipelineBarrier(cb, src, dst, 0, 1, &mb, 0, nullptr, 0, nullptr);
  }

  void stamp(VkCommandBuffer cb, int slot, std::uint32_t i) {
    if (queries)
      vkCmdWriteTimestamp(cb, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, queries,
                          static_cast<std::uint32_t>(slot) * kTimestamps + i);
  }

  template <class Push>
  void dispatch(VkCommandBuffer cb, int slot, const Kernel& k, const Push& push, std::uint32_t x, std::uint32_t y,
                std::uint32_t z) {
    vkCmdBindPipeline(cb, VK_PIPELINE_BIND_POINT_COMPUTE, k.pipeline);
    vkCmdBindDescriptorSets(cb, VK_PIPELINE_BIND_POINT_COMPUTE, k.layout, 0, 1, &k.sets[static_cast<std::size_t>(slot)],
                            0, nullptr);
    vkCmdPushConstants(cb, k.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(Push), &push);
    vkCmdDispatch(cb, x, y, z);
  }

  VkResult record(int slot, Input input, SgmBand band, const SgmConfig& params, const DicKernelConfig* dic_params,
                  const CoarseGrid& grid) {
    const VkCommandBuffer cb = slots[static_cast<std::size_t>(slot)].commands;
    constexpr VkPipelineStageFlags compute = VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT;
    constexpr VkPipelineStageFlags transfer = VK_PIPELINE_STAGE_TRANSFER_BIT;
    VkResult r = vkResetCommandBuffer(cb, 0);
    if (r != VK_SUCCESS) return r;
    auto bi = info_struct<VkCommandBufferBeginInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO);
    if ((r = vkBeginCommandBuffer(cb, &bi)) != VK_SUCCESS) return r;
    if (queries) vkCmdResetQueryPool(cb, queries, static_cast<std::uint32_t>(slot) * kTimestamps, kTimestamps);
    // No barrier against the other slot's frame: it uses its own buffers. This slot's last frame is
    // complete: submit() waits for its fence before recording again.
    const FrameBuffers& f = slots[static_cast<std::size_t>(slot)].dev;
    stamp(cb, slot, 0);
    const Buffer& up = slots[static_cast<std::size_t>(slot)].upload;
    const Buffer& down = slots[static_cast<std::size_t>(slot)].download;
    const bool raw = input != Input::Rectified;
    const VkDeviceSize bytes = raw ? raw_bytes : image_bytes;
    VkBufferCopy copy{0, 0, bytes};
    vkCmdCopyBuffer(cb, up.buffer, (raw ? f.raw_left : f.image_left).buffer, 1, &copy);
    copy.srcOffset = upload_half;
    vkCmdCopyBuffer(cb, up.buffer, (raw ? f.raw_right : f.image_right).buffer, 1, &copy);
    if (input != Input::RawOnly) {
      // wta.comp takes the minimum key per right pixel with atomics; lr_median.comp reads none as no match.
      vkCmdFillBuffer(cb, f.right_key.buffer, 0, VK_WHOLE_SIZE, kNoMatch);
      if (dic_params) vkCmdFillBuffer(cb, f.refined.buffer, 0, VK_WHOLE_SIZE, kNanBits);  // pixels not refined
    }
    barrier(cb, transfer, compute);
    stamp(cb, slot, 1);
    const VkDeviceSize strips_at = static_cast<VkDeviceSize>(width) * static_cast<VkDeviceSize>(height) * 4;
    if (raw) {
      dispatch(cb, slot, rectify,
               RectifyPush{width, height, words_per_row, raw_width, raw_height, raw_words_per_row, raw_row0},
               groups(words_per_row, 64), static_cast<std::uint32_t>(height), 2);
      barrier(cb, compute, compute | transfer);
      // The strips go back for the host's frame checks, copied while the matcher runs.
      copy = VkBufferCopy{0, strips_at, image_bytes};
      vkCmdCopyBuffer(cb, f.image_left.buffer, down.buffer, 1, &copy);
      copy.dstOffset = strips_at + image_bytes;
      vkCmdCopyBuffer(cb, f.image_right.buffer, down.buffer, 1, &copy);
    }
    // The matcher's size: the strips', or the coarse images' (band estimate), which replace the strips in
    // their buffers once the strips are on their way to the host.
    int w = width, h = height, wpr = words_per_row;
    if (input == Input::RawCoarse) {
      w = grid.width;
      h = grid.height;
      wpr = (w + 3) / 4;
      dispatch(cb, slot, downsample,
               DownsamplePush{width, height, words_per_row, w, h, wpr, grid.scale, grid.row_factor}, groups(wpr, 64),
               static_cast<std::uint32_t>(h), 2);
      barrier(cb, compute | transfer, transfer);
      copy = VkBufferCopy{0, 0, static_cast<VkDeviceSize>(wpr) * static_cast<VkDeviceSize>(h) * 4};
      vkCmdCopyBuffer(cb, f.census_left.buffer, f.image_left.buffer, 1, &copy);
      vkCmdCopyBuffer(cb, f.census_right.buffer, f.image_right.buffer, 1, &copy);
      barrier(cb, transfer, compute | transfer);
      copy.dstOffset = strips_at + 2 * image_bytes;
      vkCmdCopyBuffer(cb, f.image_left.buffer, down.buffer, 1, &copy);
    }
    stamp(cb, slot, 2);
    if (input == Input::RawOnly) {
      barrier(cb, transfer, VK_PIPELINE_STAGE_HOST_BIT);
      for (std::uint32_t i = 3; i < kTimestamps; ++i) stamp(cb, slot, i);
      return vkEndCommandBuffer(cb);
    }
    dispatch(cb, slot, census, CensusPush{w, h, wpr}, groups(w, 16), groups(h, 8), 2);
    if (dic_params) dispatch(cb, slot, bspline, CensusPush{w, h, wpr}, groups(w, 64), static_cast<std::uint32_t>(h), 2);
    barrier(cb, compute, compute);
    stamp(cb, slot, 3);
    const int lines = params.paths == 2 ? h : params.paths == 4 ? std::max(w, h) : w + h - 1;
    const int words = cost_words(band.num_disparities);
    dispatch(cb, slot, cost, CostPush{w, h, band.min_disparity, band.num_disparities, words}, groups(w * words, 64),
             static_cast<std::uint32_t>(h), 1);
    barrier(cb, compute, compute);
    // Workgroups (line, direction, segment): the two horizontal directions (0, 1) have a segment per
    // workgroup z when rows are segmented; the others one, dispatched on their own from direction 2.
    const int segments = params.segment > 0 ? (w + params.segment - 1) / params.segment : 1;
    const AggregatePush agg{w,         h,     band.num_disparities, params.p1,
                            params.p2, words, params.segment,       params.segment_run_in};
    dispatch(cb, slot, aggregate, agg, static_cast<std::uint32_t>(h), 2, static_cast<std::uint32_t>(segments));
    if (params.paths > 2) {
      vkCmdDispatchBase(cb, 0, 2, 0, static_cast<std::uint32_t>(lines), static_cast<std::uint32_t>(params.paths - 2),
                        1);
    }
    barrier(cb, compute, compute);
    stamp(cb, slot, 4);
    dispatch(cb, slot, wta,
             WtaPush{w, h, band.min_disparity, band.num_disparities, params.uniqueness, params.paths, words},
             groups(w, kWtaSegment), static_cast<std::uint32_t>(h), 1);
    barrier(cb, compute, compute);
    stamp(cb, slot, 5);
    dispatch(cb, slot, lr_median, LrMedianPush{w, h, params.lr_max_diff, params.median ? 1 : 0, band.min_disparity},
             groups(w, 64), static_cast<std::uint32_t>(h), 1);
    barrier(cb, compute, compute | transfer);
    stamp(cb, slot, 6);
    if (dic_params) {
      // One subgroup per window (dic.comp), at most 64 / subgroup_size of them per workgroup; a subgroup
      // smaller than the reported size only means fewer workgroups would have done.
      const DicKernelConfig& d = *dic_params;
      const int per_group = std::max(1, 64 / static_cast<int>(subgroup_size));
      DicPush push{};
      push.width = width;
      push.height = height;
      push.words_per_row = words_per_row;
      push.h = d.half_window;
      push.hh = d.half_height;
      push.max_iterations = d.max_iterations;
      push.step = d.step;
      push.row_step = d.row_step;
      push.first_order = d.first_order ? 1 : 0;
      push.tolerance = d.tolerance_px;
      push.max_shift = d.max_shift_px;
      push.max_gradient = d.max_gradient;
      push.min_gradient = d.min_gradient;
      push.min_zncc = d.min_zncc;
      push.max_sigma = d.max_sigma_px;
      if (d.column_windows) {
        // Every column of every row block (workgroup y).
        const ColumnBlocks blocks(d, height);
        push.hh = blocks.half_height();
        push.first_row = blocks.row_begin;
        push.columns = width;
        push.rows = blocks.rows;
        push.blocks = blocks.count;
        if (blocks.count > 0)
          dispatch(cb, slot, dic_columns, push, groups(width, per_group), static_cast<std::uint32_t>(blocks.count), 1);
      } else {
        // The grid: columns x % step == 0, rows y % row_step == 0 in [row_begin, row_end).
        const int begin = std::max(d.row_begin, 0), end = std::min(d.row_end, height);
        push.first_row = (begin + d.row_step - 1) / d.row_step * d.row_step;
        const int rows = push.first_row < end ? (end - 1 - push.first_row) / d.row_step + 1 : 0;
        push.columns = (width + d.step - 1) / d.step;
        if (rows > 0)
          dispatch(cb, slot, dic, push, groups(push.columns, per_group), static_cast<std::uint32_t>(rows), 1);
      }
      barrier(cb, compute, transfer);
    }
    stamp(cb, slot, 7);
    copy = VkBufferCopy{0, 0, static_cast<VkDeviceSize>(w) * static_cast<VkDeviceSize>(h) * 4};
    vkCmdCopyBuffer(cb, (dic_params ? f.refined : f.disparity).buffer, down.buffer, 1, &copy);
    barrier(cb, transfer, VK_PIPELINE_STAGE_HOST_BIT);
    stamp(cb, slot, 8);
    return vkEndCommandBuffer(cb);
  }

  GpuStatus fail(VkResult r) {
    const GpuStatus s = status_of(r);
    if (s == GpuStatus::DeviceLost) lost = true;
    return s;
  }

  // One copy between buffers, waited for (start-up and test paths only).
  VkResult copy_now(const Buffer& src, const Buffer& dst, std::size_t bytes) {
    auto ai = info_struct<VkCommandBufferAllocateInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO);
    ai.commandPool = pool;
    ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    ai.commandBufferCount = 1;
    VkCommandBuffer cb = VK_NULL_HANDLE;
    VkResult r = vkAllocateCommandBuffers(device, &ai, &cb);
    if (r != VK_SUCCESS) return r;
    auto bi = info_struct<VkCommandBufferBeginInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO);
    r = vkBeginCommandBuffer(cb, &bi);
    if (r == VK_SUCCESS) {
      barrier(cb, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT | VK_PIPELINE_STAGE_HOST_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT);
      const VkBufferCopy copy{0, 0, bytes};
      vkCmdCopyBuffer(cb, src.buffer, dst.buffer, 1, &copy);
      barrier(cb, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT | VK_PIPELINE_STAGE_HOST_BIT);
      r = vkEndCommandBuffer(cb);
    }
    auto si = info_struct<VkSubmitInfo>(VK_STRUCTURE_TYPE_SUBMIT_INFO);
    si.commandBufferCount = 1;
    si.pCommandBuffers = &cb;
    if (r == VK_SUCCESS) r = vkQueueSubmit(queue, 1, &si, VK_NULL_HANDLE);
    if (r == VK_SUCCESS) r = vkQueueWaitIdle(queue);
    vkFreeCommandBuffers(device, pool, 1, &cb);
    return r;
  }

  // Test path: copies a device buffer back through a temporary host buffer.
  VkResult read_back(const Buffer& src, void* dst, std::size_t bytes) {
    Buffer tmp = make_buffer(bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT, true);
    const VkResult r = copy_now(src, tmp, bytes);
    if (r == VK_SUCCESS) std::memcpy(dst, tmp.mapped, bytes);
    destroy(tmp);
    return r;
  }

  // Start-up path: host data into a device buffer through a temporary host buffer.
  VkResult write_to(const Buffer& dst, const void* src, std::size_t bytes) {
    Buffer tmp = make_buffer(bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, true);
    std::memcpy(tmp.mapped, src, bytes);
    const VkResult r = copy_now(tmp, dst, bytes);
    destroy(tmp);
    return r;
  }

  // grid: RawCoarse only.
  GpuStatus submit(const ImageView& left, const ImageView& right, Input input, SgmBand band, const SgmConfig& params,
                   const DicKernelConfig* dic, int& ticket, const CoarseGrid& grid = {});
};

VulkanSgm::VulkanSgm(const std::string& device, int width, int height, int max_disparities, int timeout_ms,
                     int aggregate_threads)
    : impl_(std::make_unique<Impl>()) {
  if (width < 1 || height < 1 || max_disparities < 2 || max_disparities > kMaxDisparities)
    throw GpuError("VulkanSgm: bad size " + std::to_string(width) + "x" + std::to_string(height) + ", " +
                   std::to_string(max_disparities) + " disparities");
  Impl& m = *impl_;
  m.width = width;
  m.height = height;
  m.max_disparities = max_disparities;
  if (aggregate_threads < 0 || aggregate_threads > 128)
    throw GpuError("VulkanSgm: aggregate_threads " + std::to_string(aggregate_threads) + " is not 0..128");
  m.aggregate_threads = aggregate_threads;
  m.instance = make_instance();
  m.select(device);
  if (timeout_ms <= 0) timeout_ms = m.info.type == "cpu" ? 300000 : 2000;
  m.timeout_ns = static_cast<std::uint64_t>(timeout_ms) * 1000000u;
  try {
    m.make_device();
    m.setup();
  } catch (const GpuError& e) {
    throw GpuError(m.info.name + ": " + e.what());
  }
}

VulkanSgm::~VulkanSgm() = default;

const GpuDeviceInfo& VulkanSgm::device() const { return impl_->info; }
int VulkanSgm::width() const { return impl_->width; }
int VulkanSgm::height() const { return impl_->height; }

void VulkanSgm::set_rectification(const RectifyMaps& maps) {
  Impl& m = *impl_;
  const std::string error = check_rectify_maps(maps, m.width, m.height);
  if (!error.empty()) throw GpuError(m.info.name + ": " + error);
  if (m.lost) throw GpuError(m.info.name + ": device lost");
  const VkResult idle = vkDeviceWaitIdle(m.device);
  if (idle != VK_SUCCESS) throw GpuError(m.info.name + ": vkDeviceWaitIdle: " + result_name(idle));
  m.raw_width = maps.raw_width;
  m.raw_height = maps.raw_height;
  m.raw_words_per_row = (maps.raw_width + 3) / 4;
  // The rows the B-spline taps read (rectify.comp): a strip of a full image needs a band of rows only, and
  // only that band is packed and uploaded per frame.
  const std::array<int, 2> rows = rectify_rows(maps);
  m.raw_row0 = rows[0];
  m.raw_rows = rows[1] - rows[0];
  m.raw_bytes = static_cast<VkDeviceSize>(m.raw_words_per_row) * static_cast<VkDeviceSize>(m.raw_rows) * 4;
  const VkBufferUsageFlags storage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  const VkDeviceSize map_bytes = maps.left.size() * sizeof(float);
  try {
    for (Buffer* b : {&m.map_left, &m.map_right}) {
      m.destroy(*b);
      *b = m.make_buffer(map_bytes, storage, false);
    }
    m.upload_half = std::max(m.image_bytes, m.raw_bytes);
    for (Impl::Slot& s : m.slots) {
      for (Buffer* b : {&s.dev.raw_left, &s.dev.raw_right}) {
        m.destroy(*b);
        *b = m.make_buffer(m.raw_bytes, storage, false);
      }
      m.destroy(s.upload);
      s.upload = m.make_buffer(2 * m.upload_half, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, true);
      s.recorded = Impl::Recorded{};  // the upload layout changed
    }
    // The maps go up once.
    for (auto [map, dst] : {std::pair{&maps.left, &m.map_left}, std::pair{&maps.right, &m.map_right}}) {
      const VkResult r = m.write_to(*dst, map->data(), map_bytes);
      if (r != VK_SUCCESS) throw GpuError("uploading the rectification maps: " + result_name(r));
    }
    if (!m.downsample.pipeline) {
      m.downsample = m.make_kernel(kDownsampleSpv, sizeof kDownsampleSpv, sizeof(DownsamplePush),
                                   [](const FrameBuffers& f) -> Bindings {
                                     return {{&f.image_left}, {&f.image_right}, {&f.census_left}, {&f.census_right}};
                                   });
    }
    if (!m.rectify.pipeline) {
      m.rectify =
          m.make_kernel(kRectifySpv, sizeof kRectifySpv, sizeof(RectifyPush), [&m](const FrameBuffers& f) -> Bindings {
            return {{&f.raw_left}, {&f.raw_right}, {&m.map_left}, {&m.map_right}, {&f.image_left}, {&f.image_right}};
          });
    } else {
      for (int slot = 0; slot < kSlots; ++slot) {
        const FrameBuffers& f = m.slots[static_cast<std::size_t>(slot)].dev;
        m.write_set(m.rectify.sets[static_cast<std::size_t>(slot)],
                    {{&f.raw_left}, {&f.raw_right}, {&m.map_left}, {&m.map_right}, {&f.image_left}, {&f.image_right}});
      }
    }
  } catch (const GpuError& e) {
    throw GpuError(m.info.name + ": " + e.what());
  }
}

GpuStatus VulkanSgm::Impl::submit(const ImageView& left, const ImageView& right, Input input, SgmBand band,
                                  const SgmConfig& params, const DicKernelConfig* dic, int& ticket,
                                  const CoarseGrid& grid) {
  if (lost) return GpuStatus::DeviceLost;
  const bool raw = input != Input::Rectified;
  const int w = raw ? raw_width : width, h = raw ? raw_height : height;
  if ((raw && raw_bytes == 0) || left.width != w || left.height != h || right.width != w || right.height != h ||
      !left.data || !right.data)
    return GpuStatus::InvalidInput;
  const bool coarse = input == Input::RawCoarse;
  if (coarse && (grid.scale < 1 || grid.row_factor < 1 || grid.width < 1 || grid.height < 1 ||
                 grid.width * grid.scale > width || grid.height * grid.row_factor > height || dic))
    return GpuStatus::InvalidInput;
  if (input != Input::RawOnly &&
      (band.num_disparities > max_disparities ||
       !check_sgm_input(coarse ? grid.width : width, coarse ? grid.height : height, band, params).empty() ||
       (dic && !check_dic_kernel_config(*dic).empty())))
    return GpuStatus::InvalidInput;
  ticket = next_slot;
  Slot& slot = slots[static_cast<std::size_t>(ticket)];
  if (slot.busy) return GpuStatus::InvalidInput;  // two frames already in flight
  // Pack both images into the upload buffer: words of four pixels, rows padded to whole words.
  auto* words = static_cast<std::uint8_t*>(slot.upload.mapped);
  const std::size_t row_bytes = static_cast<std::size_t>(raw ? raw_words_per_row : words_per_row) * 4;
  const int row0 = raw ? raw_row0 : 0, rows = raw ? raw_rows : h;
  for (int i = 0; i < 2; ++i) {
    const ImageView& im = i == 0 ? left : right;
    for (int y = 0; y < rows; ++y) {
      std::uint8_t* row = words + static_cast<std::size_t>(i) * upload_half + static_cast<std::size_t>(y) * row_bytes;
      std::memcpy(row, im.data + static_cast<std::size_t>(row0 + y) * im.stride, static_cast<std::size_t>(w));
      std::memset(row + w, 0, row_bytes - static_cast<std::size_t>(w));
    }
  }
  Recorded wanted{true, dic != nullptr, input, coarse ? grid.scale : 0, band, params, dic ? *dic : DicKernelConfig{}};
  VkResult r = VK_SUCCESS;
  if (!(slot.recorded == wanted)) {
    slot.recorded = Recorded{};
    r = record(ticket, input, band, params, dic, grid);
    if (r == VK_SUCCESS) slot.recorded = wanted;
  }
  if (r == VK_SUCCESS) r = vkResetFences(device, 1, &slot.fence);
  if (r == VK_SUCCESS) {
    auto si = info_struct<VkSubmitInfo>(VK_STRUCTURE_TYPE_SUBMIT_INFO);
    si.commandBufferCount = 1;
    si.pCommandBuffers = &slot.commands;
    r = vkQueueSubmit(queue, 1, &si, slot.fence);
  }
  if (r != VK_SUCCESS) return fail(r);
  slot.busy = true;
  slot.input = input;
  slot.grid = grid;
  next_slot = (next_slot + 1) % kSlots;
  return GpuStatus::Ok;
}

GpuStatus VulkanSgm::submit(const ImageView& left, const ImageView& right, SgmBand band, const SgmConfig& params,
                            const DicKernelConfig* dic, int& ticket) {
  return impl_->submit(left, right, Input::Rectified, band, params, dic, ticket);
}

GpuStatus VulkanSgm::submit_raw(const ImageView& left_raw, const ImageView& right_raw, const SgmBand* band,
                                const SgmConfig& params, const DicKernelConfig* dic, int& ticket) {
  return impl_->submit(left_raw, right_raw, band ? Input::Raw : Input::RawOnly, band ? *band : SgmBand{}, params,
                       band ? dic : nullptr, ticket);
}

GpuStatus VulkanSgm::submit_coarse(const ImageView& left_raw, const ImageView& right_raw, int scale, SgmBand band,
                                   const SgmConfig& params, int& ticket) {
  Impl& m = *impl_;
  return m.submit(left_raw, right_raw, Input::RawCoarse, band, params, nullptr, ticket,
                  coarse_grid(m.width, m.height, scale));
}

GpuStatus VulkanSgm::collect(int ticket, float* disparity, std::size_t stride, GpuStageTimes* times,
                             const StripsOut* strips) {
  Impl& m = *impl_;
  if (ticket < 0 || ticket >= kSlots || !m.slots[static_cast<std::size_t>(ticket)].busy) return GpuStatus::InvalidInput;
  Impl::Slot& slot = m.slots[static_cast<std::size_t>(ticket)];
  // Poll for up to a millisecond before sleeping in the driver: a frame takes about that long on a GPU,
  // and a sleeping wait adds its wake-up to every frame's latency.
  VkResult r = VK_NOT_READY;
  const auto spin_until = std::chrono::steady_clock::now() + std::chrono::milliseconds(1);
  while (r == VK_NOT_READY && std::chrono::steady_clock::now() < spin_until) r = vkGetFenceStatus(m.device, slot.fence);
  if (r == VK_NOT_READY) r = vkWaitForFences(m.device, 1, &slot.fence, VK_TRUE, m.timeout_ns);
  if (r != VK_SUCCESS) {
    // On a timeout the slot stays busy: its buffers may still be written.
    if (r != VK_TIMEOUT) slot.busy = false;
    return m.fail(r);
  }
  slot.busy = false;
  // A request the frame cannot answer: checked after the wait, so the slot is free again either way.
  if ((strips && slot.input == Input::Rectified) || (!disparity && slot.input != Input::RawOnly))
    return GpuStatus::InvalidInput;
  // The download buffer: the disparity (floats, unpadded rows), then both packed strips, then the packed
  // coarse left image (record()).
  const auto* down = static_cast<const std::uint8_t*>(slot.download.mapped);
  const std::size_t strips_at = static_cast<std::size_t>(m.width) * static_cast<std::size_t>(m.height) * 4;
  const bool coarse = slot.input == Input::RawCoarse;
  if (disparity && slot.input != Input::RawOnly) {
    const int w = coarse ? slot.grid.width : m.width, h = coarse ? slot.grid.height : m.height;
    const std::size_t row_bytes = static_cast<std::size_t>(w) * sizeof(float);
    copy_rows(disparity, stride * sizeof(float), down, row_bytes, row_bytes, h);
  }
  if (coarse && strips && strips->coarse_left)
    copy_rows(strips->coarse_left, strips->coarse_stride, down + strips_at + 2 * m.image_bytes,
              static_cast<std::size_t>((slot.grid.width + 3) / 4) * 4, static_cast<std::size_t>(slot.grid.width),
              slot.grid.height);
  if (strips) {
    const std::size_t packed_row = static_cast<std::size_t>(m.words_per_row) * 4;
    for (int i = 0; i < 2; ++i) {
      std::uint8_t* dst = i == 0 ? strips->left : strips->right;
      if (dst)
        copy_rows(dst, strips->stride, down + strips_at + static_cast<std::size_t>(i) * m.image_bytes, packed_row,
                  static_cast<std::size_t>(m.width), m.height);
    }
  }
  if (times) {
    *times = GpuStageTimes{};
    std::array<std::uint64_t, kTimestamps> t{};
    if (m.queries &&
        vkGetQueryPoolResults(m.device, m.queries, static_cast<std::uint32_t>(ticket) * kTimestamps, kTimestamps,
                              sizeof t, t.data(), sizeof(std::uint64_t), VK_QUERY_RESULT_64_BIT) == VK_SUCCESS) {
      const auto ms = [&](int a, int b) {
        return static_cast<double>(t[static_cast<std::size_t>(b)] - t[static_cast<std::size_t>(a)]) * m.timestamp_ns *
               1e-6;
      };
      *times = GpuStageTimes{ms(0, 1), ms(1, 2), ms(2, 3), ms(3, 4), ms(4, 5), ms(5, 6), ms(6, 7), ms(7, 8)};
    }
  }
  return GpuStatus::Ok;
}

GpuStatus VulkanSgm::compute(const ImageView& left, const ImageView& right, SgmBand band, const SgmConfig& params,
                             const DicKernelConfig* dic, float* disparity, std::size_t stride, GpuStageTimes* times) {
  int ticket = 0;
  const GpuStatus s = submit(left, right, band, params, dic, ticket);
  if (s != GpuStatus::Ok) return s;
  return collect(ticket, disparity, stride, times);
}

GpuStatus VulkanSgm::compute_stages(const ImageView& left, const ImageView& right, SgmBand band,
                                    const SgmConfig& params, const DicKernelConfig* dic, SgmStages& st, bool raw) {
  Impl& m = *impl_;
  const auto pixels = static_cast<std::size_t>(m.width) * static_cast<std::size_t>(m.height);
  st.width = m.width;
  st.height = m.height;
  st.band = band;
  st.disparity.resize(pixels);
  st.refined.clear();
  st.spline_left.clear();
  st.spline_right.clear();
  st.rectified_left.clear();
  st.rectified_right.clear();
  std::vector<float> out(pixels);
  int ticket = 0;
  GpuStatus s =
      raw ? submit_raw(left, right, &band, params, dic, ticket) : submit(left, right, band, params, dic, ticket);
  StripsOut strips;
  if (raw) {
    st.rectified_left.resize(pixels);
    st.rectified_right.resize(pixels);
    strips = StripsOut{st.rectified_left.data(), st.rectified_right.data(), static_cast<std::size_t>(m.width)};
  }
  if (s == GpuStatus::Ok)
    s = collect(ticket, out.data(), static_cast<std::size_t>(m.width), nullptr, raw ? &strips : nullptr);
  if (s != GpuStatus::Ok) return s;
  const FrameBuffers& f = m.slots[static_cast<std::size_t>(ticket)].dev;
  if (dic) {
    st.refined = out;
    st.spline_left.resize(pixels);
    st.spline_right.resize(pixels);
    for (auto [buffer, dst] :
         {std::pair{&f.spline_left, st.spline_left.data()}, std::pair{&f.spline_right, st.spline_right.data()},
          std::pair{&f.disparity, st.disparity.data()}}) {
      const VkResult r = m.read_back(*buffer, dst, pixels * 4);
      if (r != VK_SUCCESS) return m.fail(r);
    }
  } else {
    st.disparity = out;
  }
  st.census_left.resize(pixels * 2);
  st.census_right.resize(pixels * 2);
  st.disparity_left.resize(pixels);
  const auto nd = static_cast<std::size_t>(band.num_disparities);
  const auto words = static_cast<std::size_t>(cost_words(band.num_disparities));
  std::vector<std::uint8_t> costs(pixels * words * 4 * static_cast<std::size_t>(params.paths));
  std::vector<std::uint32_t> keys(pixels);
  for (std::size_t dir = 0; dir < static_cast<std::size_t>(params.paths); ++dir) {
    const VkResult r = m.read_back(f.costs[dir], costs.data() + dir * pixels * words * 4, pixels * words * 4);
    if (r != VK_SUCCESS) return m.fail(r);
  }
  for (auto [buffer, dst, bytes] : {std::tuple{&f.census_left, static_cast<void*>(st.census_left.data()), pixels * 8},
                                    std::tuple{&f.census_right, static_cast<void*>(st.census_right.data()), pixels * 8},
                                    std::tuple{&f.disp_left, static_cast<void*>(st.disparity_left.data()), pixels * 4},
                                    std::tuple{&f.right_key, static_cast<void*>(keys.data()), pixels * 4}}) {
    const VkResult r = m.read_back(*buffer, dst, bytes);
    if (r != VK_SUCCESS) return m.fail(r);
  }
  // The sums the reference keeps: every direction's byte costs added (as wta.comp does in shared memory).
  st.sums.assign(pixels * nd, 0);
  for (std::size_t dir = 0; dir < static_cast<std::size_t>(params.paths); ++dir)
    for (std::size_t p = 0; p < pixels; ++p)
      for (std::size_t d = 0; d < nd; ++d) st.sums[p * nd + d] += costs[(dir * pixels + p) * words * 4 + d];
  st.disparity_right.resize(pixels);
  for (std::size_t p = 0; p < pixels; ++p)
    st.disparity_right[p] = keys[p] == kNoMatch ? -1 : band.min_disparity + static_cast<int>(keys[p] & 511u);
  return GpuStatus::Ok;
}

}  // namespace rutd::gpu
