#pragma once
// The share of the track rutted beyond a depth for at least a length, as forestry guidelines count
// damage (e.g. Finnish practice: ruts deeper than 100 mm on mineral soil or 200 mm on peat over at
// least 1 m; Québec: deeper than 200 mm over at least 4 m, at most 25 % of a trail).
//
// Each measurement placed on the track covers the ground from its distance to the next placed one's.
// A stretch is a run of consecutive placed measurements that are Ok with depth_mm > depth_mm of the rule;
// it counts as rutted when its covered length is at least min_length_m. A measurement that is neither
// Ok nor NoRut (no rut is a finding: no damage) covers unmeasured ground and ends a stretch. The share
// is rutted length / measured length (ground covered by Ok or NoRut measurements).
#include <cstdint>
#include <string>
#include <vector>

#include "core/rut_measurement.hpp"

namespace rutd {

struct RutDamageRule {
  std::string name;           // e.g. "mineral soil (Finland)"
  double depth_mm = 100;      // deeper than this (strictly)
  double min_length_m = 1.0;  // over at least this length
  double max_share = 1.0;     // the guideline's limit on the share, 0..1 (1: none)
};

struct RutDamageFigures {
  double rutted_m = 0;      // length of the qualifying stretches
  double measured_m = 0;    // ground covered by Ok or NoRut measurements
  double unmeasured_m = 0;  // ground covered by refused measurements
  std::uint32_t stretches = 0;
  double share() const noexcept { return measured_m > 0 ? rutted_m / measured_m : 0.0; }
};

class RutDamage {  // not thread-safe
 public:
  explicit RutDamage(std::vector<RutDamageRule> rules);
  // One measurement placed at distance_m (increasing from call to call).
  void add(double distance_m, const RutMeasurement& m) noexcept;
  // The figures so far, with the open stretch counted if it already qualifies.
  RutDamageFigures figures(std::size_t rule) const noexcept;
  const std::vector<RutDamageRule>& rules() const noexcept { return rules_; }

 private:
  struct Run {
    RutDamageFigures done;
    double stretch_m = 0;  // open stretch
  };
  std::vector<RutDamageRule> rules_;
  std::vector<Run> runs_;
  bool have_previous_ = false;
  double previous_m_ = 0;
  RutStatus previous_status_ = RutStatus::NoMeasurement;
  double previous_depth_mm_ = 0;
};

}  // namespace rutd
