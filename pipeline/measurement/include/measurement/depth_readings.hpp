#pragma once
// Readings of one rut's depth made apart (the measured strip, its guard strips, the last frames), read
// together as one (StereoMeasurer::read_strips_together). Pure; no state.
#include <optional>
#include <span>

namespace rutd {

// A depth and its standard uncertainty u, and the part s of u (0 <= s <= u) that the rut's shape gives
// rather than the stereo noise (RutMeasurement::depth_systematic_mm), mm.
struct DepthReading {
  double depth_mm = 0.0;
  double u_mm = 0.0;
  double systematic_mm = 0.0;
};

// The readings' weighted mean (weights 1/u^2), where 2 to 7 of them agree as their uncertainties say
// (their chi-square about the mean under its 95th percentile for k - 1 degrees of freedom); nullopt
// otherwise, or for a u not positive and finite. Only the noise parts (u^2 - s^2) average out: the shape's
// parts are fully correlated between readings (the same gap beside the same wall biases every strip and
// frame over it alike), so the mean's is their weighted mean. Readings that scatter more than their
// uncertainties say (Birge's ratio, chi2 / (k - 1), above 1) widen the mean's noise part by that ratio.
// The result's u and s are the mean's.
std::optional<DepthReading> combine_depth_readings(std::span<const DepthReading> readings);

}  // namespace rutd
