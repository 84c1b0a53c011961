#pragma once
// What software is running: the package version (the CMake project version MAJOR.MINOR.PATCH and the
// Debian revision, `rutd_MAJOR.MINOR.PATCH-REVISION_ARCH.deb`) and the git commit it was built from. The
// build fills it in (daemon/build_info.hpp); `rutd --version` prints it and the RutSoftwareVersion CAN
// message carries it (can/can_encoder.hpp, config/rutd.dbc). The ranges are the CAN message's: the build
// refuses a version that does not fit them (CMakeLists.txt), so nothing is ever cut short on the wire.
#include <cstdint>

namespace rutd {

struct SoftwareVersion {
  std::uint8_t major = 0;     // 0..254
  std::uint8_t minor = 0;     // 0..254
  std::uint8_t patch = 0;     // 0..254
  std::uint8_t revision = 0;  // Debian revision of the package, 0..14
  // The commit's first five hex digits as a number (commit a5905c3... -> 0xA5905); `git show a5905`
  // finds it. Meaningless when !commit_known.
  std::uint32_t commit_prefix = 0;
  bool commit_known = false;  // false: built from a tree without git (a source archive)
  bool modified = false;      // the checkout had changes not committed when it was built
};

}  // namespace rutd
