#pragma once
// A live source that plays pairs held in memory over and over, so benchmarks and tests measure the
// pipeline without paying for rendering or decoding. Each pair is copied into the frame's buffers, as a
// camera driver fills its own, and stamped with CLOCK_MONOTONIC at delivery. Not thread-safe: one
// acquisition thread owns it, like every FrameSource.
#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include "core/frame_source.hpp"
#include "core/io_faults.hpp"

namespace rutd {

class CyclingSource final : public FrameSource {
 public:
  // frames: at least one pair. period: the pacing of next() (a camera's frame period); zero: as fast as
  // it is called. faults: tests only (core/io_faults.hpp), IoPoint::CameraPop: a paced wait that ends in
  // a timeout, or a buffer refused as corrupt or short, as a camera driver reports them; not owned.
  CyclingSource(StereoCalibration calibration, std::vector<StereoFrame> frames, std::chrono::nanoseconds period,
                IoFaults* faults = nullptr);

  SourceStatus next(StereoFrame& frame) override;
  const StereoCalibration& calibration() const override { return calibration_; }
  const std::string& error_message() const override { return error_; }

 private:
  StereoCalibration calibration_;
  std::vector<StereoFrame> frames_;
  std::chrono::nanoseconds period_;
  std::chrono::steady_clock::time_point due_{};
  std::string error_;
  std::uint64_t seq_ = 0;
  IoFaults* faults_;
};

}  // namespace rutd
