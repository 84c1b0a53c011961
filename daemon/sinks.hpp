#pragma once
// The daemon's measurement sinks over the pipeline's MeasurementSink interface. All are called from the
// pipeline's publish thread only; the atomics in LatestMeasurement are read by the main thread.
#include <atomic>
#include <cstdint>
#include <iosfwd>
#include <memory>

#include "drivers/can_encoder.hpp"
#include "drivers/candump_log.hpp"
#include "drivers/frame_recorder.hpp"
#include "drivers/measurement_csv.hpp"
#include "drivers/socketcan_sink.hpp"
#include "pipeline/measurement_sink.hpp"

namespace rutd {

// CAN: every measurement and status is encoded once; each frame goes to the bus (when configured) and
// to the candump log (when configured), so the log is exactly what the bus got. With a bus, frames the
// kernel refused (full queue) are counted, reported in the status message and not logged. With a
// recorder, every status frame after the recording failed carries RecordingError = 1.
class CanPublisher final : public MeasurementSink {
 public:
  // bus, log and recorder may be null (not configured); none is owned, all must outlive the publisher.
  // log_stream is flushed per call so a reader of a pipe sees frames as they are sent. recorder is only
  // asked failed(), which is thread-safe.
  CanPublisher(const CanIdConfig& ids, SocketCanSink* bus, CandumpLogWriter* log, std::ostream* log_stream,
               const FrameRecorder* recorder = nullptr);
  void publish(const FrameWork& work, const SensorHealth& health) override;
  void publish_status(const SensorHealth& health, std::int64_t t_ns) override;

 private:
  void emit(const CanFrame& frame);

  CanEncoder encoder_;
  SocketCanSink* bus_;
  CandumpLogWriter* log_;
  std::ostream* log_stream_;
  const FrameRecorder* recorder_;
  std::array<CanFrame, 2> frames_{};
  std::uint64_t dropped_at_last_status_ = 0;
};

// The measurement CSV (DESIGN.md, Formats), flushed per line so nothing measured is lost on a crash.
class CsvSink final : public MeasurementSink {
 public:
  explicit CsvSink(std::ostream& out) : writer_(out, /*flush_each_line=*/true) {}
  void publish(const FrameWork& work, const SensorHealth&) override {
    writer_.write(work.frame.seq, work.frame.t_ns, work.measurement);
  }
  void publish_status(const SensorHealth&, std::int64_t) override {}

 private:
  MeasurementCsvWriter writer_;
};

// The latest published figures, for systemd's STATUS= line and the start-up READY=1.
class LatestMeasurement final : public MeasurementSink {
 public:
  void publish(const FrameWork& work, const SensorHealth&) override {
    depth_mm_.store(work.measurement.depth_mm, std::memory_order_relaxed);
    status_.store(static_cast<std::uint8_t>(work.measurement.status), std::memory_order_relaxed);
    if (work.measurement.status == RutStatus::Ok) good_.fetch_add(1, std::memory_order_relaxed);
  }
  void publish_status(const SensorHealth&, std::int64_t) override {}
  double depth_mm() const { return depth_mm_.load(std::memory_order_relaxed); }
  RutStatus status() const { return static_cast<RutStatus>(status_.load(std::memory_order_relaxed)); }
  std::uint64_t good_measurements() const { return good_.load(std::memory_order_relaxed); }

 private:
  std::atomic<double> depth_mm_{0.0};
  std::atomic<std::uint8_t> status_{static_cast<std::uint8_t>(RutStatus::NoMeasurement)};
  std::atomic<std::uint64_t> good_{0};
};

}  // namespace rutd
