#pragma once
// Joins positions to measurements: puts the fix in force at each pair's capture time
// (PositionSource::position_at) into PublishedFrame::position, then hands the frame on. Publish thread
// only; allocation-free (the frame is copied on the stack; its detail pointers stay the publisher's, valid
// for the call as before).
#include <cstdint>

#include "core/measurement_sink.hpp"
#include "core/monotonic_clock.hpp"
#include "gps/position_source.hpp"

namespace rutd {

struct PositionJoinStats {
  std::uint64_t with_position = 0;     // pairs published with a valid fix
  std::uint64_t without_position = 0;  // pairs with none in force (no gpsd, no fix, or stale)
};

class PositionJoinSink final : public MeasurementSink {
 public:
  // `frames_on_local_clock`: the pairs' t_ns is this machine's CLOCK_MONOTONIC, as the fixes' receive
  // times are. When it is not (cameras' hardware clock, a recording's clock), a pair is joined at the time
  // it is published instead, a few milliseconds to max_frame_age after capture.
  PositionJoinSink(MeasurementSink& next, const PositionSource& positions, bool frames_on_local_clock)
      : next_(next), positions_(positions), local_clock_(frames_on_local_clock) {}

  void publish(const PublishedFrame& frame) override {
    PublishedFrame joined = frame;
    const bool local = local_clock_ && frame.clock == ClockKind::Monotonic;
    joined.position = positions_.position_at(local ? frame.t_ns : monotonic_now_ns());
    ++(joined.position.valid() ? stats_.with_position : stats_.without_position);
    next_.publish(joined);
  }
  void publish_status(const SensorHealth& health, std::int64_t t_ns) override { next_.publish_status(health, t_ns); }
  void publish_segment(const Segment& segment) override { next_.publish_segment(segment); }

  // Publish thread, or after the pipeline stopped.
  const PositionJoinStats& stats() const { return stats_; }

 private:
  MeasurementSink& next_;
  const PositionSource& positions_;
  bool local_clock_;
  PositionJoinStats stats_;
};

}  // namespace rutd
