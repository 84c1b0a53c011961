#pragma once
// The uplink's messages as JSON (docs/uplink.md, docs/uplink.schema.json: schema "rutd-uplink/1"). Pure:
// no I/O. Each function writes the members of the message's JSON object after its "id" (which the
// outbox adds once the message has one), without braces: `"schema":"rutd-uplink/1","type":...`.
// Units are in the member names (_m, _mm, _mm2, _deg, _s, _hz); a value that is not known is null.
#include <cstdint>
#include <string>

#include "core/sensor_health.hpp"
#include "core/track.hpp"

namespace rutd {

inline constexpr const char* kUplinkSchema = "rutd-uplink/1";

// Per second of measurements without a known speed (no speed source, or the speed not OK): no segment
// can place them, so the uplink summarises them by time.
struct SecondSummary {
  std::int64_t start_unix_ns = 0;  // the second's start, UTC
  std::uint32_t frames = 0, ok = 0;
  double mean_depth_mm = 0, max_depth_mm = 0;  // over the OK frames (NaN when none)
  RutStatus worst_status = RutStatus::NoMeasurement;
  SpeedState speed = SpeedState::NoSource;
  GeoFix position;  // the last frame's
};

// What the uplink says of itself in health messages (and on CAN).
struct UplinkHealth {
  bool link_up = false;
  std::uint64_t queued = 0, queued_bytes = 0;
  double oldest_unsent_s = 0;  // age of the oldest queued message
  std::uint64_t sent = 0, acknowledged = 0, send_errors = 0, connect_failures = 0;
  std::uint64_t dropped_oldest = 0, queue_errors = 0, not_queued = 0;
};

// The health in words, for the log: "link up, 3 queued (1.2 kB, oldest 0.4 s), 120 sent, ...".
std::string describe(const UplinkHealth& h);

// `created_unix_ns`: when rutd made the message (UTC). `vehicle`: UplinkConfig::vehicle.
std::string uplink_segment_json(const Segment& s, const std::string& vehicle, std::int64_t created_unix_ns);
std::string uplink_second_json(const SecondSummary& s, const std::string& vehicle, std::int64_t created_unix_ns);
std::string uplink_health_json(const SensorHealth& h, const UplinkHealth& u, const std::string& vehicle,
                               std::int64_t created_unix_ns);
// The retained status message (not queued, no id): "online" on connection, "offline" as the last will.
std::string uplink_status_json(bool online, const std::string& vehicle, const std::string& software);

}  // namespace rutd
