#pragma once
// When a test may skip. A test that cannot run here says what it needs, through one of two macros (never
// a bare GTEST_SKIP, never a silent return past the checks it could not make):
//
//   RUTD_SKIP_NEEDS_HARDWARE(why)   hardware, kernel support or a person this machine lacks: a CAN
//                                   controller or vcan in the host kernel, a USB bus, a camera plugged in
//                                   by hand. Skips everywhere; tests/ci_skips.txt lists the tests CI
//                                   may see skipped for that reason, and .ci/run fails on any other.
//   RUTD_SKIP_NEEDS_INSTALLED(why)  something scripts/install-deps installs or CI's root account has:
//                                   canmatrix, can-utils, qemu, busybox-static, systemd, a Vulkan driver
//                                   (lavapipe), network and mount namespaces. Skips on a developer's
//                                   machine without it; fails, with the same message, when the
//                                   environment has RUTD_TEST_NO_SKIP=1 (.ci/run sets it), where a skip
//                                   would hide a broken install or a broken code path.
//
// The GPU tests' case of the second is RUTD_SKIP_WITHOUT_VULKAN_DRIVER (gpu_test_support.hpp): they skip
// only where this build has no GPU engine or no Vulkan driver is installed at all; where a driver is
// installed an engine that falls back to the CPU fails them (the GPU path is broken, not absent).
// Scripts that CTest runs with SKIP_RETURN_CODE 77 follow the same policy through tests/skip_policy.sh.
//
// Each macro returns from the current void function (a TEST body, SetUp, a helper), as GTEST_SKIP does;
// `why` is evaluated once, only when it skips.
#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include <gtest/gtest.h>

namespace rutd::test {

// True when RUTD_TEST_NO_SKIP=1: a missing installed prerequisite fails the test.
inline bool no_skip() {
  const char* v = std::getenv("RUTD_TEST_NO_SKIP");
  return v != nullptr && std::string_view(v) == "1";
}

inline constexpr const char* kNoSkipNote =
    " [RUTD_TEST_NO_SKIP=1: CI installs this, so the skip is a failure; scripts/install-deps installs it]";

// The Vulkan drivers the loader would find: the ICD manifests (*.json) in VK_DRIVER_FILES or
// VK_ICD_FILENAMES when set (files or folders, ':'-separated; they replace the search), else in the
// loader's folders (vulkan/icd.d under XDG_CONFIG_HOME, XDG_CONFIG_DIRS, /etc, XDG_DATA_HOME,
// XDG_DATA_DIRS), plus VK_ADD_DRIVER_FILES. Presence of a manifest, not a working device: that is what
// the tests check.
inline std::vector<std::filesystem::path> vulkan_driver_manifests() {
  namespace fs = std::filesystem;
  const auto env = [](const char* name, const char* fallback) {
    const char* v = std::getenv(name);
    return std::string(v != nullptr && *v != '\0' ? v : fallback);
  };
  const auto split = [](const std::string& list) {
    std::vector<std::string> out;
    for (std::size_t at = 0; at <= list.size();) {
      const std::size_t end = std::min(list.find(':', at), list.size());
      if (end > at) out.push_back(list.substr(at, end - at));
      at = end + 1;
    }
    return out;
  };
  std::string drivers = env("VK_DRIVER_FILES", "");
  if (drivers.empty()) drivers = env("VK_ICD_FILENAMES", "");
  std::vector<std::string> places = split(drivers);
  if (places.empty()) {
    const std::string home = env("HOME", "/nonexistent");
    std::vector<std::string> roots = {env("XDG_CONFIG_HOME", (home + "/.config").c_str())};
    for (const std::string& r : split(env("XDG_CONFIG_DIRS", "/etc/xdg"))) roots.push_back(r);
    roots.push_back("/etc");
    roots.push_back(env("XDG_DATA_HOME", (home + "/.local/share").c_str()));
    for (const std::string& r : split(env("XDG_DATA_DIRS", "/usr/local/share:/usr/share"))) roots.push_back(r);
    for (const std::string& r : roots) places.push_back(r + "/vulkan/icd.d");
  }
  for (const std::string& p : split(env("VK_ADD_DRIVER_FILES", ""))) places.push_back(p);
  std::vector<fs::path> found;
  std::error_code ec;
  for (const std::string& place : places) {
    if (fs::is_directory(place, ec)) {
      for (const auto& entry : fs::directory_iterator(place, ec))
        if (entry.path().extension() == ".json") found.push_back(entry.path());
    } else if (fs::is_regular_file(place, ec)) {
      found.push_back(place);
    }
  }
  return found;
}

}  // namespace rutd::test

#define RUTD_SKIP_NEEDS_HARDWARE(why) GTEST_SKIP() << why

#define RUTD_SKIP_NEEDS_INSTALLED(why)                  \
  do {                                                  \
    if (::rutd::test::no_skip()) {                      \
      GTEST_FAIL() << why << ::rutd::test::kNoSkipNote; \
    } else {                                            \
      GTEST_SKIP() << why;                              \
    }                                                   \
  } while (false)
