#pragma once
// The frame source `rutd run` measures from, chosen by the configuration at run time.
#include <memory>
#include <string>

#include "core/frame_source.hpp"
#include "daemon/config.hpp"

namespace rutd {

// Throws InputError for an unusable source (bad recording folder, a source this build lacks).
std::unique_ptr<FrameSource> make_source(const RutdConfig& config);
std::string describe_source(const RutdConfig& config);

}  // namespace rutd
