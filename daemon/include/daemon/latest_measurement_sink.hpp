#pragma once
// The latest published figures, for systemd's STATUS= line and the start-up READY=1. publish() runs on
// the pipeline's publish thread; the getters are read by the main thread (relaxed atomics: each figure
// is read whole, the set of them need not be consistent).
#include <atomic>
#include <cstdint>

#include "core/measurement_sink.hpp"

namespace rutd {

// The latest published figures, for systemd's STATUS= line and the start-up READY=1.
class LatestMeasurementSink final : public MeasurementSink {
 public:
  void publish(const PublishedFrame& frame) override {
    depth_mm_.store(frame.measurement.depth_mm, std::memory_order_relaxed);
    status_.store(static_cast<std::uint8_t>(frame.measurement.status), std::memory_order_relaxed);
    if (frame.measurement.status == RutStatus::Ok) good_.fetch_add(1, std::memory_order_relaxed);
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
