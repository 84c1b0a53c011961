#pragma once
// Where measurements go: CAN, the candump log, the measurement CSV, plots (drivers/), the daemon's own
// bookkeeping. A sink sees a PublishedFrame, a small view of one measured pair, and never the pipeline's
// internals, so an output library needs nothing of the pipeline: `rutd run` (the real-time pipeline's
// publish stage) and `rutd replay` (a loop over a recording) feed the same sink classes.
//
// Contract: calls come from one thread at a time (the publish thread), so a sink needs no locking of its
// own; they must return promptly (they are inside the measured end-to-end latency) and must not throw (an
// exception is caught, counted as a sink error and the frame or status is lost).
#include <cstdint>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "core/cross_section.hpp"
#include "core/rut_measurement.hpp"
#include "core/sensor_health.hpp"
#include "core/stereo_frame.hpp"
#include "core/track.hpp"

namespace rutd {

// Thread time of each stage of one measurement, ms (see the measurer's diagnostics).
struct StageTimes {
  double rectify_ms = 0, band_ms = 0, disparity_ms = 0, dic_ms = 0, reproject_ms = 0, rut_ms = 0;
};

// One published pair. The figures are values; the detail below them points into the publisher's buffers
// (not owned, valid only during the call: the slot is recycled right after) and is null where the
// publisher has none (a pair refused before it was measured). Images and rows are in the measurer's
// rectification (StereoRectification, core/stereo_calibration.hpp).
struct PublishedFrame {
  std::uint64_t seq = 0;  // the source's sequence number
  std::int64_t t_ns = 0;  // capture time, ns, on `clock`
  ClockKind clock = ClockKind::Monotonic;
  std::int64_t skew_ns = 0;    // right capture time minus left (StereoFrame::skew_ns); 0: synchronised or unknown
  RutMeasurement measurement;  // whatever its status
  SensorHealth health;         // the publisher's view at this moment (RealtimePipeline::health())
  VehicleMotion motion;        // speed and distance at capture time (NoSource without a speed source)
  GeoFix position;             // the latest fix at capture time (Mode::None without a positioning source)

  const cv::Mat* left_raw = nullptr;  // the raw camera images as acquired, CV_8UC1 or CV_16UC1
  const cv::Mat* right_raw = nullptr;
  // The rectified strips, CV_8UC1, rectified width x rows from strip_row0 (the measured rows and the
  // margin matched around them).
  const cv::Mat* left_strip = nullptr;
  const cv::Mat* right_strip = nullptr;
  int strip_row0 = 0;  // rectified row of the strips' (and the disparity's) first row
  // The rectified rows the cross-section averages along the travel direction, inside the strip.
  int measured_row0 = 0, measured_rows = 0;
  const cv::Mat* disparity = nullptr;     // refined disparity, CV_32FC1 px, NaN invalid; rows as the strips
  const CrossSection* section = nullptr;  // the cross-section measured
  const RutGeometry* geometry = nullptr;  // where the rut lies on it
  StageTimes times;
};

class MeasurementSink {
 public:
  virtual ~MeasurementSink() = default;
  // One measured pair (whatever its status).
  virtual void publish(const PublishedFrame& frame) = 0;
  // The periodic status, sent every status period even when no measurement arrives. t_ns: the time of
  // the status on the publisher's clock (CLOCK_MONOTONIC live; the recording's clock in replay). Sinks
  // that know more (CAN transmit drops, bus off, recording errors) set those flags in their own copy
  // before encoding.
  virtual void publish_status(const SensorHealth& health, std::int64_t t_ns) = 0;
  // A segment of the track closed (core/track.hpp), after the publish() of the frame that closed it.
  // Sinks that do not report segments ignore it.
  virtual void publish_segment(const Segment& segment) { (void)segment; }
};

// Fans one publish out to several sinks, in order. Holds non-owning pointers; the sinks must outlive it.
class SinkFanout : public MeasurementSink {
 public:
  explicit SinkFanout(std::vector<MeasurementSink*> sinks) : sinks_(std::move(sinks)) {}
  void publish(const PublishedFrame& frame) override {
    for (MeasurementSink* s : sinks_) s->publish(frame);
  }
  void publish_status(const SensorHealth& health, std::int64_t t_ns) override {
    for (MeasurementSink* s : sinks_) s->publish_status(health, t_ns);
  }
  void publish_segment(const Segment& segment) override {
    for (MeasurementSink* s : sinks_) s->publish_segment(segment);
  }

 private:
  std::vector<MeasurementSink*> sinks_;
};

}  // namespace rutd
