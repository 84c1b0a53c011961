#pragma once
// A live FrameSource backed by the synthetic renderer: the software test bench as a camera pair.
#include <cstdint>
#include <string>

#include "core/frame_source.hpp"
#include "core/io_faults.hpp"
#include "synthetic/synthetic_renderer.hpp"

namespace rutd {

struct SyntheticSourceConfig {
  // true: next() paces itself at params.fps on CLOCK_MONOTONIC and stamps each pair with the time its
  // render finished (ClockKind::Monotonic); a late render does not cause a burst, the schedule restarts.
  // false: pairs come as fast as they render, stamped with the synthetic timeline index * 1e9 / fps.
  bool paced = true;
  std::uint64_t first_index = 0;  // frame index (seq) of the first pair
  std::uint64_t frame_count = 0;  // pairs before EndOfStream; 0 = endless
};

// Not thread-safe (one acquisition thread owns it), like every FrameSource. next() allocates only
// when the frame's buffers do not fit.
class SyntheticSource : public FrameSource {
 public:
  // Throws std::invalid_argument for impossible parameters (see SyntheticRenderer). faults: tests only
  // (core/io_faults.hpp), IoPoint::CameraPop, asked once per pair after the paced wait: the pair of that
  // period is lost as a timeout, or refused as a short or corrupt buffer (Error); not owned.
  explicit SyntheticSource(const SyntheticRendererConfig& params, SyntheticSourceConfig options = {},
                           IoFaults* faults = nullptr);

  SourceStatus next(StereoFrame& frame) override;
  const StereoCalibration& calibration() const override { return renderer_.calibration(); }
  const std::string& error_message() const override { return error_; }

  // The renderer, for the truth of a pair: renderer().truth(frame.seq).
  const SyntheticRenderer& renderer() const noexcept { return renderer_; }

 private:
  void wait_for_slot();  // sleeps until the next pair is due on the schedule

  SyntheticRenderer renderer_;
  SyntheticSourceConfig options_;
  std::uint64_t produced_ = 0;
  std::int64_t schedule_start_ns_ = -1;  // CLOCK_MONOTONIC time of the schedule's pair 0
  std::uint64_t schedule_first_ = 0;     // produced_ count at schedule_start_ns_
  std::string error_;                    // empty but after an injected fault: rendering cannot fail
  IoFaults* faults_;
};

}  // namespace rutd
