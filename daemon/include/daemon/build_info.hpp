#pragma once
// This build's version (core/software_version.hpp): the package version, from project() in CMakeLists.txt
// and the cache variable RUTD_PACKAGE_REVISION, and the git commit found at build time
// (daemon/git_commit.cmake). One library (rutd_build_info) holds it, so a new commit recompiles one file.
#include <string>

#include "core/software_version.hpp"

namespace rutd {

const SoftwareVersion& software_version();

// The package's version, "MAJOR.MINOR.PATCH-REVISION" (what dpkg shows).
const char* package_version();

// The full 40-digit commit, or "" when not built from a git checkout.
const char* git_commit();

// One line for `rutd --version` and the journal:
//   "0.1.0-1 (git a5905c3e...)", "0.1.0-1 (git a5905c3e..., modified: built with changes not committed)"
//   or "0.1.0-1 (commit unknown: not built from a git checkout)".
std::string version_line();

}  // namespace rutd
