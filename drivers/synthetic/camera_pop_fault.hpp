#pragma once
// The synthetic sources' camera-pop fault (tests only, core/io_faults.hpp, IoPoint::CameraPop), shared
// by the live renderer and the cycling source so both fail the way a camera driver reports it. Private
// to drivers/synthetic.
#include <cstring>
#include <string>

#include "core/frame_source.hpp"
#include "core/io_faults.hpp"

namespace rutd {

// Asks `faults` (may be null) whether this pop fails. Ok: deliver the pair. Otherwise the pair of this
// period is lost: Timeout for io_fault::kTimeout (nothing arrived), Error with `error` saying why for a
// short or corrupt buffer or an errno.
inline SourceStatus check_camera_pop_fault(IoFaults* faults, std::string& error) {
  const int fault = faults != nullptr ? faults->check(IoPoint::CameraPop) : 0;
  if (fault == 0) return SourceStatus::Ok;
  if (fault == io_fault::kTimeout) return SourceStatus::Timeout;
  error = fault == io_fault::kShort     ? "synthetic camera: short buffer"
          : fault == io_fault::kCorrupt ? "synthetic camera: corrupt buffer"
                                        : std::string("synthetic camera: ") + std::strerror(fault);
  return SourceStatus::Error;
}

}  // namespace rutd
