#pragma once
// What the daemon's main thread does while the pipeline runs: tell systemd when rutd is ready, keep the
// watchdog fed only while the pipeline is alive, and publish a one-line STATUS=. Main thread only.
#include <chrono>
#include <cstdint>

#include "daemon/latest_measurement_sink.hpp"
#include "daemon/service_notifier.hpp"
#include "pipeline/realtime_pipeline.hpp"

namespace rutd {

class Supervisor {
 public:
  // stall_after: how long pairs may arrive without any being handled before the pipeline counts as
  // stalled. ready_timeout: READY=1 is sent at the first good measurement or after this long.
  Supervisor(ServiceNotifier& notifier, std::chrono::milliseconds stall_after, std::chrono::milliseconds ready_timeout);
  // Call every few tens of milliseconds (more often than half the watchdog interval). Returns false
  // while the pipeline is stalled (then no watchdog ping is sent).
  bool tick(const PipelineStats& stats, const LatestMeasurementSink& latest, std::int64_t now_ns);
  bool ready_sent() const { return ready_; }

 private:
  ServiceNotifier& notifier_;
  LivenessMonitor liveness_;
  std::int64_t ready_timeout_ns_;
  std::int64_t start_ns_ = -1, next_status_ns_ = 0;
  bool ready_ = false, alive_ = true;
};

}  // namespace rutd
