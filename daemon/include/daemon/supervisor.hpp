#pragma once
// What the daemon's main thread does while the pipeline runs: tell systemd when rutd is ready, feed the
// watchdog from READY=1 on and only while the pipeline is alive, report when no measurement comes out,
// and publish a one-line STATUS=. Main thread only.
//
// Watchdog contract (the unit's WatchdogSec=):
// - No WATCHDOG=1 before READY=1. systemd arms the watchdog at the first ping even while the unit is
//   still activating, so an early ping would let a slow start (cameras negotiating, first pairs taking
//   seconds on a loaded machine) be killed as a hang; until READY=1 only TimeoutStartSec= applies.
// - From READY=1 on, a ping every tick while LivenessMonitor says alive: a stage that hangs (pairs arrive,
//   none is handled) or a publish thread whose status messages stop ends the pings, and systemd kills
//   and restarts rutd.
// - A lost camera, and pairs that are all dropped or refused as stale, keep the pings going: a restart
//   cannot bring a camera back sooner than the driver's reconnection, nor make a pipeline that is too
//   slow for its frames faster, and a restart loop ends in systemd's start limit with no status frame
//   on the bus at all. Such a sensor must not be silently useless instead: the status frame says so
//   (NoCamera or StaleFrames, and NO_MEASUREMENT as the latest status, see NoOutputStatusSink), STATUS=
//   says so, and the journal gets one line when output stops and one when it resumes.
#include <chrono>
#include <cstdint>

#include "daemon/latest_measurement_sink.hpp"
#include "daemon/service_notifier.hpp"
#include "runtime/realtime_pipeline.hpp"

namespace rutd {

class Supervisor {
 public:
  // stall_after: how long pairs may arrive without any being handled before the pipeline counts as
  // stalled. ready_timeout: READY=1 is sent at the first good measurement or after this long.
  // no_output_after: how long without a published measurement before rutd reports that it has no output.
  Supervisor(ServiceNotifier& notifier, std::chrono::milliseconds stall_after, std::chrono::milliseconds ready_timeout,
             std::chrono::milliseconds no_output_after = std::chrono::seconds(5));
  // Call every few tens of milliseconds (more often than half the watchdog interval). Returns false
  // while the pipeline is stalled (then no watchdog ping is sent; none is sent before READY=1 either).
  bool tick(const PipelineStats& stats, const LatestMeasurementSink& latest, std::int64_t now_ns);
  bool ready_sent() const { return ready_; }
  // True while no measurement has been published for no_output_after (none at all since start counts
  // from the first tick).
  bool without_output() const { return without_output_; }

 private:
  ServiceNotifier& notifier_;
  LivenessMonitor liveness_;
  std::int64_t ready_timeout_ns_, no_output_after_ns_;
  std::int64_t start_ns_ = -1, next_status_ns_ = 0;
  std::uint64_t published_ = 0, acquired_at_output_ = 0, stale_at_output_ = 0;
  std::int64_t published_at_ns_ = 0;
  bool ready_ = false, alive_ = true, without_output_ = false;
};

}  // namespace rutd
