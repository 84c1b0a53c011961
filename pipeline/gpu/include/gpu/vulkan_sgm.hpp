#pragma once
// The semi-global matcher of sgm.hpp on a Vulkan compute device: census, path aggregation, winner-takes-all
// with uniqueness and sub-pixel, left-right check and median, every stage a compute shader whose integer
// arithmetic equals the reference's (so results are bit for bit those of sgm_reference). Optionally it
// starts from raw images, rectified on the device (rectify.hpp, byte for byte rectify_reference), and runs
// the band estimate's coarse pass there too. Needs Vulkan 1.1 with subgroup arithmetic in compute shaders
// (any subgroup size); runs on lavapipe as on GPUs.
//
// Errors: the constructor and set_rectification throw GpuError (no loader, no usable device, allocation
// failure); the per-frame calls return a GpuStatus and never throw. DeviceLost is sticky: the object is
// then unusable.
// Not thread-safe: one thread uses one VulkanSgm.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "gpu/dic.hpp"
#include "gpu/rectify.hpp"
#include "gpu/sgm.hpp"
#include "gpu/vulkan_faults.hpp"

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
  // The driver's name and version (VkPhysicalDeviceDriverProperties: "NVIDIA 580.159.04", "llvmpipe Mesa
  // 22.3.6 (LLVM 15.0.6)"), or its raw driverVersion where the device predates Vulkan 1.2.
  std::string driver;
  std::uint32_t subgroup_size = 0;
  bool usable = false;  // Vulkan 1.1, subgroup arithmetic and shuffles in compute, 16-bit storage buffers
  bool half = false;    // shaderFloat16: VulkanSgmOptions::aggregate_half can run
  // A host-visible memory type is cached: the download buffer is read at memory speed (without it, at the
  // speed of uncached reads, far slower; the matcher takes a cached type where there is one).
  bool host_cached = false;
};

// Every physical device the loader reports. Throws GpuError when there is no Vulkan loader or instance.
std::vector<GpuDeviceInfo> list_gpu_devices();

// Logical devices this process has opened so far (one per VulkanSgm: resize() keeps its device).
std::uint64_t gpu_devices_opened();

// Device time of each stage of one frame, ms (GPU timestamps; all 0 when the queue has none). rectify_ms
// is 0 for rectified input; census_ms includes the DIC's B-spline prefilter.
struct GpuStageTimes {
  double upload_ms = 0, rectify_ms = 0, census_ms = 0, aggregate_ms = 0, wta_ms = 0, lr_median_ms = 0, dic_ms = 0,
         download_ms = 0;
};

// A frame's disparity as the device downloads it, 16-bit fixed point: px = offset_px + value * step_px,
// kInvalid where invalid. offset_px is an integer, the band's min_disparity less a margin that holds every
// disparity the DIC may give (DicKernelConfig::max_shift_px, plus max_gradient times the half height of a
// column window's block); step_px the finest power of two whose 65,535 steps span the band and both
// margins, never coarser than 1/64 px (the matcher's own resolution, which it therefore keeps exactly). On
// the daemon's 48-row strip with the default DIC (margins of 15 px): 1/1024 px for bands up to 32 px,
// 1/512 px up to 96, 1/256 px up to 224 and 1/128 px up to 512, the most the matcher takes.
struct DisparityView {
  static constexpr std::uint16_t kInvalid = 0xFFFF;
  const std::uint16_t* data = nullptr;  // in the slot's download buffer (collect())
  int width = 0, height = 0;
  std::size_t stride = 0;  // elements between rows
  float offset_px = 0, step_px = 0;
  float at(int x, int y) const;  // px, NaN invalid
  // Row y as px (NaN invalid) into `out` (width floats).
  void decode_row(int y, float* out) const;
};

// What collect() hands back: views into the slot's mapped download buffer, valid until that slot is
// submitted again (two submits later), read in place with no copy.
struct FrameOutput {
  DisparityView disparity;  // empty (data nullptr) for a rectification-only frame
  // Raw input: the rectified strips, width() x height() bytes, rows strip_stride bytes apart.
  const std::uint8_t* strip_left = nullptr;
  const std::uint8_t* strip_right = nullptr;
  std::size_t strip_stride = 0;
  // submit_coarse(): the coarse left image (the disparity's size), rows coarse_stride bytes apart.
  const std::uint8_t* coarse_left = nullptr;
  std::size_t coarse_stride = 0;
};

// Where collect() copies the rectified strips of a frame submitted raw: width() x height() bytes each,
// rows `stride` bytes apart. The caller owns the memory.
struct StripsOut {
  std::uint8_t* left = nullptr;
  std::uint8_t* right = nullptr;
  std::size_t stride = 0;
  // submit_coarse(): the coarse left image (CoarseGrid size), rows coarse_stride bytes apart; nullptr: not
  // copied.
  std::uint8_t* coarse_left = nullptr;
  std::size_t coarse_stride = 0;
};

// One line naming the device, its type, driver and subgroup size, for logs and reports.
std::string describe(const GpuDeviceInfo& info);

struct VulkanSgmOptions {
  // Bounds the wait for one frame; <= 0: 2 s on a GPU, 300 s on a CPU device (lavapipe takes seconds per
  // full frame).
  int timeout_ms = 0;
  // The aggregation's workgroup size, 0..128; 0 is the device's subgroup size (its fast path). Tests give
  // several subgroups' worth to run its shared-memory path, which devices that choose a smaller subgroup
  // than they report take.
  int aggregate_threads = 0;
  // The invocations that walk one line of the aggregation (aggregate.comp): 0 (the default) picks
  // kAggregateLanesGpu on a GPU and the whole workgroup on a CPU device; else a power of two no larger
  // than the workgroup (larger: the workgroup) and dividing the device's subgroup size (else the
  // constructor throws). Fewer lanes: more disparities each and several lines a workgroup. The path
  // costs are the same either way. On an H100 (README, "The GPU engine") 16 lanes of a 32-wide subgroup
  // took 0.414 ms for a 640x480 frame's 8 paths and 128 disparities, whole subgroups 0.436, 8 lanes 0.54.
  static constexpr int kAggregateLanesGpu = 16;
  int aggregate_lanes = 0;
  // The winner-takes-all's workgroup size, 0..128, as aggregate_threads; and the px of a row one of its
  // workgroups walks (0: whole rows; else >= 16), so that a device walks a row's segments in parallel: the
  // segments share no work, and gather the right view by atomicMin into a buffer filled before
  // (wta.comp). The output is the same either way. kWtaSegmentAuto (the default): kWtaSegmentGpu px on a
  // GPU, whole rows on a CPU device (lavapipe), which has cores enough for the rows. On an H100 16-px
  // segments took 0.146 ms for a 640x480 frame (whole rows 0.407) and 0.025 ms for the 48-row strip.
  // A wta_threads larger than the device's subgroup walks whole rows whatever wta_segment says
  // (vulkan_sgm.cpp: segments in a workgroup of several subgroups failed a check on an H100).
  static constexpr int kWtaSegmentAuto = -1;
  static constexpr int kWtaSegmentGpu = 16;
  int wta_threads = 0;
  int wta_segment = kWtaSegmentAuto;
  // The subgroups that share one column window of the DIC (dic.comp): 0 (the default) on a GPU 128
  // invocations' worth where a row block has 32 rows or more (the strip's whole-height windows, few and
  // tall), else one subgroup a window, and one on a CPU device; 1..16 that many wherever column windows
  // run (the per-pixel mode keeps one). The refinement is the same to float rounding (the sums' order).
  int dic_window_subgroups = 0;
  // The aggregation's step in packed half floats, two disparities an operation (GpuDeviceInfo::half; else
  // the constructor throws); the same path costs exactly. Off: 32-bit integers.
  bool aggregate_half = false;
  // Tests only: faults injected at the lowest Vulkan calls (vulkan_faults.hpp); nullptr: none. The
  // caller keeps it alive while the matcher exists.
  VulkanFaults* faults = nullptr;
};

class VulkanSgm {
 public:
  // device: "" picks the first usable device preferring discrete, then integrated, virtual, CPU; a decimal
  // number picks that index; anything else the first usable device whose name contains it (case-
  // insensitive). Every buffer is allocated here for width x height pairs and up to max_disparities.
  // Throws GpuError naming the device and the failing call.
  VulkanSgm(const std::string& device, int width, int height, int max_disparities,
            const VulkanSgmOptions& options = {});
  ~VulkanSgm();
  VulkanSgm(const VulkanSgm&) = delete;
  VulkanSgm& operator=(const VulkanSgm&) = delete;

  const GpuDeviceInfo& device() const;
  int width() const;
  int height() const;
  int max_disparities() const;
  // The winner-takes-all's segment in use (VulkanSgmOptions::wta_segment, kWtaSegmentAuto resolved).
  int wta_segment() const;
  int aggregate_lanes() const;  // VulkanSgmOptions::aggregate_lanes as resolved for the device
  // The subgroups that share one DIC window of `d` on this matcher's images (dic_window_subgroups resolved).
  int dic_subgroups_per_window(const DicKernelConfig& d) const;

  // Buffers for a new size and disparity count, on the same device with the same kernels (a device is
  // opened once per matcher): waits for the frames in flight, which are then lost, and forgets the
  // rectification (set_rectification() again). Throws GpuError (the matcher is then unusable).
  void resize(int width, int height, int max_disparities);

  // Rectification on the device: from now on submit_raw() takes raw images of maps.raw_width x
  // maps.raw_height and resamples them into width() x height() strips through `maps` (rectify.hpp) before
  // matching. The maps are uploaded once, here. Throws GpuError for maps that do not fit the matcher or
  // a failed allocation or upload.
  void set_rectification(const RectifyMaps& maps);

  // Two frames can be in flight: submit() packs the pair straight into the mapped upload buffer of slot
  // `ticket` (alternating 0, 1) and queues its work; collect() waits for that slot and reads its mapped
  // download buffer. Submitting the next pair before collecting the current one overlaps its packing with
  // this frame's device work. Images must be width() x height(). dic: refine on the device (dic.hpp;
  // census also runs the B-spline prefilter) and return the refined disparity; nullptr: return the
  // matcher's.
  GpuStatus submit(const ImageView& left, const ImageView& right, SgmBand band, const SgmConfig& params,
                   const DicKernelConfig* dic, int& ticket);
  // As submit(), from raw images (set_rectification() first, else InvalidInput): rectified on the device,
  // then matched. band == nullptr: rectification only; collect() then copies out the strips alone.
  GpuStatus submit_raw(const ImageView& left_raw, const ImageView& right_raw, const SgmBand* band,
                       const SgmConfig& params, const DicKernelConfig* dic, int& ticket);
  // The band estimate's coarse pass on the device (set_rectification() first): rectifies the raw pair,
  // averages the strips to coarse_grid(width(), height(), scale) (rectify.hpp) and matches the coarse
  // images in `band` (coarse px) with `params`, without DIC. collect() then returns the coarse disparity
  // (rows of grid.width floats at `stride`), the strips and the coarse left image.
  GpuStatus submit_coarse(const ImageView& left_raw, const ImageView& right_raw, int scale, SgmBand band,
                          const SgmConfig& params, int& ticket);
  // Waits for frame `ticket` and points `out` at its results in the slot's download buffer (FrameOutput:
  // no copy); times: the stages' device times, where the queue has timestamps.
  GpuStatus collect(int ticket, FrameOutput& out, GpuStageTimes* times = nullptr);
  // As above, then the disparity decoded into `disparity` (px, NaN invalid; rows of `stride` floats) and
  // the strips copied to `strips`: for a frame submitted raw, where its rectified strips go (nullptr: not
  // copied); must be nullptr for a frame submitted rectified. disparity may be nullptr for a
  // rectification-only frame.
  GpuStatus collect(int ticket, float* disparity, std::size_t stride, GpuStageTimes* times = nullptr,
                    const StripsOut* strips = nullptr);
  // submit() then collect().
  GpuStatus compute(const ImageView& left, const ImageView& right, SgmBand band, const SgmConfig& params,
                    const DicKernelConfig* dic, float* disparity, std::size_t stride, GpuStageTimes* times = nullptr);

  // For tests: one frame, then every stage's buffer copied back into `st` (allocates; may throw GpuError).
  // raw: left/right are raw images, rectified on the device (st.rectified_left/right filled).
  GpuStatus compute_stages(const ImageView& left, const ImageView& right, SgmBand band, const SgmConfig& params,
                           const DicKernelConfig* dic, SgmStages& st, bool raw = false);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rutd::gpu
