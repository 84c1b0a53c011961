#include "daemon/supervisor.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

namespace rutd {

Supervisor::Supervisor(ServiceNotifier& notifier, std::chrono::milliseconds stall_after,
                       std::chrono::milliseconds ready_timeout, std::chrono::milliseconds no_output_after)
    : notifier_(notifier),
      liveness_(stall_after),
      ready_timeout_ns_(ready_timeout.count() * 1000000),
      no_output_after_ns_(no_output_after.count() * 1000000) {}

bool Supervisor::tick(const PipelineStats& s, const LatestMeasurementSink& latest, std::int64_t now_ns) {
  if (start_ns_ < 0) start_ns_ = next_status_ns_ = published_at_ns_ = now_ns;
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
  if (alive && ready_) notifier_.watchdog_ping();
  if (alive != alive_) {
    if (alive) {
      spdlog::info("pipeline moving again{}", ready_ ? "; watchdog pings resumed" : "");
    } else {
      spdlog::error("pipeline stalled: pairs arrive but none is handled; {}",
                    ready_ ? "watchdog pings stopped" : "READY=1 waits for the start-up limit");
    }
    alive_ = alive;
  }

  if (s.published != published_) {
    published_ = s.published;
    published_at_ns_ = now_ns;
    if (without_output_) spdlog::info("measurements published again");
    without_output_ = false;
    acquired_at_output_ = s.acquired;
    stale_at_output_ = s.stale_total();
  } else if (!without_output_ && now_ns - published_at_ns_ >= no_output_after_ns_) {
    without_output_ = true;
    spdlog::warn(
        "no measurement published for {:.1f} s: {} pairs acquired, {} refused as stale since the last one; "
        "the status frame says NO_MEASUREMENT",
        (now_ns - published_at_ns_) / 1e9, s.acquired - acquired_at_output_, s.stale_total() - stale_at_output_);
  }

  if (now_ns >= next_status_ns_) {
    next_status_ns_ = now_ns + 1000000000;
    const std::string output =
        without_output_ ? fmt::format("NO OUTPUT for {:.0f} s ({}), ", (now_ns - published_at_ns_) / 1e9,
                                      s.acquired == acquired_at_output_ ? "no pairs from the cameras"
                                                                        : "every pair dropped or stale")
                        : fmt::format("depth {:.1f} mm ({}), ", latest.depth_mm(), to_string(latest.status()));
    notifier_.status(fmt::format("{}{:.1f} Hz in, {:.1f} Hz out, {} dropped, {} stale", output, s.acquire_hz,
                                 s.publish_hz, s.dropped_total(), s.stale_total()));
  }
  return alive;
}

}  // namespace rutd
