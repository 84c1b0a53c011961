#include "memory.hpp"

#include <algorithm>
#include <cstring>
#include <limits>

namespace rutd::gpu::vk {

Buffer make_buffer(const Device& device, VkDeviceSize size, VkBufferUsageFlags usage, bool host) {
  const VkDevice d = device.handle();
  Buffer b;
  b.size = std::max<VkDeviceSize>(size, 4);
  auto bi = info_struct<VkBufferCreateInfo>(VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO);
  bi.size = b.size;
  bi.usage = usage;
  bi.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  check(vkCreateBuffer(d, &bi, nullptr, &b.buffer), "vkCreateBuffer");
  VkMemoryRequirements req;
  vkGetBufferMemoryRequirements(d, b.buffer, &req);
  // Host buffers: coherent, cached if possible (the download is read by the CPU). Device buffers: local.
  const VkMemoryPropertyFlags want = host ? (VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT)
                                          : VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT;
  const VkPhysicalDeviceMemoryProperties& memory = device.memory();
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
  if (type == std::numeric_limits<std::uint32_t>::max()) {
    vkDestroyBuffer(d, b.buffer, nullptr);
    throw GpuError(device.info().name + ": no suitable memory type");
  }
  auto ai = info_struct<VkMemoryAllocateInfo>(VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO);
  ai.allocationSize = req.size;
  ai.memoryTypeIndex = type;
  try {
    check(vkAllocateMemory(d, &ai, nullptr, &b.memory), "vkAllocateMemory");
    check(vkBindBufferMemory(d, b.buffer, b.memory, 0), "vkBindBufferMemory");
    if (host) check(vkMapMemory(d, b.memory, 0, VK_WHOLE_SIZE, 0, &b.mapped), "vkMapMemory");
  } catch (...) {
    destroy(device, b);
    throw;
  }
  return b;
}

void destroy(const Device& device, Buffer& b) {
  if (b.mapped) vkUnmapMemory(device.handle(), b.memory);
  vkDestroyBuffer(device.handle(), b.buffer, nullptr);
  vkFreeMemory(device.handle(), b.memory, nullptr);
  b = Buffer{};
}

void barrier(VkCommandBuffer cb, VkPipelineStageFlags src, VkPipelineStageFlags dst) {
  auto mb = info_struct<VkMemoryBarrier>(VK_STRUCTURE_TYPE_MEMORY_BARRIER);
  mb.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT;
  mb.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_READ_BIT |
                     VK_ACCESS_TRANSFER_WRITE_BIT | VK_ACCESS_HOST_READ_BIT;
  vkCmdPipelineBarrier(cb, src, dst, 0, 1, &mb, 0, nullptr, 0, nullptr);
}

VkResult copy_now(const Device& device, VkCommandPool pool, const Buffer& src, const Buffer& dst, std::size_t bytes) {
  auto ai = info_struct<VkCommandBufferAllocateInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO);
  ai.commandPool = pool;
  ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  ai.commandBufferCount = 1;
  VkCommandBuffer cb = VK_NULL_HANDLE;
  VkResult r = vkAllocateCommandBuffers(device.handle(), &ai, &cb);
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
  if (r == VK_SUCCESS) r = vkQueueSubmit(device.queue(), 1, &si, VK_NULL_HANDLE);
  if (r == VK_SUCCESS) r = vkQueueWaitIdle(device.queue());
  vkFreeCommandBuffers(device.handle(), pool, 1, &cb);
  return r;
}

VkResult read_back(const Device& device, VkCommandPool pool, const Buffer& src, void* dst, std::size_t bytes) {
  Buffer tmp = make_buffer(device, bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT, true);
  const VkResult r = copy_now(device, pool, src, tmp, bytes);
  if (r == VK_SUCCESS) std::memcpy(dst, tmp.mapped, bytes);
  destroy(device, tmp);
  return r;
}

VkResult write_to(const Device& device, VkCommandPool pool, const Buffer& dst, const void* src, std::size_t bytes) {
  Buffer tmp = make_buffer(device, bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, true);
  std::memcpy(tmp.mapped, src, bytes);
  const VkResult r = copy_now(device, pool, tmp, dst, bytes);
  destroy(device, tmp);
  return r;
}

}  // namespace rutd::gpu::vk
