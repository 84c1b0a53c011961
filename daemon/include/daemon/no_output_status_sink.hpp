#pragma once
// Makes the status frame say when rutd has no output. The pipeline's SensorHealth::last_status is the
// status of the last published measurement, however old: with every pair refused as stale for minutes
// it would still read OK. This sink sits in front of the CAN sink and, once no measurement has been
// published for `after`, sends NO_MEASUREMENT as the latest status (beside the pipeline's own NoCamera or
// StaleFrames flag saying why) until a measurement is published again. Publish thread only, like every
// sink. Time counts on CLOCK_MONOTONIC live; in replay, on the recording's clock (the frames' t_ns and the
// statuses' own times, ReplayStatus).
#include <chrono>
#include <cstdint>

#include "core/measurement_sink.hpp"
#include "core/monotonic_clock.hpp"

namespace rutd {

class NoOutputStatusSink final : public MeasurementSink {
 public:
  enum class Clock { Monotonic, Frames };
  // `next` must outlive this sink.
  NoOutputStatusSink(MeasurementSink& next, std::chrono::milliseconds after, Clock clock = Clock::Monotonic)
      : next_(next), after_ns_(std::chrono::nanoseconds(after).count()), clock_(clock) {}
  void publish(const PublishedFrame& frame) override {
    published_ns_ = clock_ == Clock::Frames ? frame.t_ns : monotonic_now_ns();
    next_.publish(frame);
  }
  void publish_status(const SensorHealth& health, std::int64_t t_ns) override {
    if (published_ns_ < 0) published_ns_ = t_ns;  // counts from the first status, not from boot
    SensorHealth h = health;
    if (t_ns - published_ns_ >= after_ns_) h.last_status = RutStatus::NoMeasurement;
    next_.publish_status(h, t_ns);
  }
  void publish_segment(const Segment& segment) override { next_.publish_segment(segment); }

 private:
  MeasurementSink& next_;
  std::int64_t after_ns_;
  Clock clock_;
  std::int64_t published_ns_ = -1;
};

}  // namespace rutd
