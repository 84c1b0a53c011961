#pragma once
// The pipeline's measurement sink for the measurement CSV (the adapter between
// pipeline/measurement_sink.hpp and recording/measurement_csv.hpp). Called from the publish thread only.
#include <ostream>

#include "pipeline/measurement_sink.hpp"
#include "recording/measurement_csv.hpp"

namespace rutd {

// The measurement CSV (DESIGN.md, Formats), flushed per line so nothing measured is lost on a crash.
class MeasurementCsvSink final : public MeasurementSink {
 public:
  explicit MeasurementCsvSink(std::ostream& out) : writer_(out, /*flush_each_line=*/true) {}
  void publish(const FrameWork& work, const SensorHealth&) override {
    writer_.write(work.frame.seq, work.frame.t_ns, work.measurement);
  }
  void publish_status(const SensorHealth&, std::int64_t) override {}

 private:
  MeasurementCsvWriter writer_;
};

}  // namespace rutd
