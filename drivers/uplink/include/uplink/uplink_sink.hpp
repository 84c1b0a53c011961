#pragma once
// The measurement sink of the fleet uplink (core/measurement_sink.hpp): every closed segment goes up as a
// segment message; measurements without a known speed (no speed source, or the speed not OK), which no
// segment places, go up summarised per second of UTC time; the sensor's and the uplink's health every
// health period. Publish thread only; per frame it only adds to the second's summary (no allocation); a
// message is formatted when it is posted (a few a second at most).
#include <cstdint>
#include <functional>

#include "core/measurement_sink.hpp"
#include "uplink/uplink.hpp"

namespace rutd {

class UplinkSink final : public MeasurementSink {
 public:
  // uplink: not owned, outlives the sink. unix_now: the UTC clock in ns (tests give their own).
  explicit UplinkSink(Uplink& uplink, std::function<std::int64_t()> unix_now = {});
  void publish(const PublishedFrame& frame) override;
  void publish_status(const SensorHealth& health, std::int64_t t_ns) override;
  void publish_segment(const Segment& segment) override;

 private:
  void flush_second(std::int64_t now_unix_ns);
  Uplink& uplink_;
  std::function<std::int64_t()> unix_now_;
  SecondSummary second_;
  double depth_sum_ = 0;
  std::int64_t next_health_unix_ns_ = 0;
};

}  // namespace rutd
