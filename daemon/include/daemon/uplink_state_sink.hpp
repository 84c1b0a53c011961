#pragma once
// Puts the fleet uplink's state into the status (SensorHealth::uplink) on its way to the CAN sink, which
// sends it as RutUplinkStatus: the figures as the uplink reports them now, the flags raised when their
// counters moved since the previous status. Publish thread only; everything else passes through.
#include <cstdint>

#include "core/measurement_sink.hpp"
#include "uplink/uplink.hpp"

namespace rutd {

class UplinkStateSink final : public MeasurementSink {
 public:
  // next, uplink: not owned; both outlive the sink.
  UplinkStateSink(MeasurementSink& next, const Uplink& uplink) : next_(next), uplink_(uplink) {}
  void publish(const PublishedFrame& frame) override { next_.publish(frame); }
  void publish_segment(const Segment& segment) override { next_.publish_segment(segment); }
  void publish_status(const SensorHealth& health, std::int64_t t_ns) override {
    SensorHealth h = health;
    const UplinkHealth u = uplink_.health();
    const std::uint64_t errors = u.send_errors + u.connect_failures, dropped = u.dropped_oldest + u.not_queued;
    h.uplink.enabled = true;
    h.uplink.link_up = u.link_up;
    h.uplink.queued = u.queued;
    h.uplink.oldest_unsent_s = u.oldest_unsent_s;
    h.uplink.send_errors = errors != errors_;
    h.uplink.queue_error = u.queue_errors != queue_errors_;
    h.uplink.dropped = dropped != dropped_;
    errors_ = errors;
    queue_errors_ = u.queue_errors;
    dropped_ = dropped;
    next_.publish_status(h, t_ns);
  }

 private:
  MeasurementSink& next_;
  const Uplink& uplink_;
  std::uint64_t errors_ = 0, queue_errors_ = 0, dropped_ = 0;
};

}  // namespace rutd
