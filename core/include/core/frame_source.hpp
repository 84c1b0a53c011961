#pragma once
// A source of synchronised stereo pairs: synthetic renderer, recording replay, Aravis cameras. Chosen
// from the configuration at run time. Not thread-safe: one thread (acquisition) owns a source.
#include <string>

#include "core/stereo_calibration.hpp"
#include "core/stereo_frame.hpp"

namespace rutd {

enum class SourceStatus {
  Ok,           // `frame` holds a new pair
  EndOfStream,  // a finite source (recording) has no more pairs
  Timeout,      // no pair within the source's own bounded wait; try again
  Error,        // a per-frame failure (unreadable image, lost camera); error_message() says what
};

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  // Fills `frame` with the next pair, reusing its buffers when they fit. A live source paces itself at
  // its frame rate; a recording returns as fast as it can read.
  virtual SourceStatus next(StereoFrame& frame) = 0;
  // The calibration of the rig the pairs come from.
  virtual const StereoCalibration& calibration() const = 0;
  // The message of the last Error, empty otherwise.
  virtual const std::string& error_message() const = 0;
};

}  // namespace rutd
