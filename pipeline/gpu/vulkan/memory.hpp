#pragma once
// Buffers and their memory, memory barriers, and the one-off transfers of start-up and tests (the
// per-frame transfers are recorded into a frame's command buffer: frame.cpp). Private to rutd_gpu.
#include <vulkan/vulkan.h>

#include <cstddef>

#include "device.hpp"

namespace rutd::gpu::vk {

struct Buffer {
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkDeviceSize size = 0;
  void* mapped = nullptr;  // host-visible buffers stay mapped
};

// host: host-visible and coherent, cached where the device offers it (the host reads downloads), mapped
// for the buffer's lifetime; else device-local. Throws GpuError.
Buffer make_buffer(const Device& device, VkDeviceSize size, VkBufferUsageFlags usage, bool host);
// Frees b (a default Buffer is a no-op) and resets it.
void destroy(const Device& device, Buffer& b);

// Every shader or transfer write before it is visible to every shader, transfer or host read after it.
void barrier(VkCommandBuffer cb, VkPipelineStageFlags src, VkPipelineStageFlags dst);

// One copy between buffers, waited for (start-up and test paths only).
VkResult copy_now(const Device& device, VkCommandPool pool, const Buffer& src, const Buffer& dst, std::size_t bytes);
// Test path: a device buffer's first `bytes` copied back through a temporary host buffer.
VkResult read_back(const Device& device, VkCommandPool pool, const Buffer& src, void* dst, std::size_t bytes);
// Start-up path: host data into a device buffer through a temporary host buffer.
VkResult write_to(const Device& device, VkCommandPool pool, const Buffer& dst, const void* src, std::size_t bytes);

}  // namespace rutd::gpu::vk
