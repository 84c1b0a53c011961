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
//   quality           0..1: how much to trust the figure (coverage of the strip, fit residuals)
#include <cstdint>
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
};

std::string_view to_string(RutStatus status) noexcept;

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
};

}  // namespace rutd
