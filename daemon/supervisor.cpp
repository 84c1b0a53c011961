#include "daemon/supervisor.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

namespace rutd {

Supervisor::Supervisor(ServiceNotifier& notifier, std::chrono::milliseconds stall_after,
                       std::chrono::milliseconds ready_timeout)
    : notifier_(notifier), liveness_(stall_after), ready_timeout_ns_(ready_timeout.count() * 1000000) {}

bool Supervisor::tick(const PipelineStats& s, const LatestMeasurementSink& latest, std::int64_t now_ns) {
  if (start_ns_ < 0) start_ns_ = next_status_ns_ = now_ns;
  if (!ready_ && (latest.good_measurements() > 0 || now_ns - start_ns_ >= ready_timeout_ns_)) {
    notifier_.ready();
    ready_ = true;
    spdlog::info("ready: {}", latest.good_measurements() > 0 ? "first good measurement published"
                                                             : "start-up time elapsed without a good measurement");
  }
  // Pairs a stage finished with. Drops at acquisition do not count: acquisition drops exactly when the
  // stages stop taking frames.
  const std::uint64_t handled = s.published + s.dropped_total() - s.dropped[static_cast<std::size_t>(Stage::Acquire)] +
                                s.stale_total() + s.rectify_rejected + s.stage_errors;
  const bool alive = liveness_.update(s.acquired, handled, s.status_sent, now_ns);
  if (alive) notifier_.watchdog_ping();
  if (alive != alive_) {
    if (alive) {
      spdlog::info("pipeline moving again; watchdog pings resumed");
    } else {
      spdlog::error("pipeline stalled: pairs arrive but none is handled; watchdog pings stopped");
    }
    alive_ = alive;
  }
  if (now_ns >= next_status_ns_) {
    next_status_ns_ = now_ns + 1000000000;
    notifier_.status(fmt::format("depth {:.1f} mm ({}), {:.1f} Hz in, {:.1f} Hz out, {} dropped, {} stale",
                                 latest.depth_mm(), to_string(latest.status()), s.acquire_hz, s.publish_hz,
                                 s.dropped_total(), s.stale_total()));
  }
  return alive;
}

}  // namespace rutd
