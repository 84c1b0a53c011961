#pragma once
// One stereo pair in, one rut measurement out (DESIGN.md §2-5), in three stages that a real-time
// pipeline runs on separate threads and `replay` runs one after the other:
//   rectify  - remap the strip of both raw images (rows around the measured strip); with the GPU engine
//              the match stage's device does it (MeasurerConfig::rectify_on_device)
//   match    - find the disparity band (or keep the last frame's while it fits: BandTracker), match,
//              refine by digital image correlation
//   extract  - reproject to millimetres, reduce to a cross-section, extract the rut, check the frame for
//              the conditions that would make the depth wrong (measurement/frame_checks.hpp)
// Per-frame path: nothing here throws because of frame content; a status says what went wrong.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "core/measurement_sink.hpp"
#include "core/rut_measurement.hpp"
#include "core/stereo_calibration.hpp"
#include "core/stereo_frame.hpp"
#include "engines/disparity_engine.hpp"
#include "geometry/stereo_geometry.hpp"
#include "measurement/band_estimate.hpp"
#include "measurement/frame_checks.hpp"
#include "refinement/dic_refine.hpp"
#include "rut/extract.hpp"
#include "rut/waterline.hpp"

namespace rutd {

// The strip of rectified rows measured (DESIGN.md §2).
struct StripConfig {
  int rows = 0;                  // 0: default_strip()'s, a tenth of the image height (20..64)
  std::optional<int> first_row;  // the strip's first rectified row; std::nullopt: centred in the image
  // Guard strips: water lies along a rut further than the image's length, while what one strip sees of
  // it is chance (a lid's gaps, a waterline's steps fall between its rows). A frame the measured strip
  // finds OK is measured again on this many more strips of the same height (the first guard_spacing of
  // the image height above it, the second as far below, 0..2; a guard that would leave the image or
  // overlap the strip is dropped), and refused BOTTOM_NOT_SEEN with Water where a guard finds water the
  // strip did not (read through it, or the bottom hidden by it: a lid the strip took for the bottom),
  // or, where the strip read the bottom through clear water, where a guard finds the bottom hidden (a
  // lid over clear water glimpsed through its gaps). Off with water checks off. Only OK frames pay for
  // them: up to twice a strip's work more, in extract() (a GPU engine's guards match on the CPU).
  int guards = 2;
  double guard_spacing = 0.25;
  // When the guards are asked: on every OK frame (guards_always), or only on an OK frame captured at most
  // guard_after_water_s after a frame flagged Water, this one included (the strip's own finding, a
  // guard's refusal). Water is seen along a rut before the frames where the strip alone misses it (a
  // lid's debris lit like the soil); dry ground, most of a drive, then costs nothing.
  bool guards_always = false;
  double guard_after_water_s = 0.5;
  // A depth UNCERTAIN for its noise alone that its strips cannot publish together (read_strips_together)
  // is read with the strip's own depths of the last frames (up to RutWorkspace::kRecentDepths), captured
  // at most frames_together_s before it, that were OK or UNCERTAIN for their noise alone, away from water:
  // where all agree as their uncertainties say and their combined uncertainty is within the limit, their
  // weighted mean is published. The rut over that stretch of travel, as the strips together give the rut
  // over half the image. 0: off.
  double frames_together_s = 0.2;
};

struct MeasurerConfig {
  // The default: with DIC every engine gives the same depth on rendered ruts (within 0.01 mm), so the
  // choice rests on real images, where SGBM_3WAY has the lowest bad-1.0 of the full-coverage engines on
  // the Middlebury pairs (tests/integration/test_middlebury.cpp), and on speed, where it is the fastest
  // SGBM mode.
  EngineKind engine = EngineKind::Sgbm3Way;
  EngineConfig engine_config;
  StripConfig strip;
  // Plausible camera-to-terrain distances. The band is found per frame inside it (estimate_band) unless
  // fixed_band is set.
  WorkingRange range;
  std::optional<DisparityBand> fixed_band;
  bool dic = true;  // sub-pixel refinement; without it OpenCV's pixel locking biases the depth
  // Every second row: adjacent windows overlap by 10 of 11 rows, so this halves the time for the same
  // accuracy (measured: depth changed by under 0.01 mm on rendered ruts).
  DicConfig dic_config{.row_step = 2};
  // DIC windows per column (DicConfig::column_windows): a strip of up to kMaxColumnWindowRows rows is
  // one window per column spanning it (a sixth of per-pixel windows' time, the same depths); taller
  // strips (full frame, surface maps) are refined in blocks of kColumnBlockRows rows, one window per
  // column and block, so every pixel still gets a refined disparity. false: per pixel on dic_config's
  // grid.
  bool column_windows = true;
  static constexpr int kMaxColumnWindowRows = 64;
  static constexpr int kColumnBlockRows = 16;
  // With DIC: start this frame's windows from the last frame's refined disparity instead of running the
  // engine, while that keeps refining at least kMinReusedShare of what the engine's start refined, for
  // up to kMaxReusedFrames frames in a row (the terrain moves far less than the windows' convergence
  // range, about a pixel, between frames). A frame that falls short is matched again from the engine.
  bool reuse_starts = true;
  // EngineKind::Gpu with 8-bit images: the engine rectifies on its device, in the same submission as the
  // match and the DIC when the band is known, and only the rectified strips (for the frame checks) and
  // the refined disparity come back; the rectify stage then only checks the frame. false: the CPU
  // rectifies and the engine gets the strips.
  bool rectify_on_device = true;
  // A frame whose depth is Uncertain only for its gaps (extract_rut's coverage term: low-texture,
  // foreshortened walls whose windows the DIC rejects, the walls' slopes then bounding what the gaps
  // could hide) is read again by DIC with windows this wide (half width, px; dic_config.half_window + 1
  // to 15), started from its refined disparity carried linearly across each row's gaps, and its gaps
  // bounded by what that reading sees (extract_rut's gap_fill). The depth stays the narrow windows':
  // wide windows blur a lid's edges and the bottom's curvature. In extract(), on the CPU, for any
  // engine; other frames cost nothing. 0: off.
  int gap_fill_half_window = 11;
  // A frame refused for what its windows did not match (TooFewPoints, NoGround, Uncertain) is read again by
  // DIC with the raw images' noise judging each window's correlation (DicConfig::noise_grey), from its
  // refined disparity carried across the gaps, and that reading replaces the first where it keeps more
  // windows (read_low_texture); a depth it alone makes Ok is published only where the guard strips confirm
  // it (read_strips_together). Low-texture ground under gain (snow, dim light) correlates under min_zncc
  // where it matches. In extract(), on the CPU, for any engine; other frames cost nothing.
  bool low_texture_read = true;
  static constexpr int kMaxReusedFrames = 15;
  static constexpr double kMinReusedShare = 0.97;
  RutConfig rut;
  ConditionConfig conditions;
  // Standing water: its waterline found on the cross-section and the brightness of the left strip, the
  // bottom read through clear water by refraction, a lid or opaque water refused (rut/waterline.hpp).
  WaterlineConfig water;
};

// Empty when `half_window` is a valid MeasurerConfig::gap_fill_half_window beside the first reading's
// `narrow_half_window` (0, or wider than it up to the DIC's 15 px); else what is expected and what was got.
// The one rule for the configuration file, the command line and the measurer's constructor.
std::string gap_fill_window_problem(int half_window, int narrow_half_window);

// Which rule flagged a frame Water (README, "Conditions rutd flags"; rut/waterline.hpp), the one that
// decided it (the guard strips' over the strip's own): what a user reading a recording, or the scene matrix, needs to
// tell a lid from a waterline or a guard strip's finding. Names as water_rule_name() spells them.
enum class WaterRule : std::uint8_t {
  None,             // not flagged Water
  Lid,              // a level span at the bottom lit unlike a wall, of another material, or brighter all round
  LidRecalled,      // at the level of a lid (or a waterline the profile stopped at) found a moment ago
  LidUnlikeGround,  // a level span unlike the flat ground, under no waterline
  WaterlineHides,   // a waterline on both walls the profile stops at, follows, or brightens below: bottom hidden
  WaterlineAtLid,   // a waterline at the level of a lid found a moment ago: the bottom seen in the debris' gaps
  ReadThrough,      // the bottom read through the water below a waterline, corrected for refraction
  Candidate,        // a candidate waterline: the readings dry and through it disagree beyond the limit
  GuardStrip,       // a guard strip found the water, or the lid two strips found a moment ago (check_guards)
  FrameCheck,       // the frame checks' own: a reflection in the rut, or its surface flat and unmatched
};
inline constexpr std::size_t kWaterRuleCount = static_cast<std::size_t>(WaterRule::FrameCheck) + 1;
const char* water_rule_name(WaterRule rule);  // "lid", "read_through", ...; "" for None

// Figures of one frame's measurement, for logs and benchmarks. Milliseconds of thread time per stage.
struct MeasurementDiagnostics {
  DisparityBand band;
  bool band_estimated = false;  // false: the last frame's band was kept (BandTracker), or fixed_band
  bool starts_reused = false;   // the DIC started from the last frame's disparity; the engine did not run
  DicStats dic;
  // rectify_ms: CPU rectification, or the device's alone (a frame whose band was estimated); a frame
  // rectified, matched and refined in one device submission counts it in disparity_ms.
  double rectify_ms = 0, band_ms = 0, disparity_ms = 0, dic_ms = 0, reproject_ms = 0,
         rut_ms = 0;  // rut_ms: extraction and frame checks
  bool rectified_on_device = false;
  bool band_on_device = false;  // the band's coarse pass ran on the engine's device (it rectified too)
  int guard_strips = 0;         // guard strips measured (StripConfig::guards), in rut_ms
  bool gaps_read = false;  // the gaps were read with wider windows (MeasurerConfig::gap_fill_half_window), in rut_ms
  bool low_texture_read = false;  // read again with the noise judging the correlation (read_low_texture), in rut_ms
  bool strips_together = false;   // an Uncertain depth published from the strip and its guards (read_strips_together)
  int strips_read = 0;            // ... from how many strips: the strip and one or both guards
  int frames_read = 0;  // ... and how many of the last frames' depths with them (StripConfig::frames_together_s)
  WaterRule water_rule = WaterRule::None;  // GuardStrip: a guard strip refused the frame
  // The rule that would have flagged the frame Water by its looks, overruled as the steady dry frames a moment
  // before read the bottom at its depth (StereoMeasurer::recall_dry); None: not overruled.
  WaterRule dry_overruled = WaterRule::None;
};

// Everything one pair needs on its way through the stages. Frame pools hold these; every buffer is
// reused, so once a slot has seen a frame of a given size nothing is allocated for the next one (OpenCV's
// matchers allocate their own internal buffers).
struct FrameWork {
  StereoFrame frame;
  cv::Mat left_strip, right_strip;  // CV_8UC1 rectified strips, rows of StereoGeometry::roi()
  bool strips_ready = false;        // false: rectify() left the strips to the match stage's engine
  // Set by rectify(): the rectified row of the strips' first row, and the rows measured within them.
  int strip_row0 = 0, measured_row0 = 0, measured_rows = 0;
  cv::Mat disparity;  // CV_32FC1 px, NaN invalid
  cv::Mat xyz;        // CV_32FC3 mm, left rectified camera frame, NaN invalid
  CrossSection section;
  RutGeometry geometry;   // where extract() found the rut on `section` (a copy: allocates nothing)
  bool measured = false;  // extract() ran on this frame; false after rectify() refused it
  RutMeasurement measurement;
  MeasurementDiagnostics diag;
  FrameCheckScratch checks;
  // Standing water (StereoMeasurer::extract): the left strip's brightness and texture per cross-section
  // bin, the section as read through the water, and their scratch.
  std::vector<double> bin_brightness, bin_texture;
  std::vector<int> bin_pixels;
  CrossSection refracted;
  WaterlineWorkspace water;
  // The gaps read with wider windows (MeasurerConfig::gap_fill_half_window): the refined disparity
  // carried across the gaps and refined again, its points and cross-section, and the DIC's scratch.
  cv::Mat gap_disparity, gap_xyz;
  cv::Mat low_disparity;  // StereoMeasurer::read_low_texture's reading, swapped with `disparity` where it stands
  CrossSection gap_section;
  DicWorkspace gap_dic;
};

// What the sinks see of a frame (core/measurement_sink.hpp): its figures and `health`, and, once
// measured, pointers to its images, strips, disparity, cross-section and rut geometry (valid while `work`
// is unchanged).
PublishedFrame published_frame(const FrameWork& work, const SensorHealth& health);

// What the match stage needs of its own: one per thread that runs match().
struct MatchContext {
  std::unique_ptr<DisparityEngine> engine;
  BandEstimator band;
  BandTracker band_tracker;
  DicWorkspace dic;
  cv::Mat left_binned, right_binned, disparity_binned;  // column windows: the strips binned 2:1 along columns
  // MeasurerConfig::reuse_starts: the last refined disparity, and how it came about.
  cv::Mat previous;
  int reused_frames = 0;   // frames in a row started from `previous`
  int engine_refined = 0;  // DicStats::refined of the last frame started from the engine
};

class StereoMeasurer {
 public:
  // Computes the rectification once. Throws std::invalid_argument for a strip outside the image.
  StereoMeasurer(const StereoCalibration& calibration, const MeasurerConfig& config);
  ~StereoMeasurer();
  StereoMeasurer(StereoMeasurer&&) noexcept;
  StereoMeasurer& operator=(StereoMeasurer&&) noexcept;

  // Stages; each is const and thread-safe as long as every thread passes its own FrameWork and context
  // (extract() measures the guard strips, StripConfig::guards, one caller at a time).
  // rectify() returns false, with measurement.status NoMeasurement, when the frame does not match the
  // calibration (size, type); later stages must then be skipped.
  bool rectify(FrameWork& work) const;
  void match(FrameWork& work, MatchContext& context) const;
  void extract(FrameWork& work, RutWorkspace& workspace) const;

  MatchContext make_match_context() const;

  // The three stages in turn on internal buffers (replay, tests). Not thread-safe. skew_ns, t_ns: the
  // pair's StereoFrame::skew_ns and capture time (the waterline's memory, WaterlineConfig::memory_s).
  RutMeasurement measure(const cv::Mat& left_raw, const cv::Mat& right_raw, std::int64_t skew_ns = 0,
                         std::int64_t t_ns = 0);
  const MeasurementDiagnostics& diagnostics() const { return work_.diag; }
  // The last measure() call's refined disparity strip (CV_32FC1 px, NaN invalid).
  const cv::Mat& disparity() const { return work_.disparity; }

  const StereoGeometry& geometry() const { return geometry_; }
  const MeasurerConfig& config() const { return config_; }
  // The rectified rows measured, config().strip resolved for the image size.
  StripRoi strip() const { return strip_; }
  // The guard strips' rows (StripConfig::guards), those that fit the image.
  std::vector<StripRoi> guard_strips() const;

 private:
  // Engine (or, with reuse, the last frame's disparity) and DIC in w.diag.band.
  void match_in_band(FrameWork& w, MatchContext& context, bool reuse) const;
  // Strips left to the engine: rectified, matched and refined on its device in `band`; false when the
  // engine cannot (then nothing changed).
  bool match_raw(FrameWork& w, MatchContext& context, DisparityBand band) const;
  // Strips left to the engine: rectified on its device, or here on the CPU when it cannot.
  void rectify_late(FrameWork& w, MatchContext& context) const;
  // A new band for w (its strips ready or left to the engine): the coarse pass on the engine's device
  // where it can (8-bit frames, a GPU engine), else on the CPU from the strips (rectified first if needed).
  DisparityBand estimate_band(FrameWork& w, MatchContext& context) const;
  DicConfig strip_dic_config() const;
  // An Uncertain depth whose gaps alone make it so, measured again with its gaps read by wider windows
  // (MeasurerConfig::gap_fill_half_window); `first`: the measured strip's first row within the strips.
  void read_gaps(FrameWork& w, RutWorkspace& workspace, int first) const;
  // A frame still refused after read_gaps for what its windows did not match (TooFewPoints, NoGround,
  // Uncertain) read again by DIC with the raw images' noise as the correlation's judge
  // (DicConfig::noise_grey), from its refined disparity carried across the gaps; where that keeps more
  // windows, it replaces the first reading (disparity, points, section, measurement; diag.low_texture_read)
  // and its gaps are read as read_gaps reads them.
  void read_low_texture(FrameWork& w, RutWorkspace& workspace, const PairSignal& signal, int first) const;
  void read_through_water(FrameWork& w, RutWorkspace& workspace, const cv::Mat& measured, int first) const;
  // A frame as it was before read_through_water judged it: its dry reading, and the memories it found.
  struct DryReading {
    RutMeasurement measurement;
    RutGeometry geometry;
    WaterlineMemory last_waterline;
    LidMemory last_lid;
  };
  // Overrules a finding of the water rules that judge the strip's looks where the steady dry frames a
  // moment before read the bottom at this frame's dry depth and both guard strips find it dry
  // (MeasurementDiagnostics::dry_overruled; measurer.cpp says why). remember_frame keeps the DryMemory and
  // the recent depths (RutWorkspace::recent) after every rule has judged the frame; guards_dry measures
  // both guards on the frame.
  void recall_dry(FrameWork& w, RutWorkspace& workspace, const DryReading& before) const;
  void remember_frame(const FrameWork& w, RutWorkspace& workspace) const;
  bool guards_dry(FrameWork& w) const;
  void read_waterline(FrameWork& w, RutWorkspace& workspace, const WaterlineMemory& last, const LidMemory& last_lid,
                      const LevelSpan& lid, double lid_u, double y_mm) const;
  void weigh_candidate_waterline(FrameWork& w, RutWorkspace& workspace, const Waterline& line, double y_mm) const;
  // An OK frame measured again on the guard strips (StripConfig::guards) where guards_asked() says so, and
  // refused where one finds water; the frames flagged Water are remembered in `workspace`.
  void check_guards(FrameWork& w, RutWorkspace& workspace) const;
  // A depth Uncertain for its noise alone (low texture against the sensor's noise: snow, dim light under
  // auto gain), away from water, measured again on the guard strips: where the strip's depth and those of
  // one or both guards, each within 3 times RutConfig::max_depth_uncertainty_mm, agree as their
  // uncertainties say (chi-square under its 95th percentile: 3.84 for one degree of freedom, 5.99 for
  // two), their weighted mean (1/u^2) agrees so with the last frames' own depths (RutWorkspace::recent,
  // within StripConfig::frames_together_s, where those agree among themselves), and their combined
  // uncertainty, widened by Birge's ratio where chi-square exceeds its degrees of freedom, is within it,
  // the mean is published OK with that uncertainty. The section and geometry stay the strip's. The rut
  // is one along the half of the image they span; strips that disagree leave it Uncertain. A depth Ok
  // only by read_low_texture is measured so too, and refused Uncertain where both guards do not confirm
  // it. Else an Uncertain depth is read so with the last frames' depths as well (diag.frames_read).
  void read_strips_together(FrameWork& w, const RutWorkspace& workspace) const;
  // Whether one of `depths` (depth, standard uncertainty, mm: the strip's and its guards' OK depths)
  // lies at the level of a lid that this strip or a guard found within memory_s and another of them
  // found at the same level (check_guards; the guards' lock held).
  bool at_lid_of_two_strips(const RutWorkspace& workspace, std::int64_t t_ns,
                            std::span<const std::pair<double, double>> depths) const;
  bool guards_asked(const RutWorkspace& workspace, std::int64_t t_ns) const;
  // The engine is to rectify this frame on its device (MeasurerConfig::rectify_on_device).
  bool device_rectifies(const StereoFrame& frame) const;

  MeasurerConfig config_;
  StripRoi strip_;
  cv::Size image_size_;
  StereoGeometry geometry_;
  // Scratch of measure().
  FrameWork work_;
  MatchContext context_;
  RutWorkspace rut_ws_;
  // The guard strips' measurers, each measuring with its own buffers under one lock; null without guards.
  struct Guards;
  std::unique_ptr<Guards> guards_;
};

// The default strip: centred, clamp(height/10, 20, 64) rows of the rectified image.
StripRoi default_strip(cv::Size rectified_size);

}  // namespace rutd
