#include "trafficability/segment_tracker.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace rutd {

namespace {

int severity(Advisory a) noexcept {  // for "the worst of": GO < CAUTION < NO_GO
  switch (a) {
    case Advisory::Go: return 0;
    case Advisory::Caution: return 1;
    case Advisory::NoGo: return 2;
    case Advisory::Unknown: return 1;  // inside the hysteresis window: not known to be good
  }
  return 1;
}

Advisory worst(Advisory a, Advisory b) noexcept {
  if (a == Advisory::Unknown) a = Advisory::Caution;
  if (b == Advisory::Unknown) b = Advisory::Caution;
  return severity(a) >= severity(b) ? a : b;
}

// Linear interpolation between order statistics of sorted values (numpy's default percentile).
double percentile_sorted(const std::vector<double>& v, double q) noexcept {
  const double pos = q * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(pos));
  const std::size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (pos - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

}  // namespace

std::string check_segment_config(const SegmentConfig& c, const std::string& key) {
  if (!(c.length_m >= 0.05 && c.length_m <= 1000)) return key + ".segment_length_m: must be 0.05 .. 1000";
  const AdvisoryConfig& a = c.advisory;
  if (!(a.caution_depth_mm > 0 && a.no_go_depth_mm >= a.caution_depth_mm))
    return key + ".advisory.no_go_depth_mm: must be >= caution_depth_mm > 0";
  if (!(a.hysteresis_m >= 0 && a.hysteresis_m <= 1000)) return key + ".advisory.hysteresis_m: must be 0 .. 1000";
  if (!(a.max_untrusted_fraction >= 0 && a.max_untrusted_fraction <= 1))
    return key + ".advisory.max_untrusted_fraction: must be 0 .. 1";
  if (a.min_trusted_frames < 1) return key + ".advisory.min_trusted_frames: must be >= 1";
  if (!(a.coverage_factor >= 0 && a.coverage_factor <= 10)) return key + ".advisory.coverage_factor: must be 0 .. 10";
  for (std::size_t i = 0; i < c.damage.size(); ++i) {
    const RutDamageRule& r = c.damage[i];
    const std::string at = key + ".damage[" + std::to_string(i) + "]";
    if (!(r.depth_mm > 0)) return at + ".depth_mm: must be > 0";
    if (!(r.min_length_m >= 0)) return at + ".min_length_m: must be >= 0";
    if (!(r.max_share > 0 && r.max_share <= 1)) return at + ".max_share: must be in (0, 1]";
  }
  return check_soil_strength_config(c.soil, key + ".soil");
}

SegmentTracker::SegmentTracker(SegmentConfig config) : config_(std::move(config)), damage_(config_.damage) {
  if (const std::string e = check_segment_config(config_, "trafficability"); !e.empty()) throw std::invalid_argument(e);
  depths_.reserve(kMaxDepthsPerSegment);
  sorted_.reserve(kMaxDepthsPerSegment);
  recent_max_ = static_cast<std::size_t>(std::ceil(config_.advisory.hysteresis_m / config_.length_m)) + 2;
  recent_.reserve(recent_max_ + 1);
  closed_.resize(kMaxClosedPerCall);
}

void SegmentTracker::open_segment(std::uint64_t index) {
  open_ = Open{};
  open_.index = index;
  depths_.clear();
  have_open_ = true;
}

std::size_t SegmentTracker::add(std::int64_t t_ns, const RutMeasurement& m, const VehicleMotion& motion,
                                const GeoFix& position) {
  n_closed_ = 0;
  ++stats_.frames;
  if (motion.state != SpeedState::Ok || !std::isfinite(motion.distance_m)) {
    ++stats_.no_motion;
    if (have_open_) open_.untrusted_speed = true;
    return 0;
  }
  const double d = motion.distance_m;
  if (have_placed_ && d <= last_placed_m_) {
    ++stats_.not_placed;
    return 0;
  }
  const auto k = static_cast<std::uint64_t>(std::max(0.0, std::floor(d / config_.length_m)));
  if (have_open_ && k > open_.index) {
    const std::uint64_t next = open_.index + 1;
    close_open();
    // Segments passed over without a measurement (more than a segment between two frames).
    for (std::uint64_t skipped = next; skipped < k && n_closed_ < kMaxClosedPerCall; ++skipped) {
      open_segment(skipped);
      open_.t_start_ns = open_.t_end_ns = t_ns;
      close_open();
    }
  }
  if (!have_open_) {
    open_segment(k);
    open_.t_start_ns = t_ns;
  }
  ++stats_.placed;
  have_placed_ = true;
  last_placed_m_ = d;
  stats_.distance_m = d;
  damage_.add(d, m);

  Open& o = open_;
  ++o.frames;
  o.t_end_ns = t_ns;
  if (position.valid()) {
    const double from_middle = std::abs(d - (static_cast<double>(o.index) + 0.5) * config_.length_m);
    if (!o.fix.valid() || from_middle < o.fix_from_middle_m) {
      o.fix = position;
      o.fix_from_middle_m = from_middle;
    }
  }
  if (status_severity(m.status) > status_severity(o.worst)) o.worst = m.status;
  if (m.status == RutStatus::NoRut) ++o.no_rut;
  if (m.status == RutStatus::Ok) {
    ++o.ok;
    o.sum_depth += m.depth_mm;
    o.sum_width += m.width_mm;
    o.sum_area += m.area_mm2;
    o.max_depth = o.ok == 1 ? m.depth_mm : std::max(o.max_depth, m.depth_mm);
    if (std::isfinite(m.depth_uncertainty_mm)) {
      o.sum_u += m.depth_uncertainty_mm;
      ++o.u_count;
    }
    if (depths_.size() < kMaxDepthsPerSegment) depths_.push_back(m.depth_mm);
  }
  return n_closed_;
}

std::size_t SegmentTracker::finish() {
  n_closed_ = 0;
  if (have_open_) close_open();
  return n_closed_;
}

void SegmentTracker::close_open() {
  const Open& o = open_;
  Segment& s = closed_[n_closed_];
  s = Segment{};
  s.index = o.index;
  s.start_m = static_cast<double>(o.index) * config_.length_m;
  s.end_m = static_cast<double>(o.index + 1) * config_.length_m;
  s.t_start_ns = o.t_start_ns;
  s.t_end_ns = o.t_end_ns;
  s.frames = o.frames;
  s.refused = o.frames - o.ok;
  s.worst_status = o.frames == 0 ? RutStatus::NoMeasurement : o.worst;
  s.position = o.fix;
  if (o.ok > 0) {
    s.mean_depth_mm = o.sum_depth / o.ok;
    s.max_depth_mm = o.max_depth;
    s.mean_width_mm = o.sum_width / o.ok;
    s.mean_area_mm2 = o.sum_area / o.ok;
    if (o.u_count > 0) s.depth_uncertainty_mm = o.sum_u / o.u_count;
    sorted_.assign(depths_.begin(), depths_.end());
    std::sort(sorted_.begin(), sorted_.end());
    s.p95_depth_mm = percentile_sorted(sorted_, 0.95);
    if (!config_.soil.table.empty()) {
      const SoilStrength st = soil_strength_at(config_.soil.table, s.mean_depth_mm, s.depth_uncertainty_mm);
      s.soil_strength = st.value;
      s.soil_strength_uncertainty = st.uncertainty;
    }
  }
  const Advisory raw = raw_advisory(s, o);
  s.advisory = with_hysteresis(s, raw);
  ++stats_.segments;
  ++stats_.advisories[static_cast<std::size_t>(s.advisory)];
  ++n_closed_;
  have_open_ = false;
}

Advisory SegmentTracker::raw_advisory(const Segment& s, const Open& o) const noexcept {
  const AdvisoryConfig& a = config_.advisory;
  const std::uint32_t trusted = o.ok + o.no_rut;
  if (o.untrusted_speed || trusted < a.min_trusted_frames || o.frames == 0) return Advisory::Unknown;
  const double untrusted = static_cast<double>(o.frames - trusted) / o.frames;
  if (untrusted > a.max_untrusted_fraction) return Advisory::Unknown;
  Advisory level = Advisory::Go;
  if (o.ok > 0) {
    if (s.p95_depth_mm >= a.no_go_depth_mm) level = Advisory::NoGo;
    else if (s.p95_depth_mm >= a.caution_depth_mm) level = Advisory::Caution;
  }
  if (o.ok > 0 && !config_.soil.table.empty()) {
    const double k = a.coverage_factor;
    const double lo = s.soil_strength - k * s.soil_strength_uncertainty;
    const double hi = s.soil_strength + k * s.soil_strength_uncertainty;
    const double one = config_.soil.limit_one_pass, fifty = config_.soil.limit_fifty_passes;
    Advisory by_strength = Advisory::Go;
    if (one > 0 && hi < one) by_strength = Advisory::NoGo;
    else if ((one > 0 && lo < one) || (fifty > 0 && lo < fifty)) by_strength = Advisory::Caution;
    level = worst(level, by_strength);
  }
  return level;
}

Advisory SegmentTracker::with_hysteresis(const Segment& s, Advisory raw) noexcept {
  Advisory out = raw;
  if (raw != Advisory::Unknown) {
    for (const auto& [end_m, earlier] : recent_) {
      if (end_m > s.start_m - config_.advisory.hysteresis_m + 1e-9) out = worst(out, earlier);
    }
  }
  recent_.emplace_back(s.end_m, raw);
  if (recent_.size() > recent_max_) recent_.erase(recent_.begin());
  return out;
}

}  // namespace rutd
