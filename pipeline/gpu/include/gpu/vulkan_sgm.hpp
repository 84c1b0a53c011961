#pragma once
// The semi-global matcher of sgm.hpp on a Vulkan compute device: census, path aggregation, winner-takes-all
// with uniqueness and sub-pixel, left-right check and median, every stage a compute shader whose integer
// arithmetic equals the reference's (so results are bit for bit those of sgm_reference). Needs Vulkan 1.1
// with subgroup arithmetic in compute shaders (any subgroup size); runs on lavapipe as on GPUs.
//
// Errors: the constructor throws GpuError (no loader, no usable device, allocation failure); the per-frame
// calls return a GpuStatus and never throw. DeviceLost is sticky: the object is then unusable.
// Not thread-safe: one thread uses one VulkanSgm.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "gpu/dic.hpp"
#include "gpu/sgm.hpp"

namespace rutd::gpu {

enum class GpuStatus { Ok, InvalidInput, Timeout, OutOfMemory, DeviceLost, Failed };
std::string_view to_string(GpuStatus status);

class GpuError : public std::runtime_error {
 public:
  explicit GpuError(const std::string& what) : std::runtime_error(what) {}
};

struct GpuDeviceInfo {
  int index = -1;    // in the loader's enumeration order
  std::string name;  // VkPhysicalDeviceProperties::deviceName
  std::string type;  // "discrete", "integrated", "virtual", "cpu", "other"
  std::uint32_t subgroup_size = 0;
  bool usable = false;  // Vulkan 1.1, subgroup arithmetic in compute shaders
};

// Every physical device the loader reports. Throws GpuError when there is no Vulkan loader or instance.
std::vector<GpuDeviceInfo> list_gpu_devices();

// Device time of each stage of one frame, ms (GPU timestamps; all 0 when the queue has none).
struct GpuStageTimes {
  double upload_ms = 0, census_ms = 0, aggregate_ms = 0, wta_ms = 0, lr_median_ms = 0, dic_ms = 0, download_ms = 0;
};

class VulkanSgm {
 public:
  // device: "" picks the first usable device preferring discrete, then integrated, virtual, CPU; a decimal
  // number picks that index; anything else the first usable device whose name contains it (case-
  // insensitive). Every buffer is allocated here for width x height pairs and up to max_disparities.
  // timeout_ms bounds the wait for one frame; <= 0: 2 s on a GPU, 300 s on a CPU device (lavapipe takes
  // seconds per full frame). Throws GpuError naming the device and the failing call.
  // aggregate_threads: the aggregation's workgroup size; 0 is the device's subgroup size (its fast path).
  // Tests give several subgroups' worth to run its shared-memory path, which devices that choose a
  // smaller subgroup than they report take.
  VulkanSgm(const std::string& device, int width, int height, int max_disparities, int timeout_ms = 0,
            int aggregate_threads = 0);
  ~VulkanSgm();
  VulkanSgm(const VulkanSgm&) = delete;
  VulkanSgm& operator=(const VulkanSgm&) = delete;

  const GpuDeviceInfo& device() const;
  int width() const;
  int height() const;

  // Two frames can be in flight: submit() copies the pair into the staging memory of slot `ticket`
  // (alternating 0, 1) and queues its work; collect() waits for that slot and copies the disparity (px,
  // NaN invalid; rows of `stride` floats) out. Submitting the next pair before collecting the current one
  // overlaps its host copy with this frame's device work. Images must be width() x height(). dic: refine
  // on the device (dic.hpp; census also runs the B-spline prefilter) and return the refined disparity;
  // nullptr: return the matcher's.
  GpuStatus submit(const ImageView& left, const ImageView& right, SgmBand band, const SgmParams& params,
                   const DicParams* dic, int& ticket);
  GpuStatus collect(int ticket, float* disparity, std::size_t stride, GpuStageTimes* times = nullptr);
  // submit() then collect().
  GpuStatus compute(const ImageView& left, const ImageView& right, SgmBand band, const SgmParams& params,
                    const DicParams* dic, float* disparity, std::size_t stride, GpuStageTimes* times = nullptr);

  // For tests: one frame, then every stage's buffer copied back into `st` (allocates; may throw GpuError).
  GpuStatus compute_stages(const ImageView& left, const ImageView& right, SgmBand band, const SgmParams& params,
                           const DicParams* dic, SgmStages& st);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rutd::gpu
