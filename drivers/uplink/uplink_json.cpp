#include "uplink/uplink_json.hpp"

#include <cmath>
#include <ctime>

#include <fmt/format.h>

namespace rutd {
namespace {

std::string num(double v, int decimals) { return std::isfinite(v) ? fmt::format("{:.{}f}", v, decimals) : "null"; }

// ISO 8601 UTC with milliseconds: 2026-11-27T04:18:04.123Z.
std::string utc_text(std::int64_t unix_ns) {
  const std::time_t s = static_cast<std::time_t>(unix_ns / 1'000'000'000);
  std::tm tm{};
  gmtime_r(&s, &tm);
  return fmt::format("{:04}-{:02}-{:02}T{:02}:{:02}:{:02}.{:03}Z", tm.tm_year + 1900, tm.tm_mon + 1, tm.tm_mday,
                     tm.tm_hour, tm.tm_min, tm.tm_sec, (unix_ns / 1'000'000) % 1000);
}

std::string head(const char* type, const std::string& vehicle, std::int64_t created_unix_ns) {
  return fmt::format(R"("schema":"{}","type":"{}","vehicle":"{}","created":"{}")", kUplinkSchema, type, vehicle,
                     utc_text(created_unix_ns));
}

std::string position_json(const GeoFix& p) {
  if (!p.valid()) return "null";
  return fmt::format(R"({{"latitude_deg":{},"longitude_deg":{},"horizontal_error_m":{},"heading_deg":{}}})",
                     num(p.latitude_deg, 9), num(p.longitude_deg, 9), num(p.horizontal_error_m, 2),
                     num(p.heading_deg, 1));
}

}  // namespace

std::string uplink_segment_json(const Segment& s, const std::string& vehicle, std::int64_t created_unix_ns) {
  return head("segment", vehicle, created_unix_ns) +
         fmt::format(
             R"(,"index":{},"start_m":{},"end_m":{},"frames":{},"refused":{},"mean_depth_mm":{},"max_depth_mm":{},)"
             R"("p95_depth_mm":{},"depth_uncertainty_mm":{},"mean_width_mm":{},"mean_area_mm2":{},"worst_status":"{}",)"
             R"("soil_strength":{},"soil_strength_uncertainty":{},"advisory":"{}","position":{})",
             s.index, num(s.start_m, 3), num(s.end_m, 3), s.frames, s.refused, num(s.mean_depth_mm, 2),
             num(s.max_depth_mm, 2), num(s.p95_depth_mm, 2), num(s.depth_uncertainty_mm, 2), num(s.mean_width_mm, 2),
             num(s.mean_area_mm2, 0), to_string(s.worst_status), num(s.soil_strength, 1),
             num(s.soil_strength_uncertainty, 1), to_string(s.advisory), position_json(s.position));
}

std::string uplink_second_json(const SecondSummary& s, const std::string& vehicle, std::int64_t created_unix_ns) {
  return head("second", vehicle, created_unix_ns) +
         fmt::format(R"(,"start":"{}","frames":{},"ok":{},"mean_depth_mm":{},"max_depth_mm":{},"worst_status":"{}",)"
                     R"("speed_state":"{}","position":{})",
                     utc_text(s.start_unix_ns), s.frames, s.ok, num(s.ok ? s.mean_depth_mm : NAN, 2),
                     num(s.ok ? s.max_depth_mm : NAN, 2), to_string(s.worst_status), to_string(s.speed),
                     position_json(s.position));
}

std::string uplink_health_json(const SensorHealth& h, const UplinkHealth& u, const std::string& vehicle,
                               std::int64_t created_unix_ns) {
  return head("health", vehicle, created_unix_ns) +
         fmt::format(R"(,"sensor":{{"no_camera":{},"stale_frames":{},"calibration_invalid":{},"low_texture":{},)"
                     R"("frame_drops":{},"can_tx_drops":{},"bus_off":{},"recording_error":{},"frame_rate_hz":{},)"
                     R"("dropped_frames":{},"last_status":"{}"}},)"
                     R"("uplink":{{"link":"{}","queued":{},"queued_bytes":{},"oldest_unsent_s":{},"sent":{},)"
                     R"("acknowledged":{},"send_errors":{},"connect_failures":{},"dropped_oldest":{},)"
                     R"("queue_errors":{},"not_queued":{}}})",
                     h.no_camera, h.stale_frames, h.calibration_invalid, h.low_texture, h.frame_drops, h.can_tx_drops,
                     h.bus_off, h.recording_error, num(h.frame_rate_hz, 2), h.dropped_frames, to_string(h.last_status),
                     u.link_up ? "up" : "down", u.queued, u.queued_bytes, num(u.oldest_unsent_s, 1), u.sent,
                     u.acknowledged, u.send_errors, u.connect_failures, u.dropped_oldest, u.queue_errors, u.not_queued);
}

std::string describe(const UplinkHealth& h) {
  return fmt::format(
      "link {}, {} queued ({} bytes, oldest {:.1f} s), {} sent, {} acknowledged, {} send errors, {} failed "
      "connections, {} dropped as the oldest beyond the queue's bound, {} queue write errors, {} not queued",
      h.link_up ? "up" : "down", h.queued, h.queued_bytes, h.oldest_unsent_s, h.sent, h.acknowledged, h.send_errors,
      h.connect_failures, h.dropped_oldest, h.queue_errors, h.not_queued);
}

std::string uplink_status_json(bool online, const std::string& vehicle, const std::string& software) {
  return fmt::format(R"({{"schema":"{}","type":"status","vehicle":"{}","state":"{}","software":"{}"}})", kUplinkSchema,
                     vehicle, online ? "online" : "offline", software);
}

}  // namespace rutd
