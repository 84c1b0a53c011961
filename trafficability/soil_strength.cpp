#include "trafficability/soil_strength.hpp"

#include <algorithm>
#include <cmath>

namespace rutd {

std::string check_soil_strength_config(const SoilStrengthConfig& c, const std::string& key) {
  if (c.table.empty()) return {};
  if (c.table.size() < 2) return key + ".table: needs at least two points (sinkage_mm, strength)";
  for (std::size_t i = 0; i < c.table.size(); ++i) {
    const SoilStrengthPoint& p = c.table[i];
    if (!std::isfinite(p.sinkage_mm) || !std::isfinite(p.strength) || p.sinkage_mm < 0 || p.strength < 0)
      return key + ".table[" + std::to_string(i) + "]: sinkage and strength must be finite and >= 0";
    if (i > 0 && p.sinkage_mm <= c.table[i - 1].sinkage_mm)
      return key + ".table[" + std::to_string(i) + "]: sinkage must increase from point to point";
    if (i > 0 && p.strength > c.table[i - 1].strength)
      return key + ".table[" + std::to_string(i) + "]: strength must not increase with sinkage";
  }
  if (c.units.empty()) return key + ".units: name the units of the strength (e.g. kPa)";
  if (c.source.empty()) return key + ".source: name where the calibration comes from";
  if (!(c.limit_one_pass >= 0) || !(c.limit_fifty_passes >= 0) ||
      (c.limit_fifty_passes > 0 && c.limit_fifty_passes < c.limit_one_pass))
    return key + ".vehicle_limit_fifty_passes: must be >= vehicle_limit_one_pass >= 0";
  return {};
}

SoilStrength soil_strength_at(const std::vector<SoilStrengthPoint>& t, double z, double u) noexcept {
  SoilStrength out;
  // The segment [i, i+1] that holds z (the first or last one outside the table).
  std::size_t i = 0;
  while (i + 2 < t.size() && z > t[i + 1].sinkage_mm) ++i;
  const SoilStrengthPoint& a = t[i];
  const SoilStrengthPoint& b = t[i + 1];
  const double slope = (b.strength - a.strength) / (b.sinkage_mm - a.sinkage_mm);
  if (z <= t.front().sinkage_mm) {
    out.value = t.front().strength;
    out.clamped = z < t.front().sinkage_mm;
  } else if (z >= t.back().sinkage_mm) {
    out.value = t.back().strength;
    out.clamped = z > t.back().sinkage_mm;
  } else {
    out.value = a.strength + slope * (z - a.sinkage_mm);
  }
  out.uncertainty = std::abs(slope) * (std::isfinite(u) ? u : 0.0);
  return out;
}

}  // namespace rutd
