#include "daemon/service_notifier.hpp"

#include <cstdlib>

#include <systemd/sd-daemon.h>

namespace rutd {

bool LivenessMonitor::update(std::uint64_t acquired, std::uint64_t handled, std::uint64_t status_sent,
                             std::int64_t now_ns) {
  if (!started_) {
    started_ = true;
    acquired_ = acquired;
    handled_ = handled;
    status_sent_ = status_sent;
    handled_at_ns_ = status_at_ns_ = now_ns;
    return true;
  }
  if (handled != handled_) {
    handled_ = handled;
    handled_at_ns_ = now_ns;
    acquired_since_handled_ = false;
  }
  if (acquired != acquired_) {
    acquired_ = acquired;
    acquired_since_handled_ = true;
  }
  if (status_sent != status_sent_) {
    status_sent_ = status_sent;
    status_at_ns_ = now_ns;
  }
  const bool stage_hung = acquired_since_handled_ && now_ns - handled_at_ns_ > stall_after_ns_;
  const bool publisher_hung = now_ns - status_at_ns_ > stall_after_ns_;
  return !stage_hung && !publisher_hung;
}

ServiceNotifier::ServiceNotifier() {
  under_systemd_ = std::getenv("NOTIFY_SOCKET") != nullptr;
  std::uint64_t usec = 0;
  if (sd_watchdog_enabled(0, &usec) > 0) watchdog_ = std::chrono::microseconds(usec);
}

void ServiceNotifier::ready() {
  if (under_systemd_) sd_notify(0, "READY=1");
}

void ServiceNotifier::stopping() {
  if (under_systemd_) sd_notify(0, "STOPPING=1");
}

void ServiceNotifier::status(const std::string& text) {
  if (under_systemd_) sd_notify(0, ("STATUS=" + text).c_str());
}

void ServiceNotifier::watchdog_ping() {
  if (under_systemd_ && watchdog_.count() > 0) sd_notify(0, "WATCHDOG=1");
}

}  // namespace rutd
