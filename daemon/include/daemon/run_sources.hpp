#pragma once
// The frame source `rutd run` measures from, chosen by the configuration at run time.
#include <memory>
#include <string>

#include "core/frame_source.hpp"
#include "core/io_faults.hpp"
#include "daemon/config.hpp"

namespace rutd {

// Throws InputError for an unusable source (bad recording folder, a source this build lacks). faults:
// tests only (core/io_faults.hpp), handed to the source's lowest calls; not owned.
std::unique_ptr<FrameSource> make_source(const RutdConfig& config, IoFaults* faults = nullptr);
std::string describe_source(const RutdConfig& config);

}  // namespace rutd
