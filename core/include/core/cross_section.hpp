#pragma once
// The rut as a picture, beside its figures (core/rut_measurement.hpp): the lateral cross-section the rut
// extraction measured (rut/extract.hpp fills both) and where on it the rut lies: the ground line, the
// rut's edges, the deepest point, the piles. What a sink needs to draw or describe the rut (a plot, a
// live view) without the rut extraction. Millimetres, left rectified camera frame: X across the rut,
// Z distance from the camera.
#include <cmath>
#include <vector>

namespace rutd {

// Z(X) on a regular X grid, left rectified camera frame, mm.
struct CrossSection {
  double x0_mm = 0.0;        // X of bin 0 centre; always a multiple of dx_mm
  double dx_mm = 1.0;        // bin width
  std::vector<double> z_mm;  // robust mean Z of each bin; NaN where the bin had no valid point
  std::vector<int> count;    // valid points averaged into each bin
  // Along travel: the strip's rows see the ground at Y = (row - cy) Z / f, so a point of the rut's bottom
  // lies further along Y than the ground on the same row, by (row - cy) depth / f. Where the ground slopes
  // along Y (the rig pitched against it), the bottom is read that much deeper or shallower: heights
  // above or below the ground on this section are read (1 - along_slope * ray_elevation) times too
  // large (about 1 % per degree of pitch a quarter of the image off the principal row; nothing where
  // the strip straddles it). extract_rut takes it out of its figures.
  double along_slope = 0.0;    // dZ/dY of the surface seen (median over bins); 0 where unknown
  double ray_elevation = 0.0;  // mean Y / Z of the points: the strip's mean row, (row - cy) / f
  // Storage reused by reduce_to_cross_section between frames; contents unspecified.
  std::vector<float> scratch_z;
  std::vector<float> scratch_y;
  std::vector<double> scratch_slope;
  std::vector<int> scratch_offset;
};

// Where the rut extraction (extract_rut) found the rut on the cross-section (same frame and units). Each
// part is valid only when its flag is set: the line once the ground was fitted (any status but
// TooFewPoints and NoGround), the rest once a rut opening was found (Ok, NoRut, RutAtEdge after the
// ground fit). Plain values: copying it allocates nothing.
struct RutGeometry {
  bool has_line = false;
  double line_m = 0.0, line_c = 0.0;  // ground line Z = m X + c
  bool has_rut = false;
  // The deepest point: at X deepest_x_mm, depth_mm below the line measured perpendicular to it, so at
  // Z = m X + c + depth_mm * sqrt(1 + m^2).
  double deepest_x_mm = 0.0;
  double left_x_mm = 0.0, right_x_mm = 0.0;  // the ground-line crossings that define width_mm
  // X of each pile's top; NaN where the pile is reported as 0.
  double left_pile_x_mm = 0.0, right_pile_x_mm = 0.0;
  // Scatter of the raw bins about the local fit (robust sigma, mm): the profile's roughness; valid
  // whenever the status is not TooFewPoints.
  double roughness_mm = 0.0;
  // How much deeper than the depth the rut could be where it was not seen (gaps inside the opening
  // whose walls still descend into them; see extract_rut's coverage term), mm; valid with has_rut.
  double unseen_depth_mm = 0.0;
  // The same bound as the depth uncertainty counts it: unseen_depth_mm, or less where a second reading
  // with wider windows saw into the gaps (extract_rut's gap_fill), mm; valid with has_rut.
  double unseen_bound_mm = 0.0;
  // Standing water found in the rut (a level waterline on both walls): the surface's depth below the
  // ground line and the X of the two waterlines; refracted: the depth was read through the water, on
  // the section corrected for refraction at the surface (the section a sink sees is that one).
  bool has_water = false;
  double water_level_mm = 0.0;
  double waterline_left_x_mm = 0.0, waterline_right_x_mm = 0.0;
  bool refracted = false;
};

// Z of the deepest point, depth_mm below the ground line measured perpendicular to it (see RutGeometry);
// valid where g.has_rut.
inline double deepest_z_mm(const RutGeometry& g, double depth_mm) {
  return g.line_m * g.deepest_x_mm + g.line_c + depth_mm * std::sqrt(1 + g.line_m * g.line_m);
}

}  // namespace rutd
