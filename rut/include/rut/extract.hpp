#pragma once
// Rut extraction (DESIGN.md §5): a strip of 3D points -> a lateral cross-section Z(X) -> one
// RutMeasurement whose fields follow the definitions in core/rut_measurement.hpp exactly.
//
// All lengths are millimetres in the left rectified camera frame (X across the rut, Z distance from
// the camera), so the results do not depend on image resolution. Nothing here throws or allocates on
// the per-frame path once the caller-owned CrossSection and RutWorkspace have grown to the largest
// section seen. Not thread-safe per object: use one CrossSection/RutWorkspace per thread.
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "core/cross_section.hpp"
#include "core/rut_measurement.hpp"
#include "rut/waterline.hpp"

namespace rutd {

struct RutConfig {
  double bin_mm = 1.0;          // cross-section sampling step along X
  double fit_window_mm = 25.0;  // sliding parabola window (the paper used 50 px)
  // Expected rut width range: a rut whose opening (width_mm) falls outside it is reported as NoRut.
  double min_rut_width_mm = 80.0;
  double max_rut_width_mm = 400.0;
  // A depression shallower than this (or than 6x the smoothed noise) below the ground line is not a
  // rut (NoRut).
  double min_rut_depth_mm = 3.0;
  // A pile lower than this (or lower than 5x the smoothed noise) is reported as 0: no pile.
  double min_pile_mm = 1.0;
  // A bin is undisturbed ground only if |dZ/dX - ground slope| of the local fit is below this
  // (dimensionless; raised automatically above 4x the slope noise of the fit).
  double ground_gradient_max = 0.15;
  // Undisturbed ground needed to fit the line (else NoGround): at least min_ground_mm in all, or at
  // least min_ground_each_side_mm on both sides of the rut. Ground on both sides pins the slope by the
  // lever arm between them (a rut and its piles apart), so a little on each side is enough; ground on
  // one side only must fix the slope by itself. Ground counts from a pile's outer foot on, less the
  // bins whose local fit (fit_window_mm) still sees the pile's flank, about a quarter window: the
  // honest minimum of visible ground beyond each pile is therefore about fit_window_mm / 4 +
  // min_ground_each_side_mm (12 mm at the defaults). Narrow views (80 mm baseline at 300 mm, 640 px)
  // leave 20-40 mm per side. Under noise correlated over ~10 bins (low-texture snow, 0.4 mm) 20 mm
  // per side gives depth within 0.4 mm rms, single frames within about 1.1 mm.
  double min_ground_mm = 40.0;
  double min_ground_each_side_mm = 5.0;
  // Fewer valid bins than this fraction of the section, or than two fit windows -> TooFewPoints.
  double min_valid_fraction = 0.4;
  // reduce_to_cross_section: fraction of samples dropped at each end of every bin before averaging
  // (0.25 = interquartile mean: robust to stereo outliers, ~85 % of the mean's efficiency).
  double trim_fraction = 0.25;
  // A depth whose estimated standard uncertainty (RutMeasurement::depth_uncertainty_mm, see
  // extract_rut) exceeds this is not Ok but Uncertain. 0.6 mm: the 1 mm tolerance is then 1.65
  // standard uncertainties, which a normal error exceeds on one side 5 % of the time. The estimate is
  // honest on clean rendered snow, whose correlated stereo noise is the largest (u 0.32-0.50 mm,
  // errors up to 0.42 mm), so a tighter limit refuses depths that are right; a bottom not seen
  // (coverage term) gives estimates of tens of millimetres.
  double max_depth_uncertainty_mm = 0.6;
  // Soil seen by stereo and averaged along the strip is smooth at the scale of a bin: its per-bin
  // scatter about the local parabola is the stereo noise, a few tenths of a millimetre. Grass blades
  // standing above the soil put single bins millimetres above or below their neighbours. A scatter
  // (robust sigma of raw bins about the local fit) above this is Vegetation, mm.
  double vegetation_roughness_mm = 1.5;
  // reduce_to_cross_section: the section never spans more than this; points beyond it (reprojection
  // outliers far off to the side) are dropped, which also bounds the memory a frame can claim.
  double max_section_mm = 4000.0;
};

// Scratch vectors reused between frames by extract_rut; contents unspecified, except `geometry`.
struct RutWorkspace {
  RutGeometry geometry;        // of the last extract_rut call
  std::vector<double> smooth;  // local quadratic fit value per bin (Z, mm)
  std::vector<double> slope;   // local fit dZ/dX per bin
  std::vector<double> h_raw;   // raw heights above the current ground line (mm, + = towards camera)
  std::vector<double> h_fit;   // smoothed heights above the current ground line
  std::vector<double> a;       // general scratch (residuals, fit inputs)
  std::vector<double> b;
  std::vector<double> c;
  std::vector<double> ground_x, ground_z;  // the ground bins of the last line fit
  std::vector<double> h_fill;              // gap_fill's heights above the line, on the section's grid
  // Carried from frame to frame by the one caller that measures a sequence with this workspace (the
  // extract stage; measure()): the last waterline a frame confirmed, and the last lid it found.
  WaterlineMemory last_waterline;
  LidMemory last_lid;
  DryMemory last_dry;
  // ... and the strip's own depths of the last frames that were OK, or UNCERTAIN for their noise alone,
  // away from water (StripConfig::frames_together_s): a ring, `recent_count` of them, the newest at
  // recent_next - 1.
  struct RecentDepth {
    std::int64_t t_ns = 0;
    double depth_mm = 0.0, u_mm = 0.0, systematic_mm = 0.0;  // RutMeasurement's depth and its uncertainties
  };
  static constexpr std::size_t kRecentDepths = 4;
  std::array<RecentDepth, kRecentDepths> recent{};
  std::size_t recent_count = 0, recent_next = 0;
  // ... and the capture time of the last frame flagged Water (StripConfig::guard_after_water_s).
  bool water_seen = false;
  std::int64_t water_seen_ns = 0;
};

// xyz: CV_32FC3 strip of 3D points (X, Y, Z in mm), a point is invalid if any coordinate is NaN/inf
// or Z <= 0. Every valid point falls into the X bin of width params.bin_mm nearest to it; each bin's
// Z is the trimmed mean of its points (params.trim_fraction), i.e. the paper's box filter along Y made
// robust to outliers. The grid spans the valid points (at most params.max_section_mm, centred on their
// median X). An empty strip or one of another type yields a section with no bins.
void reduce_to_cross_section(const cv::Mat& xyz, const RutConfig& params, CrossSection& out);

// The seed method of DESIGN.md §5 in mm units, made robust (see extract.cpp for the steps). Pure:
// depends only on its arguments. Fills every field it could measure; only status Ok guarantees all
// of them. Once a depth is found, depth_uncertainty_mm estimates its standard uncertainty as the root
// sum of squares of
//   - the noise of the smoothed profile at the bottom (its wander, from the fit residuals and the
//     smoothed ground's scatter about the line);
//   - the ground line's standard error at the deepest point (residual scatter of the ground bins,
//     their number and lever arm; the slope's share widened by the wander's excess over white noise,
//     as noise correlated from bin to bin leaves fewer independent bins);
//   - the coverage across the rut: over a gap without valid bins inside the opening the bottom is not
//     seen; the profile could continue down with the slopes at the gap's edges (the steepest within
//     half a fit window of each) until the two meet (a V; half the gap's width where only one edge
//     descends; the deeper edge where they meet beyond the gap; RutGeometry::unseen_depth_mm), and that
//     extra depth (taken as uniformly distributed, / sqrt(3)) counts where it would exceed the measured
//     depth;
//   - the selection at a gap's edge: a deepest point within half a fit window of a gap is read
//     again at the deepest bin clear of gaps by as much; where the first reading is deeper, the depth
//     is the two readings' midpoint and half their difference counts (two hypotheses; bins beside
//     what the matcher lost read the surface off, and the deepest of them is picked);
//   - the fit of the deepest region: a parabola whose vertex lies above every sample it was fitted to
//     (fragments across gaps) gives the highest sample as the depth, and half the overshoot counts;
// (the last three, the rut's shape's share, also make up depth_systematic_mm)
// and quality = 1 - u / (2 max_depth_uncertainty_mm), clamped to 0..1 (0 unless the status is Ok,
// Uncertain or Vegetation). A rough profile is Vegetation and a depth with u above the limit Uncertain
// (both with the depth computed but not Ok).
//
// gap_fill (optional): the same strip read again with wider matching windows, on the same bin width.
// Wider windows see into low-texture, steep patches (snow walls) that the section's own windows leave
// as gaps, at less lateral resolution. gap_fill is smoothed as the section is and offset onto it (the
// median difference of the two smoothed profiles over the bins both measured, at least 16); a gap it
// covers (no run of missing bins longer than half the fit window) is bounded by its deepest smoothed
// bin there plus the scatter of that difference (1.4826 MAD) instead of by the walls' slopes
// (RutGeometry::unseen_bound_mm). The depth itself and unseen_depth_mm (what the section's own bins
// leave unseen, which the frame checks judge) are the section's alone.
RutMeasurement extract_rut(const CrossSection& section, const RutConfig& params, RutWorkspace& ws,
                           const CrossSection* gap_fill = nullptr);

// quality from a depth uncertainty u against the limit (RutConfig::max_depth_uncertainty_mm), as above:
// 1 - u / (2 limit), clamped to 0..1; 0 when the limit is not positive.
double depth_quality(double u_mm, double limit_mm);

}  // namespace rutd
