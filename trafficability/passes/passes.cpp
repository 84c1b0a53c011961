#include "trafficability/passes.hpp"

#include <cmath>
#include <limits>
#include <numbers>

namespace rutd {
namespace {

constexpr double kEarthRadiusM = 6378137.0;  // WGS84 semi-major axis
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double radians(double deg) { return deg * std::numbers::pi / 180.0; }

// Smallest absolute difference of two headings, degrees in [0, 180].
double heading_difference(double a, double b) {
  const double d = std::fmod(std::abs(a - b), 360.0);
  return d > 180.0 ? 360.0 - d : d;
}

bool usable(const Segment& s) { return s.position.valid() && std::isfinite(s.position.heading_deg); }

double error_of(const Segment& s, const PassConfig& c) {
  const double e = s.position.horizontal_error_m;
  return std::isfinite(e) && e > 0.0 ? e : c.default_error_m;
}

}  // namespace

double ground_distance_m(const GeoFix& a, const GeoFix& b) {
  if (!a.valid() || !b.valid()) return kNaN;
  const double mean_lat = radians(0.5 * (a.latitude_deg + b.latitude_deg));
  const double dn = radians(b.latitude_deg - a.latitude_deg) * kEarthRadiusM;
  const double de = radians(b.longitude_deg - a.longitude_deg) * kEarthRadiusM * std::cos(mean_lat);
  return std::hypot(dn, de);
}

std::vector<SegmentMatch> match_pass(const std::vector<Segment>& earlier, const std::vector<Segment>& later,
                                     const PassConfig& config) {
  // Each later segment's best candidate: the nearest earlier one within the errors and the heading
  // tolerance.
  std::vector<SegmentMatch> candidates;
  std::vector<bool> has(later.size(), false);
  candidates.resize(later.size());
  for (std::size_t i = 0; i < later.size(); ++i) {
    const Segment& l = later[i];
    if (!usable(l)) continue;
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t j = 0; j < earlier.size(); ++j) {
      const Segment& e = earlier[j];
      if (!usable(e)) continue;
      const double dh = heading_difference(l.position.heading_deg, e.position.heading_deg);
      if (dh > config.heading_tolerance_deg) continue;
      const double d = ground_distance_m(l.position, e.position);
      const double allowed = std::hypot(error_of(l, config), error_of(e, config));
      if (d > allowed || d >= best) continue;
      best = d;
      SegmentMatch& m = candidates[i];
      m.later = i;
      m.earlier = j;
      m.distance_m = d;
      m.allowed_m = allowed;
      m.heading_difference_deg = dh;
      m.sinkage_increase_mm = l.mean_depth_mm - e.mean_depth_mm;  // NaN when either is
      m.sinkage_increase_uncertainty_mm = std::hypot(l.depth_uncertainty_mm, e.depth_uncertainty_mm);
      has[i] = true;
    }
  }
  // Keep only runs of consecutive matched later segments covering at least min_common_m.
  std::vector<SegmentMatch> kept;
  std::size_t i = 0;
  while (i < later.size()) {
    if (!has[i]) {
      ++i;
      continue;
    }
    std::size_t end = i;
    double length = 0.0;
    while (end < later.size() && has[end]) {
      length += std::abs(later[end].end_m - later[end].start_m);
      ++end;
    }
    if (length >= config.min_common_m)
      for (std::size_t k = i; k < end; ++k) kept.push_back(candidates[k]);
    i = end;
  }
  return kept;
}

PassNumbering number_passes(std::vector<std::vector<Segment>>& drives, const PassConfig& config) {
  PassNumbering result;
  result.matches.resize(drives.size());
  result.covering.resize(drives.size());
  for (std::size_t d = 0; d < drives.size(); ++d) {
    for (Segment& s : drives[d]) s.pass = 0;
    // Later earlier drives overwrite: the latest drive that covered a segment's ground is its reference.
    std::vector<SegmentMatch> best(drives[d].size());
    std::vector<std::size_t> from(drives[d].size(), drives.size());
    for (std::size_t q = 0; q < d; ++q) {
      for (const SegmentMatch& m : match_pass(drives[q], drives[d], config)) {
        best[m.later] = m;
        from[m.later] = q;
      }
    }
    for (std::size_t i = 0; i < drives[d].size(); ++i) {
      if (from[i] == drives.size()) continue;
      drives[d][i].pass = drives[from[i]][best[i].earlier].pass + 1;
      result.matches[d].push_back(best[i]);
      result.covering[d].push_back(from[i]);
    }
  }
  return result;
}

}  // namespace rutd
