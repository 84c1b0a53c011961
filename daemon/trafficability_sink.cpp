#include "daemon/trafficability_sink.hpp"

#include <fstream>
#include <utility>

#include <fmt/format.h>

namespace rutd {

TrafficabilitySink::TrafficabilitySink(MeasurementSink& downstream, SpeedSamplePull pull,
                                       const OdometerConfig& odometer, const SegmentConfig& segments,
                                       std::int64_t status_lag_ns)
    : downstream_(downstream),
      pull_(std::move(pull)),
      odometer_(odometer),
      tracker_(segments),
      status_lag_ns_(status_lag_ns) {}

void TrafficabilitySink::take_samples(std::int64_t up_to_ns) {
  if (!pull_) return;
  SpeedSample s;
  while (pull_(up_to_ns, s)) odometer_.add(s);
}

void TrafficabilitySink::publish(const PublishedFrame& frame) {
  frame_ = frame;
  if (pull_) {
    take_samples(frame.t_ns);
    frame_.motion = odometer_.motion_at(frame.t_ns);
  }
  downstream_.publish(frame_);
  if (!pull_) return;
  const std::size_t closed = tracker_.add(frame.t_ns, frame.measurement, frame_.motion, frame.position);
  for (std::size_t i = 0; i < closed; ++i) downstream_.publish_segment(tracker_.closed(i));
}

void TrafficabilitySink::publish_status(const SensorHealth& health, std::int64_t t_ns) {
  take_samples(t_ns - status_lag_ns_);  // keeps the receiver's queue short while no frame is published
  downstream_.publish_status(health, t_ns);
}

void TrafficabilitySink::finish() {
  if (!pull_) return;
  const std::size_t closed = tracker_.finish();
  for (std::size_t i = 0; i < closed; ++i) downstream_.publish_segment(tracker_.closed(i));
}

std::string TrafficabilitySink::describe() const {
  const TrackStats& t = tracker_.stats();
  const OdometerStats& o = odometer_.stats();
  std::string s = fmt::format(
      "track {:.2f} m of new ground ({:.2f} m reversed, {} speed gaps), {} segments: {} GO, {} CAUTION, {} NO_GO, "
      "{} UNKNOWN; frames {} placed, {} at rest or reversing, {} without speed",
      t.distance_m, o.reversed_m, o.gaps, t.segments, t.advisories[static_cast<int>(Advisory::Go)],
      t.advisories[static_cast<int>(Advisory::Caution)], t.advisories[static_cast<int>(Advisory::NoGo)],
      t.advisories[static_cast<int>(Advisory::Unknown)], t.placed, t.not_placed, t.no_motion);
  const RutDamage& d = tracker_.damage();
  for (std::size_t i = 0; i < d.rules().size(); ++i) {
    const RutDamageRule& r = d.rules()[i];
    const RutDamageFigures f = d.figures(i);
    s += fmt::format(
        "; {} (> {:g} mm over >= {:g} m): {:.1f} % of {:.2f} m measured ({:.2f} m rutted, {} stretches{})", r.name,
        r.depth_mm, r.min_length_m, 100 * f.share(), f.measured_m, f.rutted_m, f.stretches,
        r.max_share < 1 && f.share() > r.max_share ? fmt::format(", above the limit {:g} %", 100 * r.max_share) : "");
  }
  return s;
}

std::string damage_csv_path(const std::string& segments_csv) {
  const std::string ext = ".csv";
  const bool csv =
      segments_csv.size() > ext.size() && segments_csv.compare(segments_csv.size() - ext.size(), ext.size(), ext) == 0;
  return (csv ? segments_csv.substr(0, segments_csv.size() - ext.size()) : segments_csv) + ".damage.csv";
}

bool TrafficabilitySink::write_damage_csv(const std::string& path, std::string& error) const {
  std::ofstream out(path, std::ios::out | std::ios::trunc);
  out << kDamageCsvHeader << '\n';
  const RutDamage& d = tracker_.damage();
  for (std::size_t i = 0; i < d.rules().size(); ++i) {
    const RutDamageRule& r = d.rules()[i];
    const RutDamageFigures f = d.figures(i);
    // The rule's name is the configuration's free text: quoted, as RFC 4180 does.
    std::string name = "\"";
    for (const char ch : r.name) name += ch == '"' ? std::string("\"\"") : std::string(1, ch);
    name += '"';
    out << fmt::format("{},{:g},{:g},{:g},{:.3f},{:.3f},{:.3f},{},{:.4f},{}\n", name, r.depth_mm, r.min_length_m,
                       r.max_share, f.measured_m, f.unmeasured_m, f.rutted_m, f.stretches, f.share(),
                       r.max_share < 1 && f.share() > r.max_share ? 1 : 0);
  }
  out.flush();
  if (!out) {
    error = path + ": cannot write the damage CSV";
    return false;
  }
  return true;
}

}  // namespace rutd
