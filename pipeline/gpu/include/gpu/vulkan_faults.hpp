#pragma once
// Fault injection at the Vulkan matcher's lowest calls, for tests only (as core/io_faults.hpp does for
// rutd's I/O). VulkanSgm, given a VulkanFaults (VulkanSgmOptions::faults), asks it just before each of
// these Vulkan calls whether the call fails; if so it skips the call and carries on exactly as if the
// driver had returned that result. Production code never creates one (no configuration key, option or
// environment variable reaches it): there the cost is one predictable branch per call.
//
// Thread safety: set() before the matcher is made; check() and injected() from any thread.
#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <limits>

namespace rutd::gpu {

// Where a fault is injected.
enum class VulkanCall {
  CreateDevice,    // vkCreateDevice: the device cannot be opened
  CreatePipeline,  // vkCreateComputePipelines: a shader's pipeline fails to build
  QueueSubmit,     // vkQueueSubmit of a frame
  WaitForFrame,    // vkGetFenceStatus / vkWaitForFences while collecting a frame
};
inline constexpr std::size_t kVulkanCallCount = 4;

// What the call returns instead (VkResult): the device lost, out of device memory, or the driver's
// generic failure.
enum class VulkanFault { None, DeviceLost, OutOfDeviceMemory, InitializationFailed };

struct VulkanFaultRule {
  VulkanFault fault = VulkanFault::None;
  std::uint64_t after = 0;                                          // this many calls succeed first
  std::uint64_t count = std::numeric_limits<std::uint64_t>::max();  // then this many fail; later ones succeed
};

class VulkanFaults {
 public:
  void set(VulkanCall call, VulkanFaultRule rule) noexcept { at(call).rule = rule; }

  // None: do the call. Otherwise the fault to behave as.
  VulkanFault check(VulkanCall call) noexcept {
    Point& p = at(call);
    const std::uint64_t n = p.calls.fetch_add(1, std::memory_order_relaxed);
    if (p.rule.fault == VulkanFault::None || n < p.rule.after || n - p.rule.after >= p.rule.count)
      return VulkanFault::None;
    p.injected.fetch_add(1, std::memory_order_relaxed);
    return p.rule.fault;
  }

  // Calls made at `call` (each asked check() first), and those that were made to fail.
  std::uint64_t calls(VulkanCall call) const noexcept { return at(call).calls.load(std::memory_order_relaxed); }
  std::uint64_t injected(VulkanCall call) const noexcept { return at(call).injected.load(std::memory_order_relaxed); }

 private:
  struct Point {
    VulkanFaultRule rule;
    std::atomic<std::uint64_t> calls{0};
    std::atomic<std::uint64_t> injected{0};
  };
  Point& at(VulkanCall call) noexcept { return points_[static_cast<std::size_t>(call)]; }
  const Point& at(VulkanCall call) const noexcept { return points_[static_cast<std::size_t>(call)]; }

  std::array<Point, kVulkanCallCount> points_{};
};

}  // namespace rutd::gpu
