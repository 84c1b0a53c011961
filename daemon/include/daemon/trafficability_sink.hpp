#pragma once
// Where trafficability/ meets the publish path: a MeasurementSink in front of the daemon's other sinks.
// For each published frame it takes the speed samples received up to the frame's capture time (from the
// live receiver, or from a recording's vehicle.log in replay), fills PublishedFrame::motion, hands the
// frame on, places the measurement on the track and hands on every segment that closed
// (MeasurementSink::publish_segment). Called from the publish thread only; allocates nothing per frame.
#include <cstdint>
#include <functional>
#include <string>

#include "core/measurement_sink.hpp"
#include "trafficability/odometer.hpp"
#include "trafficability/segment_tracker.hpp"

namespace rutd {

inline constexpr const char* kDamageCsvHeader =
    "rule,depth_mm,min_length_m,max_share,measured_m,unmeasured_m,rutted_m,stretches,share,over_limit";

// Where the damage CSV of a segment CSV goes: "DIR/NAME.csv" -> "DIR/NAME.damage.csv" (else PATH.damage.csv).
std::string damage_csv_path(const std::string& segments_csv);

// The next speed sample received at or before up_to_ns, in order of receipt; false when none.
using SpeedSamplePull = std::function<bool(std::int64_t up_to_ns, SpeedSample& out)>;

class TrafficabilitySink final : public MeasurementSink {
 public:
  // downstream: not owned, outlives this. pull: empty when no speed source is configured (every frame's
  // motion is then NoSource and no segment is made). status_lag_ns: how far behind a status's time the
  // frames still to be published may have been captured (live: the pipeline's max_frame_age and a
  // margin; replay, whose statuses follow the frames' times: 0). A status drains the samples received up
  // to its time minus that lag only, so it never feeds the odometer a sample received after the capture
  // of a frame not yet published: that frame's motion is what a replay computes.
  TrafficabilitySink(MeasurementSink& downstream, SpeedSamplePull pull, const OdometerConfig& odometer,
                     const SegmentConfig& segments, std::int64_t status_lag_ns = 0);
  void publish(const PublishedFrame& frame) override;
  void publish_status(const SensorHealth& health, std::int64_t t_ns) override;
  void publish_segment(const Segment& segment) override { downstream_.publish_segment(segment); }
  // End of the run: closes the open segment and hands it on.
  void finish();

  const Odometer& odometer() const noexcept { return odometer_; }
  const SegmentTracker& tracker() const noexcept { return tracker_; }
  // The run's figures in words (for the log): distance, segments per advisory, motion, damage shares.
  std::string describe() const;
  // The damage shares as a CSV (kDamageCsvHeader, one row per configured rule), written at the end of a
  // run beside the segment CSV (damage_csv_path). False, with `error` naming the file, when it cannot be
  // written; the segments already written stay.
  bool write_damage_csv(const std::string& path, std::string& error) const;

 private:
  void take_samples(std::int64_t up_to_ns);
  MeasurementSink& downstream_;
  SpeedSamplePull pull_;
  Odometer odometer_;
  SegmentTracker tracker_;
  PublishedFrame frame_;  // the frame handed on, with its motion
  std::int64_t status_lag_ns_;
};

}  // namespace rutd
