#pragma once
// The engine factory: the one place that knows every engine (engines/opencv_engines.hpp,
// engines/gpu_engine.hpp), above them; everything else sees only the DisparityEngine interface.
#include <memory>

#include "engines/disparity_engine.hpp"

namespace rutd {

// Throws std::invalid_argument for parameters OpenCV would refuse (even block size, p2 <= p1, ...), and for
// EngineKind::Gpu (not a CPU engine).
std::unique_ptr<DisparityEngine> make_cpu_engine(EngineKind kind, const EngineConfig& params = {});

// Any engine. Gpu: when the build has no Vulkan engine or no usable Vulkan device exists (or the device
// fails later), the engine logs the reason once on stderr and computes with the SgmRef engine instead
// (same disparities, slower). Throws std::invalid_argument for bad parameters.
std::unique_ptr<DisparityEngine> make_engine(EngineKind kind, const EngineConfig& params = {});

// Throws std::invalid_argument where make_engine would, without making the engine (no GPU device is
// opened): a start-up check for objects that make their engine later.
void check_engine(EngineKind kind, const EngineConfig& params = {});

}  // namespace rutd
