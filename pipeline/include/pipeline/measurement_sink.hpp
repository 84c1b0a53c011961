#pragma once
// Where the real-time pipeline's publish stage hands its results: CAN, candump log, CSV (the daemon
// implements them). Every call comes from the publish thread only, so a sink needs no locking of its
// own; calls must return promptly (they are inside the measured end-to-end latency) and must not throw
// (an exception is caught, counted as a sink error and the frame or status is lost).
#include <cstdint>
#include <vector>

#include "core/sensor_health.hpp"
#include "pipeline/measurer.hpp"

namespace rutd {

class MeasurementSink {
 public:
  virtual ~MeasurementSink() = default;
  // One measured pair: work.frame (seq, t_ns, clock) and work.measurement (whatever its status).
  // `health` is the pipeline's view at this moment (see RealtimePipeline::health()). The reference is
  // valid only during the call: the slot is recycled right after.
  virtual void publish(const FrameWork& work, const SensorHealth& health) = 0;
  // The periodic status, sent at PipelineConfig::status_period even when no measurement arrives.
  // t_ns: CLOCK_MONOTONIC. Sinks that know more (CAN transmit drops, bus off, recording errors) set
  // those flags in their own copy before encoding.
  virtual void publish_status(const SensorHealth& health, std::int64_t t_ns) = 0;
};

// Fans one publish out to several sinks, in order. Holds non-owning pointers; the sinks must outlive it.
class SinkFanout : public MeasurementSink {
 public:
  explicit SinkFanout(std::vector<MeasurementSink*> sinks) : sinks_(std::move(sinks)) {}
  void publish(const FrameWork& work, const SensorHealth& health) override {
    for (MeasurementSink* s : sinks_) s->publish(work, health);
  }
  void publish_status(const SensorHealth& health, std::int64_t t_ns) override {
    for (MeasurementSink* s : sinks_) s->publish_status(health, t_ns);
  }

 private:
  std::vector<MeasurementSink*> sinks_;
};

}  // namespace rutd
