#pragma once
// Standing water in the rut, read through its surface (README, "Conditions rutd flags"). Pure functions on
// the cross-section, like extract.hpp: no threads, no I/O, no allocation once the vectors have grown.
//
// A level water surface meets both walls of the rut at one height: the waterline. Below it the soil is
// wet (darker: water fills its pores), seen through the surface's reflection and the water's body
// colour, or hidden by a floating lid of foam or leaves (brighter or darker, and textured otherwise): in
// every case the brightness of the cross-section steps at the waterline, on both walls, by more than
// the soil's own texture varies, and in the same sense on both. find_waterline looks for that pair of
// steps. Where the bottom shows through the water (clear water), stereo triangulates the two cameras'
// rays bent at the surface as if they were straight, so the submerged part appears about 1/n as deep
// (two-media photogrammetry); refract_section undoes that ray by ray by Snell's law at the fitted plane.
// Where the profile stops at the waterline (a lid, turbid water matched on its surface) the bottom is
// not seen and no depth may be published.
#include <algorithm>
#include <cstdint>
#include <limits>
#include <vector>

#include "core/cross_section.hpp"

namespace rutd {

struct WaterlineConfig {
  bool enabled = true;
  double refractive_index = 1.333;  // fresh water, visible light, 20 degC
  // Standard uncertainty of the index over the water a rut holds (temperature 0-30 degC: 0.0015;
  // dissolved and suspended matter up to a few grams per litre: about 0.002), doubled for the
  // flat-surface model itself (a meniscus, a slight ripple).
  double refractive_index_u = 0.005;
  // Brightness steps are the log ratio of the mean brightness of step_window_mm of the section on each
  // side of a bin. A step must exceed min_step (log; 0.22 = 20 % darker, the least that wetting darkens
  // soil) and step_over_ground times the robust spread of the same statistic over the ground outside
  // the rut (the soil's own texture at that scale).
  double step_window_mm = 8.0;
  double min_step = 0.22;
  double step_over_ground = 4.0;
  // The two walls' steps are one waterline when their heights below the ground line agree within
  // level_tolerance_mm plus what two bins of lateral uncertainty each (the capillary fringe above a
  // waterline darkens the soil gradually) give on the walls' slopes.
  double level_tolerance_mm = 1.0;
  // The bottom is seen through the water on at least this share of the submerged span's bins (deeper
  // than the waterline by what min_seen_below_mm and the uncertainties ask); less, and the surface is
  // mostly a lid whose level the profile follows, the bottom glimpsed through gaps where the matching
  // windows blend lid and bottom into a shallower one (scene matrix: leaves, litter and foam over clear
  // water, 0-0.17 with the corrected depth 1.3-10 mm short; the bottom seen through clear water, open
  // or with floating debris, 0.34-0.98). 0: off.
  double min_share_seen_below = 0.25;
  // Steps closer than this below the ground line are the rut's rim (shading at the crest), not water.
  double min_level_mm = 2.0;
  // The bottom is seen through the water when the profile reaches deeper than the waterline by more
  // than this, and by more than twice the combined uncertainty of the depth and of the waterline's level
  // (else a lid or opaque water: the bottom not seen; a leaf lid 1.3 mm below a waterline located to a
  // few millimetres passed for 1.3 mm of water seen through), mm.
  double min_seen_below_mm = 1.0;
  // The submerged span (between the two steps) must differ from the walls just above in the steps'
  // sense by at least half the step threshold, and by at least this (log).
  double min_submerged_step = 0.0;
  // A pair of darkening steps that passes every test above with candidate_step_over_ground in place of
  // step_over_ground, the whole span between them darker than the walls above by at least min_step
  // (all of it wet), is a candidate waterline: clear water whose wet walls darken less, against the
  // soil's own texture, than the threshold asks (rendered clear water: 2-3.8 times the ground's spread,
  // against 4; its submerged span 0.6-1.0 darker) or a coincidence of the texture (shading under a rim
  // darkens a band, not the span: 0.1-0.17). Where the whole submerged span darkens by what a waterline's
  // steps must reach (step_over_ground times the spread, and min_step), the water is there and the
  // steps only place its level: the candidate is a waterline (rendered clear water: 4.1-5.0 times; clean
  // ruts' candidates: at most 3.7, and all but one at the bottom, where nothing is read below), where
  // the span is as much darker than the flat ground on both sides of the rut too
  // (Waterline::submerged_ground_step: a mud blotched on a larger scale than the rut darkened a clean
  // rut's span 4.4 times against its walls, and was read through as 13 mm of water). Else the
  // frame is read both ways and refused where the two readings differ by more than its depth
  // uncertainty allows (StereoMeasurer). 0: off.
  double candidate_step_over_ground = 2.0;
  // Standing water lies along the rut for metres; one frame's walls show its steps below the threshold
  // where the last showed them above it. A candidate waterline at the level of a waterline confirmed at
  // most memory_s before (capture times), within twice their levels' combined standard uncertainty and
  // level_tolerance_mm, is that water's waterline. 0: off.
  // So does a floating lid: one frame's lid is lit like the soil on its walls where the last one's was
  // not. A level span at the bottom of a profile that would be published, at the level of a lid (or of
  // a waterline the profile stopped at) found at most memory_s before, within level_tolerance_mm and
  // twice their levels' combined standard uncertainty, stepping at one end by a candidate waterline's
  // share of the threshold, is that lid: the bottom is not seen (StereoMeasurer). A lid found on two
  // frames running is recalled by any profile whose depth lies at its level. Nor is a waterline at
  // the level of a lid found within memory_s read through: what stereo finds below it is the bottom in
  // the debris' gaps. Guard strips judge each frame alone.
  double memory_s = 0.5;
  // The dry memory (DryMemory, StereoMeasurer::recall_dry): a finding of the rules that judge one
  // strip's looks is overruled where the steady dry frames at most memory_s before read the bottom at
  // the depth this frame's dry reading finds, within twice their combined standard uncertainty and
  // dry_tolerance_mm (so is "steady": two dry frames running agreeing so), and both guard strips find it
  // dry. Half the 1 mm a depth may be off: a rut deepening by less than that a frame reaches a pool's
  // surface with less water over its bottom than that. 0: off.
  double dry_tolerance_mm = 0.5;

  // A floating lid (foam, leaves, litter on the water) where no pair of steps marks the waterline
  // (foam on snow is as bright as the snow on one wall): the profile's deepest span is level, not much
  // rougher than the ground outside the rut at the matcher's precision, and its brightness steps
  // against the wall beyond it on at least one side by lid_step_factor times the threshold above (one
  // step is weaker evidence than a pair at one height: a wall turned from the light steps too; in
  // rendered clean ruts up to 1.1 times the threshold, against 1.5-2.6 for litter and leaves). The span is the run of
  // bins about the deepest point within lid_tolerance_mm of its depth (or 3 times the ground's
  // bin-to-bin scatter, if more), so it is level with the ground line within that over its width; it
  // must be at least lid_min_width_mm wide and scatter at most lid_roughness_ratio times the ground's:
  // floating debris is bumpier than still water (foam and leaves 2-3.2 times the ground's scatter on
  // rendered sand and grass), a bottom scattered more is soil (clods, tread marks).
  // A level span whose mean brightness differs from the flat ground on both sides of the rut, in one
  // sense, by lid_ground_factor times the threshold is unlike the ground (LevelSpan::unlike_ground):
  // ground and span face the light alike, so shading cannot explain the difference, only another surface
  // can: a lid, or the bottom seen darker through clear water. Without a waterline above it, it is taken
  // for a lid (litter on snow: 1.20-2.20 times the threshold; rendered clean rut bottoms: up to 0.98, in
  // mud, whose blotches are larger than the rut). A rut's own bottom is soil lit like its walls where
  // it meets them (its surface turns smoothly there); a water surface cuts the walls wherever it stands. Where its
  // walls' slopes change at the waterline the matching window rounds the corner off (a few millimetres), as it does a
  // rut bottom's, so the corner alone tells neither apart.
  // A level span of another material than the soil (LevelSpan::other_material): its texture differs
  // from the walls beyond both its ends and from the flat ground on both sides of the rut, in one
  // sense, by more than lid_texture_step (log; 0.8: 2.2 times). The texture is the brightness's RMS
  // difference between neighbouring rows (along the travel, where walls are not foreshortened), less
  // the noise's share, over the mean brightness: light falling on a surface scales its grey levels and
  // their variations alike, so shading, which confounds the brightness steps above, leaves it alone,
  // while foam, leaves and litter are not soil (foam on snow 3.5-5 times the snow's). A rut's own
  // bottom is the soil of its walls: in the scene matrix, clean ruts reach 0.34 in log on all three
  // together (mud), tread-marked bottoms 0.10, clear water 0.17; lids on snow and mud 0.91-2.44
  // (22 frames of 9 scenes), the other lids less. The walls' windows need two textured bins only: a
  // steep wall beside a lid is often matched for a few bins down from it, DIC losing the rest. 0: off.
  double lid_texture_step = 0.8;
  // A level span brighter than the walls beyond both its ends and than the flat ground on both sides
  // of the rut, each by lid_bright_factor times the step threshold, is not the rut's soil
  // (LevelSpan::brighter_all_round): the bottom of a rut sees less of the sky than the open ground does
  // and is shaded by its walls, so lit soil there is at most as bright as the ground; what is brighter
  // all round is another surface (foam, pale litter, a leaf lid). Soil cut down to a paler layer is
  // paler on its walls too, and a bottom darker all round is the rut's own shade, so only brightening
  // is judged. In the scene matrix, clean and tread-marked bottoms reach 0.36 times the threshold on
  // all three together; lids 0.5-1.8. 0: off.
  double lid_bright_factor = 0.5;
  bool lid_check = true;
  double lid_tolerance_mm = 0.5;
  double lid_min_width_mm = 10.0;
  double lid_roughness_ratio = 4.0;
  double lid_step_factor = 1.5;
  double lid_ground_factor = 1.1;
};

inline constexpr double kLevelSpanUnknown = std::numeric_limits<double>::quiet_NaN();

// A level flat span at the bottom of the profile, lit unlike a wall beside it (WaterlineConfig::lid_check).
struct LevelSpan {
  bool found = false;          // all the tests passed
  bool unlike_ground = false;  // level, flat and unlike the flat ground (lid_ground_factor)
  double level_mm = 0.0;       // the span's mean depth below the ground line, mm
  double left_x_mm = 0.0;      // its ends
  double right_x_mm = 0.0;
  double tilt = 0.0;                         // its slope against the ground line
  double roughness_mm = 0.0;                 // its bin-to-bin scatter (robust sigma)
  double ground_roughness_mm = 0.0;          // the same over the ground outside the rut
  double left_step = 0.0, right_step = 0.0;  // log brightness on the span minus on the wall beyond
  double ground_step = 0.0;     // mean log brightness on the span minus the flat ground's median, the nearer side's
  double step_threshold = 0.0;  // what a step must reach (find_waterline's); NaN without brightness
  // Log texture (WaterlineConfig::lid_texture_step) on the span minus on the wall beyond each end, and
  // minus the flat ground's (the smaller side's, 0 unless both sides have one sign); NaN unknown.
  double texture_left_step = kLevelSpanUnknown, texture_right_step = kLevelSpanUnknown;
  double texture_ground_step = kLevelSpanUnknown;
  bool other_material = false;      // level, flat, and its texture unlike the soil's on all three (lid_texture_step)
  bool brighter_all_round = false;  // level, flat, and brighter than both walls and the ground (lid_bright_factor)
};

struct Waterline {
  bool found = false;
  double level_mm = 0.0;    // depth of the surface below the ground line, perpendicular, mm
  double level_u_mm = 0.0;  // its standard uncertainty, mm
  double left_x_mm = 0.0;   // X of the two waterlines on the walls
  double right_x_mm = 0.0;
  double left_step = 0.0;  // log brightness ratio (below / above) at each
  double right_step = 0.0;
  double submerged_step = 0.0;  // mean log brightness between the two, minus on the walls just above
  // ... minus the flat ground's median on each side of the rut, the smaller (0 unless both have one sign)
  double submerged_ground_step = 0.0;
  double ground_spread = 0.0;  // robust spread of the step statistic over the ground
};

// The last waterline a frame confirmed by its own steps (WaterlineConfig::memory_s), carried to the next
// frame; line.found false: none.
struct WaterlineMemory {
  std::int64_t t_ns = 0;  // that frame's capture time
  Waterline line;
};

// The last surface a frame found hiding the bottom at a known level (WaterlineConfig::memory_s): a
// floating lid, or a waterline the profile stops at. found false: none.
struct LidMemory {
  std::int64_t t_ns = 0;  // that frame's capture time
  bool found = false;
  double level_mm = 0.0;    // depth of the surface below the ground line, mm
  double level_u_mm = 0.0;  // its standard uncertainty, mm
  // Found at this level by the frame before too, within memory_s: a lid seen twice running, not one
  // frame's chance finding.
  bool confirmed = false;
};

// The last frame that read the bottom dry by its own evidence: published OK with no condition, no water
// rule raised on it (WaterlineConfig::memory_s). found false: none, or a frame flagged Water since.
struct DryMemory {
  std::int64_t t_ns = 0;  // that frame's capture time
  bool found = false;
  double depth_mm = 0.0;  // its depth and standard uncertainty, mm
  double depth_u_mm = 0.0;
  // That frame's depth agreed with the dry frame's before it (within memory_s, dry_tolerance): the rut
  // is not deepening faster than that from frame to frame.
  bool steady = false;
};

// What a brightness step must reach (find_waterline, find_level_span): min_step, and step_over_ground
// times the step statistic's robust spread over the ground outside the rut.
inline double waterline_step_threshold(const WaterlineConfig& config, double ground_spread) {
  return std::max(config.min_step, config.step_over_ground * ground_spread);
}

// Scratch reused between frames; contents unspecified.
struct WaterlineWorkspace {
  std::vector<double> log_brightness, log_texture, step, values, x, z;
};

// section: the cross-section extract_rut measured; brightness: mean grey level of the left image's
// pixels averaged into each bin (NaN where none); geometry: extract_rut's (has_line and has_rut needed,
// else nothing is found). Looks for one waterline as described above.
Waterline find_waterline(const CrossSection& section, const std::vector<double>& brightness,
                         const RutGeometry& geometry, const WaterlineConfig& config, WaterlineWorkspace& ws);

// Looks for a floating lid as described at WaterlineConfig::lid_check, on the section extract_rut
// measured (geometry: has_line and has_rut needed). texture: the left image's texture per bin as
// WaterlineConfig::lid_texture_step defines it (NaN where unknown; empty: no texture test). The span's
// figures are filled whenever a span was delimited, `found` and `other_material` only when their tests passed.
LevelSpan find_level_span(const CrossSection& section, const std::vector<double>& brightness,
                          const std::vector<double>& texture, const RutGeometry& geometry,
                          const WaterlineConfig& config, WaterlineWorkspace& ws);

// Of the valid bins between the two waterlines (line.left_x_mm..right_x_mm), the share deeper than the
// waterline by more than margin_mm (WaterlineConfig::min_share_seen_below); 0 where none is valid.
double share_seen_below(const CrossSection& section, const RutGeometry& geometry, const Waterline& line,
                        double margin_mm);

// The section as it would be without the water: every bin deeper than the waterline is the apparent
// point stereo triangulated from two rays bent at the surface; each of the two rays (from the left
// camera centre, the origin, and the right one at (baseline_mm, 0, 0), at Y = y_mm) is refracted at the
// surface plane (parallel to the ground line, level_mm below it, normal in the X-Z plane) by Snell's law
// with `n`, and the point is where the refracted rays pass closest. The corrected points are resampled
// onto the section's grid (linear between neighbours); bins above the waterline are copied. `out` may
// not alias `apparent`.
void refract_section(const CrossSection& apparent, const RutGeometry& geometry, double level_mm, double n,
                     double baseline_mm, double y_mm, CrossSection& out, WaterlineWorkspace& ws);

}  // namespace rutd
