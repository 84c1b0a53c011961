#pragma once
// Soil strength from sinkage by a vehicle's own calibration: a table of sinkage (mm) against a strength
// figure (cone index or penetration resistance, kPa, as the calibration measured it; e.g. a Herrick and
// Jones style relation fitted on test lanes with a cone penetrometer beside the ruts), interpolated
// linearly. The rating is compared with the vehicle's limits, as the NATO Reference Mobility Model
// compares the rating cone index with the vehicle cone index for one pass and for 50 passes.
#include <string>
#include <vector>

namespace rutd {

struct SoilStrengthPoint {
  double sinkage_mm = 0;
  double strength = 0;
};

struct SoilStrengthConfig {
  // Sinkage strictly increasing, strength not increasing (deeper ruts, weaker soil). Empty: off.
  std::vector<SoilStrengthPoint> table;
  std::string quantity = "cone index";  // what the strength is (cone index, penetration resistance)
  std::string units = "kPa";
  std::string source;  // where the calibration comes from (vehicle, site, date, reference)
  // The vehicle's limits in the same units (0: not compared): below one_pass the vehicle is not
  // expected to complete one pass; below fifty_passes not 50 passes (CAUTION).
  double limit_one_pass = 0;
  double limit_fifty_passes = 0;
};

// Empty if `config` is usable, else what is wrong, naming the field under `key` (for the loader).
std::string check_soil_strength_config(const SoilStrengthConfig& config, const std::string& key);

struct SoilStrength {
  double value = 0;        // strength at the sinkage
  double uncertainty = 0;  // standard uncertainty: |d strength / d sinkage| * u(sinkage)
  bool clamped = false;    // the sinkage lies outside the table: the value is the table's end (a bound)
};

// Interpolates `table` (non-empty, checked) at sinkage_mm with its standard uncertainty u_mm. Outside the
// table the end value is returned (clamped, a bound: a rut deeper than the calibration means soil no
// stronger than its last value), with the uncertainty of the end segment's slope.
SoilStrength soil_strength_at(const std::vector<SoilStrengthPoint>& table, double sinkage_mm, double u_mm) noexcept;

}  // namespace rutd
