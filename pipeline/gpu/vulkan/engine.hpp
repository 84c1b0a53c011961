#pragma once
// VulkanSgm's state (its pImpl): the device, each frame slot's buffers and command buffer, and the
// stages. vulkan_sgm.cpp makes it (buffers, kernels, rectification maps); frame.cpp records, submits
// and collects frames. Private to rutd_gpu.
#include <vulkan/vulkan.h>

#include <array>
#include <memory>
#include <tuple>

#include "device.hpp"
#include "gpu/vulkan_sgm.hpp"
#include "kernel.hpp"
#include "memory.hpp"
#include "stages.hpp"

namespace rutd::gpu {
namespace vk {

// What a frame's command buffer starts from: packed rectified strips, or raw images rectified on the
// device and then matched, or only rectified, or rectified and matched coarse (the band estimate).
enum class Input { Rectified, Raw, RawOnly, RawCoarse };

// start, after upload, rectify, census, aggregate, wta, lr/median, dic, download
constexpr std::uint32_t kTimestamps = 9;

// What a slot's command buffer was recorded for: the same frame parameters submit it again unrecorded.
struct Recorded {
  bool valid = false, dic = false;
  Input input = Input::Rectified;
  int coarse_scale = 0;  // RawCoarse
  SgmBand band;
  SgmConfig params;
  DicKernelConfig dic_params;
  bool operator==(const Recorded& o) const;
};

}  // namespace vk

struct VulkanSgm::Impl {
  int width = 0, height = 0, max_disparities = 0, words_per_row = 0;
  VkDeviceSize image_bytes = 0;  // one packed strip
  // set_rectification: the raw size; the raw rows the maps reach, the only ones uploaded; one packed
  // image's bytes of them; and the maps (shared by both slots).
  vk::RawRows raw;
  VkDeviceSize raw_bytes = 0;
  vk::Buffer map_left, map_right;
  VkDeviceSize upload_half = 0;  // offset of the right image in a slot's upload buffer
  std::uint64_t timeout_ns = 0;
  std::unique_ptr<vk::Device> device;  // destroyed last (declared first)
  VkCommandPool pool = VK_NULL_HANDLE;
  VkDescriptorPool descriptors = VK_NULL_HANDLE;
  VkQueryPool queries = VK_NULL_HANDLE;
  VulkanSgmOptions options;
  struct Slot {
    vk::FrameBuffers dev;
    vk::Recorded recorded;
    vk::Buffer upload;    // host-visible: left image at 0, right at upload_half, packed words
    vk::Buffer download;  // host-visible: the disparity (floats), then both packed strips (raw input)
    vk::Input input = vk::Input::Rectified;  // of the frame in flight
    CoarseGrid grid;                         // RawCoarse: of the frame in flight
    vk::FixedPoint fixed;                    // of the frame in flight's disparity
    VkCommandBuffer commands = VK_NULL_HANDLE;
    VkFence fence = VK_NULL_HANDLE;
    bool busy = false;
  };
  std::array<Slot, vk::kSlots> slots;
  int next_slot = 0;
  vk::CensusStage census;
  vk::CostStage cost;
  vk::AggregateStage aggregate;
  vk::WtaStage wta;
  vk::LrMedianStage lr_median;
  vk::DicStage dic;
  vk::RectifyStage rectify;  // set_rectification
  vk::BandStage band;        // set_rectification
  bool lost = false;

  ~Impl();
  // Command buffers, queries and kernels, and the buffers of allocate(). Throws GpuError.
  void setup();
  // The buffers for width x height and max_disparities: each slot's FrameBuffers, upload and download.
  void allocate();
  // Frees what allocate() and set_rectification() allocated.
  void free_buffers();
  vk::KernelFactory kernels() const;
  vk::ImageSize strip_size() const { return {width, height, words_per_row}; }
  // Bytes of the 16-bit disparity of a strip, whole words: where the strips start in the download buffer.
  VkDeviceSize fixed_bytes() const {
    return (static_cast<VkDeviceSize>(width) * static_cast<VkDeviceSize>(height) * 2 + 3) / 4 * 4;
  }

  // frame.cpp
  VkResult record(int slot, vk::Input input, SgmBand band, const SgmConfig& params, const DicKernelConfig* dic_params,
                  const CoarseGrid& grid, vk::FixedPoint fixed);
  GpuStatus fail(VkResult r);
  // grid: RawCoarse only.
  GpuStatus submit(const ImageView& left, const ImageView& right, vk::Input input, SgmBand band,
                   const SgmConfig& params, const DicKernelConfig* dic, int& ticket, const CoarseGrid& grid = {});
  GpuStatus collect(int ticket, FrameOutput& out, GpuStageTimes* times);
  GpuStatus read_stages(int ticket, SgmBand band, const SgmConfig& params, bool dic, SgmStages& st);
};

}  // namespace rutd::gpu
