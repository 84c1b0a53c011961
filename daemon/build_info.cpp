#include "daemon/build_info.hpp"

#include <string_view>

#include "build_commit.hpp"   // generated at build time
#include "build_version.hpp"  // generated at configure time

namespace rutd {
namespace {

static_assert(RUTD_VERSION_MAJOR <= 254 && RUTD_VERSION_MINOR <= 254 && RUTD_VERSION_PATCH <= 254,
              "the RutSoftwareVersion CAN message carries 0..254 per version number");
static_assert(RUTD_PACKAGE_REVISION >= 0 && RUTD_PACKAGE_REVISION <= 14,
              "the RutSoftwareVersion CAN message carries package revisions 0..14");

constexpr std::string_view kCommit = RUTD_GIT_COMMIT;

// The commit's first five hex digits as a number (git_commit.cmake writes lower-case hex only).
constexpr std::uint32_t commit_prefix(std::string_view hex) {
  std::uint32_t v = 0;
  for (std::size_t i = 0; i < 5 && i < hex.size(); ++i) {
    const char c = hex[i];
    v = v << 4 | static_cast<std::uint32_t>(c <= '9' ? c - '0' : c - 'a' + 10);
  }
  return v;
}
static_assert(commit_prefix("a5905c3e") == 0xA5905);

constexpr SoftwareVersion kVersion{RUTD_VERSION_MAJOR,    RUTD_VERSION_MINOR,     RUTD_VERSION_PATCH,
                                   RUTD_PACKAGE_REVISION, commit_prefix(kCommit), !kCommit.empty(),
                                   RUTD_GIT_MODIFIED != 0};

}  // namespace

const SoftwareVersion& software_version() { return kVersion; }

const char* package_version() { return RUTD_PACKAGE_VERSION; }

const char* git_commit() { return RUTD_GIT_COMMIT; }

std::string version_line() {
  std::string line = RUTD_PACKAGE_VERSION;
  if (kCommit.empty()) return line + " (commit unknown: not built from a git checkout)";
  line += " (git ";
  line += kCommit;
  if (kVersion.modified) line += ", modified: built with changes not committed";
  return line + ")";
}

}  // namespace rutd
