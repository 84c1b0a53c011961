#pragma once
// The status messages of `rutd replay`: what the vehicle would have sent while the recording was made,
// on the recording's clock, so that a replay's candump log is the bus traffic of the drive. The real-time
// pipeline's rules (RealtimePipeline::health) applied to a recording measured pair by pair in order, where
// nothing is dropped or stale. Every `period` of recording time from the first pair, a SensorHealth with
//   no_camera            no pair for `no_frame_timeout` (a gap in the recording)
//   calibration_invalid  a pair of the period did not fit the calibration, or the last one seen did not
//                        (held through periods without pairs until a pair fits again)
//   low_texture          the last measurement was TooFewPoints
//   frame_rate_hz        pairs per second, over windows of at least 1 s of recording time
//   last_status          the last measurement's status
// while stale_frames, frame_drops and dropped_frames stay clear. A gap of more than kMaxGapStatuses
// periods (recordings spliced together, hours apart) gets that many statuses; the next ones keep the
// period from the pair after the gap. Main thread only.
#include <chrono>
#include <cstdint>

#include "core/measurement_sink.hpp"
#include "core/sensor_health.hpp"

namespace rutd {

class ReplayStatus {
 public:
  static constexpr std::int64_t kMaxGapStatuses = 6000;  // ten minutes at 100 ms

  // Throws std::invalid_argument for a period or timeout that is not positive.
  ReplayStatus(std::chrono::milliseconds period, std::chrono::milliseconds no_frame_timeout);

  // Before the pair taken at t_ns (recording clock, not decreasing) is published: sends to `sink` every
  // status due before t_ns (one due at t_ns itself follows the pair, as the pipeline's publish thread
  // handles a pair before the status that falls due meanwhile).
  void advance(std::int64_t t_ns, MeasurementSink& sink);
  // The pair: whether it fitted the calibration (StereoMeasurer::rectify), and its status.
  void add(std::int64_t t_ns, bool fitted, RutStatus status);
  // The health as of the last status, with the latest last_status: for PublishedFrame::health.
  SensorHealth health() const;
  // After the last pair: one last status at its time (the pipeline sends one when a recording ends; a
  // status due at that very time is this one).
  void finish(MeasurementSink& sink);
  std::uint64_t sent() const { return sent_; }

 private:
  void send(std::int64_t t_ns, MeasurementSink& sink);

  std::int64_t period_ns_, timeout_ns_;
  bool started_ = false;
  std::int64_t next_ns_ = 0;                // time of the next status
  std::int64_t last_pair_ns_ = 0;           // time of the last pair
  bool rejected_ = false, fitted_ = false;  // in the current period
  std::uint64_t pairs_ = 0;
  std::int64_t rate_t0_ns_ = 0;
  std::uint64_t rate_pairs_ = 0;
  SensorHealth health_;
  std::uint64_t sent_ = 0;
};

}  // namespace rutd
