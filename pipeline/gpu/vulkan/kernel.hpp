#pragma once
// Compute kernels: a shader's pipeline, its descriptor-set layout and one descriptor set per frame slot
// (each slot binds its own FrameBuffers), made from SPIR-V embedded at build time; and the buffers every
// kernel binds, one FrameBuffers per slot. Private to rutd_gpu.
#include <vulkan/vulkan.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <utility>
#include <vector>

#include "device.hpp"
#include "memory.hpp"

namespace rutd::gpu::vk {

constexpr int kSlots = 2;     // frames in flight
constexpr int kPathsMax = 8;  // FrameBuffers::costs

// Words of four byte costs per pixel: a multiple of 4, so that wta.comp reads them 16 bytes at a time.
inline int cost_words(int disparities) { return (disparities + 15) / 16 * 4; }

// Every buffer one frame's work uses on the device. Each slot has its own, so that two frames in flight
// share nothing and the device may overlap them.
struct FrameBuffers {
  // match_cost: cost.comp's byte costs; costs: aggregate.comp's, one buffer per direction; right_key: the
  // right view as wta.comp's keys.
  Buffer image_left, image_right, census_left, census_right, match_cost, disp_left, right_key, disparity;
  std::array<Buffer, kPathsMax> costs;
  Buffer spline_left, spline_right;  // DIC
  // The 16-bit fixed-point disparity (DisparityView), the matcher's or the DIC's: what the host downloads.
  Buffer fixed;
  Buffer raw_left, raw_right;  // raw images to rectify (set_rectification)
};

// The buffers of each binding of a kernel (several: an array of descriptors), from a slot's FrameBuffers.
using Bindings = std::vector<std::vector<const Buffer*>>;
using BindingsOf = std::function<Bindings(const FrameBuffers&)>;

struct Kernel {
  VkDescriptorSetLayout set_layout = VK_NULL_HANDLE;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkPipeline pipeline = VK_NULL_HANDLE;        // of the specialization values given to make()
  std::array<VkDescriptorSet, kSlots> sets{};  // a slot's FrameBuffers
  BindingsOf bindings_of;                      // what the sets bind, for rebind()
  // Kept to build variants (variant()): the shader and the pipelines of other specialization values.
  const Device* device = nullptr;
  VkShaderModule module = VK_NULL_HANDLE;
  VkPipelineCreateFlags flags = 0;
  std::vector<std::pair<std::vector<std::int32_t>, VkPipeline>> variants;
};

// The pipeline of `k` for the specialization values `spec` (constants 0, 1, ...), built on its first use
// and kept while the kernel lives (a new disparity count costs one pipeline build, once): VK_SUCCESS, or
// the build's error, `out` then VK_NULL_HANDLE.
VkResult variant(Kernel& k, const std::vector<std::int32_t>& spec, VkPipeline& out);

// Makes kernels on one device from one descriptor pool, binding each slot's buffers.
class KernelFactory {
 public:
  KernelFactory(const Device& device, VkDescriptorPool pool, std::array<const FrameBuffers*, kSlots> slots)
      : device_(device), pool_(pool), slots_(slots) {}

  // spv: SPIR-V, `bytes` long. push_bytes: the push-constant block's size. spec: the values of the shader's
  // specialization constants 0, 1, ..., where it has them. Throws GpuError.
  Kernel make(const std::uint32_t* spv, std::size_t bytes, std::uint32_t push_bytes, const BindingsOf& bindings_of,
              const std::vector<std::int32_t>& spec = {}, VkPipelineCreateFlags flags = 0) const;
  // Points every slot's set of `k` at the buffers its bindings_of gives now (after a reallocation); a
  // kernel not made is left alone.
  void rebind(const Kernel& k) const;

 private:
  void write_set(VkDescriptorSet set, const Bindings& bindings) const;

  const Device& device_;
  VkDescriptorPool pool_;
  std::array<const FrameBuffers*, kSlots> slots_;
};

// Frees the kernel's pipeline and layouts (its sets go with the descriptor pool) and resets it.
void destroy(const Device& device, Kernel& k);

inline std::uint32_t groups(int n, int size) { return static_cast<std::uint32_t>((n + size - 1) / size); }

// Binds `pipeline` (k.pipeline or one of its variants), the slot's set and the push constants, and
// dispatches x * y * z workgroups.
template <class Push>
void dispatch(VkCommandBuffer cb, int slot, const Kernel& k, VkPipeline pipeline, const Push& push, std::uint32_t x,
              std::uint32_t y, std::uint32_t z) {
  vkCmdBindPipeline(cb, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline);
  vkCmdBindDescriptorSets(cb, VK_PIPELINE_BIND_POINT_COMPUTE, k.layout, 0, 1, &k.sets[static_cast<std::size_t>(slot)],
                          0, nullptr);
  vkCmdPushConstants(cb, k.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(Push), &push);
  vkCmdDispatch(cb, x, y, z);
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

}  // namespace rutd::gpu::vk
