#pragma once
// What excuses a GPU test, and the checks that the GPU engine really ran. A GPU test runs wherever a
// Vulkan driver is installed (CI has lavapipe, Mesa's CPU driver) and fails, never skips, when the
// engine falls back to the CPU reference, when the device faults mid-run, or when a shader or pipeline
// fails to build: each of those makes the engine fall back, which expect_on_gpu() and
// expect_ran_on_gpu() catch. It skips only where no Vulkan driver exists at all (no loader, or a loader
// that finds no device) or rutd was built without Vulkan: no_vulkan_driver() says which, and
// RUTD_SKIP_WITHOUT_VULKAN_DRIVER() skips with that reason. CI installs the driver, so its skip policy must
// treat this skip as a failure there (the one place to hook it is no_vulkan_driver()).
#include <optional>
#include <string>

#include <gtest/gtest.h>

#include "engines/disparity_engine.hpp"
#include "skip_policy.hpp"
#include "test_support.hpp"
#ifdef RUTD_HAVE_GPU
#include "gpu/vulkan_sgm.hpp"
#endif

namespace rutd::test {

// Why GPU tests cannot run here, or nullopt when they can and must. A driver whose devices rutd cannot
// use is no excuse: the engine then falls back, and the tests fail.
inline std::optional<std::string> no_vulkan_driver() {
#ifdef RUTD_HAVE_GPU
  try {
    // No device and no driver installed: absent. No device though a driver is installed: the GPU path is
    // broken, and the test runs to fail on the engine's fallback.
    if (gpu::list_gpu_devices().empty() && vulkan_driver_manifests().empty())
      return "the Vulkan loader finds no driver (no ICD manifest)";
  } catch (const gpu::GpuError& e) {
    return std::string("no Vulkan loader or instance: ") + e.what();
  }
  return std::nullopt;
#else
  return "rutd was built without Vulkan (RUTD_GPU off: no Vulkan headers or glslc)";
#endif
}

// The GPU engine's lines on stderr (pipeline/gpu_engine.cpp): one per device it opens, and the fallback.
inline constexpr const char* kGpuDeviceLine = "rutd: GPU engine on ";
inline constexpr const char* kGpuFallbackLine = "GPU engine unavailable";

// Fails the test unless `engine` computes on a Vulkan device (not on the CPU reference it falls back to).
inline void expect_on_gpu(const DisparityEngine& engine) {
  EXPECT_EQ(engine.kind(), EngineKind::Gpu) << "the GPU engine fell back to the CPU: " << engine.device();
}

// Fails the test unless a rutd command's stderr shows the GPU engine opened exactly one device and never
// fell back to the CPU.
inline void expect_ran_on_gpu(const std::string& stderr_text) {
  int devices = 0, fallbacks = 0;
  std::size_t at = 0;
  while ((at = stderr_text.find(kGpuDeviceLine, at)) != std::string::npos) ++devices, ++at;
  at = 0;
  while ((at = stderr_text.find(kGpuFallbackLine, at)) != std::string::npos) ++fallbacks, ++at;
  EXPECT_EQ(devices, 1) << "GPU devices opened; stderr:\n" << stderr_text;
  EXPECT_EQ(fallbacks, 0) << "the GPU engine fell back to the CPU; stderr:\n" << stderr_text;
}

}  // namespace rutd::test

// Skips the test, naming the reason, where no Vulkan driver exists (see above); nowhere else. A missing
// driver is a missing installed package (skip_policy.hpp): under RUTD_TEST_NO_SKIP=1 (CI) it fails.
#define RUTD_SKIP_WITHOUT_VULKAN_DRIVER()                                                               \
  do {                                                                                                  \
    if (const auto rutd_no_vulkan = ::rutd::test::no_vulkan_driver())                                   \
      RUTD_SKIP_NEEDS_INSTALLED(                                                                        \
          "needs a Vulkan driver (lavapipe: Debian package mesa-vulkan-drivers): " << *rutd_no_vulkan); \
  } while (false)
