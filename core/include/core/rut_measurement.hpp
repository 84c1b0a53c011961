#pragma once
// The result of one rut measurement (DESIGN.md §5) and the definitions every producer of a truth
// (the synthetic renderer) and every consumer (CSV, CAN) share. All lengths in millimetres, in the
// left rectified camera frame: X lateral (across the rut), Y along travel, Z distance from the camera.
//
// Definitions, with the ground line Z = m X + c fitted to undisturbed ground outside the piles and all
// heights measured perpendicular to that line (positive = towards the camera):
//   depth_mm          largest distance below the ground line of the cross-section between the piles
//   width_mm          distance along the ground line between the two points where the cross-section
//                     crosses the ground line, walking outwards from the deepest point (the rut opening)
//   left_pile_mm      largest height above the ground line on the side of smaller X (0 if none)
//   right_pile_mm     the same on the side of larger X
//   area_mm2          area enclosed between the ground line and the cross-section below it, between the
//                     two crossings that define width_mm
//   ground_slope_deg  atan(m) in degrees: the ground line's tilt in the X-Z plane (roll plus camera tilt)
//   center_x_mm       X of the midpoint between the two crossings (lateral position of the rut)
//   quality           0..1, from the depth's estimated standard uncertainty u (depth_uncertainty_mm):
//                     quality = 1 - u / (2 * RutConfig::max_depth_uncertainty_mm), clamped: 1 = no
//                     uncertainty, 0.5 = at the configured limit (a depth above it is not Ok)
#include <cstdint>
#include <limits>
#include <string_view>

namespace rutd {

// Stable numeric values: they travel on the CAN bus (config/rutd.dbc value table) and in CSV files.
enum class RutStatus : std::uint8_t {
  Ok = 0,             // all fields valid
  NoRut = 1,          // enough ground seen but no rut between two piles within the expected width range
  TooFewPoints = 2,   // too little of the cross-section has valid 3D points to decide
  NoGround = 3,       // no undisturbed ground outside the piles to fit the ground line to
  RutAtEdge = 4,      // the rut reaches the edge of the field of view: the figure would be unreliable
  NoMeasurement = 5,  // no frame could be measured (no image pair, disparity failed, ...)
  // A depth may have been computed but is not published: the images show a condition under which it
  // would be wrong (RutCondition says which; several may hold, the status names the first in this order).
  LensObstructed = 6,    // one camera's strip (or both) dark, flat or unlike the other's over a large part
  BadExposure = 7,       // the strip is too dark (low light) or saturated (overexposed) to match reliably
  CalibrationDrift = 8,  // matched features drift off the epipolar lines: the calibration no longer fits
  BottomNotSeen = 9,     // standing water or another flat textureless patch where the rut bottom should be
  Vegetation = 10,       // the profile is rough at scales that soil is not (grass above the soil)
  Uncertain = 11,        // the estimated depth uncertainty exceeds RutConfig::max_depth_uncertainty_mm, or
                         // the rut was seen only in fragments too sparse to give a depth at all
  // The two cameras exposed too far apart (free-running, StereoFrame::skew_ns): the vehicle moved between
  // them and the right view is shifted off the epipolar lines by that motion, not by the calibration.
  Unsynchronised = 12,
};
inline constexpr int kRutStatusCount = 13;

// Conditions seen on one frame, one bit each (RutMeasurement::conditions; the CAN frame RutConditions
// carries them in this order, config/rutd.dbc). They are reported whatever the status.
enum RutCondition : std::uint8_t {
  kConditionWater = 1U << 0,             // flat textureless patch inside the rut / bottom not seen
  kConditionLeftObstructed = 1U << 1,    // the left lens is (partly) obstructed
  kConditionRightObstructed = 1U << 2,   // the right lens is (partly) obstructed
  kConditionLowLight = 1U << 3,          // strip too dark
  kConditionOverexposed = 1U << 4,       // strip saturated
  kConditionVegetation = 1U << 5,        // vegetation above the soil
  kConditionCalibrationDrift = 1U << 6,  // vertical disparity above the limit
  kConditionUncertain = 1U << 7,         // depth uncertainty above the limit
};

std::string_view to_string(RutStatus status) noexcept;

// The order of "least trustworthy" for "the worst status of" a stretch (higher: worse): OK first, NO_RUT
// (a finding), then the statuses whose depth was computed but not trusted, then those where the scene
// could not be measured at all. A value outside RutStatus ranks worst.
int status_severity(RutStatus status) noexcept;

struct RutMeasurement {
  RutStatus status = RutStatus::NoMeasurement;
  double depth_mm = 0.0;
  double width_mm = 0.0;
  double left_pile_mm = 0.0;
  double right_pile_mm = 0.0;
  double area_mm2 = 0.0;
  double ground_slope_deg = 0.0;
  double center_x_mm = 0.0;
  double quality = 0.0;
  double valid_fraction = 0.0;  // fraction of cross-section bins with valid points, 0..1
  // Estimated standard uncertainty of depth_mm (see rut/extract.hpp), mm; NaN when no depth was found.
  double depth_uncertainty_mm = std::numeric_limits<double>::quiet_NaN();
  // The part of depth_uncertainty_mm (mm, at most it) that the rut's shape, not the stereo noise, gives:
  // what gaps leave unseen, the selection at a gap's edge, the fit across fragments. Strips and frames over
  // the same rut share it, so averaging them does not shrink it (StereoMeasurer::read_strips_together).
  double depth_systematic_mm = 0.0;
  // Largest vertical offset of the right strip's features against the left's over the blocks measured,
  // px (near 0 for a calibration that fits); NaN when it could not be measured.
  double vertical_disparity_px = std::numeric_limits<double>::quiet_NaN();
  // Fraction of the strip's column blocks in which that camera is obstructed, 0..1.
  double obstructed_left = 0.0;
  double obstructed_right = 0.0;
  std::uint8_t conditions = 0;  // RutCondition bits
};

}  // namespace rutd
