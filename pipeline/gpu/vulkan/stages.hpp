#pragma once
// The host side of each stage of the matcher: its kernel(s) and how a frame's command buffer dispatches
// them. One class per stage, each in its own file beside its shader (shaders/<stage>.comp):
//   rectify_stage.cpp    raw images to the matcher's packed strips (rectify.comp)
//   band_stage.cpp       the band estimate's coarse images (downsample.comp)
//   census_stage.cpp     9x7 census of both images (census.comp)
//   cost_stage.cpp       matching costs, four disparities a word (cost.comp)
//   aggregate_stage.cpp  path aggregation, every direction (aggregate.comp)
//   wta_stage.cpp        winner-takes-all, uniqueness, sub-pixel, right view: a row walker (wta.comp)
//   lr_median_stage.cpp  left-right check, 3x3 median (lr_median.comp)
//   dic_stage.cpp        B-spline prefilter and DIC (bspline.comp, dic.comp)
// A stage records dispatches only; frame.cpp orders them, with barriers and timestamps. Private to rutd_gpu.
#include <vulkan/vulkan.h>

#include "gpu/dic.hpp"
#include "gpu/rectify.hpp"
#include "gpu/sgm.hpp"
#include "kernel.hpp"

namespace rutd::gpu::vk {

// The size of what a stage works on: width x height px, rows of words_per_row words of four pixels.
struct ImageSize {
  int width = 0, height = 0, words_per_row = 0;
};

// The fixed point of a frame's downloaded disparity (DisparityView): px = base + value / scale.
struct FixedPoint {
  int base = 0;    // px
  int scale = 64;  // values per px: a power of two, at least 64
};

// The fixed point of a frame's disparity for its band and DIC (vulkan_sgm.hpp, DisparityView): the finest
// step, a power of two of at most 1/64 px, whose range holds every disparity the matcher or the DIC can give
// (frame.cpp).
FixedPoint fixed_point(SgmBand band, const DicKernelConfig* dic, int height);

// The raw rows uploaded for rectification: raw_width x raw_height images of which rows [row0, row0 +
// rows) are uploaded, packed in rows of words_per_row words.
struct RawRows {
  int width = 0, height = 0, words_per_row = 0, row0 = 0, rows = 0;
};

class RectifyStage {
 public:
  // maps: both cameras' maps (rectify.hpp), shared by the slots, which the stage keeps binding wherever
  // they are reallocated; the raw images are FrameBuffers::raw_*.
  void create(const KernelFactory& f, const Buffer& map_left, const Buffer& map_right);
  void rebind(const KernelFactory& f) const { f.rebind(kernel_); }
  bool created() const { return kernel_.pipeline != VK_NULL_HANDLE; }
  void record(VkCommandBuffer cb, int slot, ImageSize strip, const RawRows& raw) const;
  void destroy(const Device& device) { vk::destroy(device, kernel_); }

 private:
  Kernel kernel_;
};

// The band estimate's coarse pass: the strips averaged to `grid` into the census buffers (scratch).
class BandStage {
 public:
  void create(const KernelFactory& f);
  void rebind(const KernelFactory& f) const { f.rebind(kernel_); }
  bool created() const { return kernel_.pipeline != VK_NULL_HANDLE; }
  void record(VkCommandBuffer cb, int slot, ImageSize strip, const CoarseGrid& grid) const;
  void destroy(const Device& device) { vk::destroy(device, kernel_); }

 private:
  Kernel kernel_;
};

class CensusStage {
 public:
  void create(const KernelFactory& f);
  void rebind(const KernelFactory& f) const { f.rebind(kernel_); }
  void record(VkCommandBuffer cb, int slot, ImageSize image) const;
  void destroy(const Device& device) { vk::destroy(device, kernel_); }

 private:
  Kernel kernel_;
};

class CostStage {
 public:
  void create(const KernelFactory& f);
  void rebind(const KernelFactory& f) const { f.rebind(kernel_); }
  void record(VkCommandBuffer cb, int slot, ImageSize image, SgmBand band) const;
  void destroy(const Device& device) { vk::destroy(device, kernel_); }

 private:
  Kernel kernel_;
};

class AggregateStage {
 public:
  // threads: the workgroup size (the device's subgroup size for the fast path); lanes: the invocations of
  // one line (threads, or a power of two dividing it and the device's subgroup size); half: the step in
  // packed half floats (the device's shaderFloat16), else in 32-bit integers.
  void create(const KernelFactory& f, int threads, int lanes, bool half);
  void rebind(const KernelFactory& f) const { f.rebind(kernel_); }
  // Builds the pipeline of a new disparity count on its first use: VK_SUCCESS or that build's error.
  VkResult record(VkCommandBuffer cb, int slot, ImageSize image, SgmBand band, const SgmConfig& params);
  void destroy(const Device& device) { vk::destroy(device, kernel_); }

 private:
  Kernel kernel_;
  int threads_ = 0, lanes_ = 0;
};

class WtaStage {
 public:
  // threads: the workgroup size (the device's subgroup size for the fast path); segment: px of a row per
  // workgroup, 0 whole rows.
  void create(const KernelFactory& f, int threads, int segment);
  void rebind(const KernelFactory& f) const { f.rebind(kernel_); }
  // Builds the pipeline of a new disparity count or number of directions on its first use: VK_SUCCESS or
  // that build's error.
  VkResult record(VkCommandBuffer cb, int slot, ImageSize image, SgmBand band, const SgmConfig& params);
  // Rows in segments: FrameBuffers::right_key must hold 0xFFFFFFFF in every word before record()'s dispatch.
  bool segmented() const { return segment_ > 0; }
  void destroy(const Device& device) { vk::destroy(device, kernel_); }

 private:
  Kernel kernel_;
  int threads_ = 0, segment_ = 0;
};

class LrMedianStage {
 public:
  void create(const KernelFactory& f);
  void rebind(const KernelFactory& f) const { f.rebind(kernel_); }
  // float_out: FrameBuffers::disparity in px (the DIC's start); fixed_out: FrameBuffers::fixed in `fixed`.
  void record(VkCommandBuffer cb, int slot, ImageSize image, SgmBand band, const SgmConfig& params, bool float_out,
              bool fixed_out, FixedPoint fixed) const;
  void destroy(const Device& device) { vk::destroy(device, kernel_); }

 private:
  Kernel kernel_;
};

class DicStage {
 public:
  // subgroup_size: the device's; one window per subgroup, or with column windows window_subgroups of
  // them a window (0: subgroups_per_window()'s choice).
  void create(const KernelFactory& f, std::uint32_t subgroup_size, int window_subgroups);
  void rebind(const KernelFactory& f) const;
  // The B-spline coefficients of both images (with the census: it reads the same images).
  void record_prefilter(VkCommandBuffer cb, int slot, ImageSize image) const;
  // Writes every pixel of FrameBuffers::fixed in `fixed`. Builds the pipeline of a new number of subgroups
  // a window on its first use: VK_SUCCESS or that build's error.
  VkResult record(VkCommandBuffer cb, int slot, ImageSize image, const DicKernelConfig& d, FixedPoint fixed);
  // The subgroups that share a window of `d` on an image `height` rows tall.
  int subgroups_per_window(const DicKernelConfig& d, int height) const;
  void destroy(const Device& device);

 private:
  Kernel bspline_, pixels_, columns_;  // dic.comp in its two modes
  std::uint32_t subgroup_size_ = 1;
  int window_subgroups_ = 0;
};

}  // namespace rutd::gpu::vk
