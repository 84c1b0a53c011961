#pragma once
// systemd integration (Type=notify): READY=1, STATUS=, STOPPING=1 and WATCHDOG=1 (when to ping is the
// Supervisor's contract, daemon/supervisor.hpp). Inert when the process was not started by systemd (no
// NOTIFY_SOCKET).
// Called from the daemon's main thread only.
#include <chrono>
#include <cstdint>
#include <string>

namespace rutd {

// Decides whether the pipeline is alive, from counters sampled at each tick. A stage that hangs shows as
// pairs still being acquired while none is handled any more (published, dropped or refused as stale);
// that, or a publish thread whose periodic status message stopped, is a stall. A lost camera is not a
// stall (nothing is acquired, the status message says so and the daemon waits for the camera), nor is a
// pipeline too slow for its frames (they are handled: dropped or refused), so systemd does not restart
// rutd for either.
class LivenessMonitor {
 public:
  explicit LivenessMonitor(std::chrono::milliseconds stall_after) : stall_after_ns_(stall_after.count() * 1000000) {}
  // acquired/handled/status_sent: the pipeline's monotonic counters; now_ns: CLOCK_MONOTONIC.
  // Returns true while alive.
  bool update(std::uint64_t acquired, std::uint64_t handled, std::uint64_t status_sent, std::int64_t now_ns);

 private:
  std::int64_t stall_after_ns_;
  bool started_ = false;
  std::uint64_t acquired_ = 0, handled_ = 0, status_sent_ = 0;
  std::int64_t handled_at_ns_ = 0, status_at_ns_ = 0;
  bool acquired_since_handled_ = false;
};

class ServiceNotifier {
 public:
  ServiceNotifier();
  // The watchdog interval systemd asked for (WatchdogSec=); zero when there is no watchdog.
  std::chrono::microseconds watchdog_interval() const { return watchdog_; }
  void ready();
  void stopping();
  void status(const std::string& text);
  void watchdog_ping();

 private:
  bool under_systemd_ = false;
  std::chrono::microseconds watchdog_{0};
};

}  // namespace rutd
