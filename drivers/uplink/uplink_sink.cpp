#include "uplink/uplink_sink.hpp"

#include <algorithm>
#include <cmath>

#include "core/monotonic_clock.hpp"

namespace rutd {
namespace {

constexpr std::int64_t kSecondNs = 1'000'000'000;

}  // namespace

UplinkSink::UplinkSink(Uplink& uplink, std::function<std::int64_t()> unix_now)
    : uplink_(uplink), unix_now_(unix_now ? std::move(unix_now) : std::function<std::int64_t()>(unix_now_ns)) {}

void UplinkSink::flush_second(std::int64_t now_unix_ns) {
  if (second_.frames == 0 || now_unix_ns < second_.start_unix_ns + kSecondNs) return;
  if (second_.ok > 0) second_.mean_depth_mm = depth_sum_ / second_.ok;
  uplink_.post(UplinkTopic::Second, uplink_second_json(second_, uplink_.config().vehicle, now_unix_ns), now_unix_ns);
  second_ = SecondSummary{};
  depth_sum_ = 0;
}

void UplinkSink::publish(const PublishedFrame& frame) {
  if (frame.motion.state == SpeedState::Ok) return;  // placed on the track: its segment carries it
  const std::int64_t now = unix_now_();
  flush_second(now);
  if (second_.frames == 0) {
    second_.start_unix_ns = now - now % kSecondNs;
    second_.worst_status = frame.measurement.status;
    second_.max_depth_mm = NAN;
  }
  ++second_.frames;
  const RutMeasurement& m = frame.measurement;
  if (m.status == RutStatus::Ok && std::isfinite(m.depth_mm)) {
    ++second_.ok;
    depth_sum_ += m.depth_mm;
    second_.max_depth_mm = second_.ok == 1 ? m.depth_mm : std::max(second_.max_depth_mm, m.depth_mm);
  }
  if (status_severity(m.status) > status_severity(second_.worst_status)) second_.worst_status = m.status;
  second_.speed = frame.motion.state;
  second_.position = frame.position;
}

void UplinkSink::publish_status(const SensorHealth& health, std::int64_t t_ns) {
  (void)t_ns;  // the uplink speaks UTC
  const std::int64_t now = unix_now_();
  flush_second(now);  // the last second of a stretch without speed, once it is over
  if (now < next_health_unix_ns_) return;
  next_health_unix_ns_ = now + uplink_.config().health_period_s * kSecondNs;
  uplink_.post(UplinkTopic::Health, uplink_health_json(health, uplink_.health(), uplink_.config().vehicle, now), now);
}

void UplinkSink::publish_segment(const Segment& segment) {
  const std::int64_t now = unix_now_();
  uplink_.post(UplinkTopic::Segment, uplink_segment_json(segment, uplink_.config().vehicle, now), now);
}

}  // namespace rutd
