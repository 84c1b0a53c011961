#pragma once
// Per-frame checks of the conditions under which stereo gives a wrong depth (README, "Conditions rutd
// flags"): a lens obstructed, low light or overexposure, a calibration that no longer fits, standing
// water or another flat textureless patch in the rut. They look at the rectified strips the match stage
// used and at where extract_rut found the rut, set RutMeasurement's condition bits, figures and, when a
// depth would otherwise be published, the status that refuses it. Vegetation and the depth uncertainty
// are judged on the cross-section itself (rut/extract.hpp).
//
// Cost: one pass over every second measured row of both strips (sums per column block and a histogram)
// and five small template matches for the vertical disparity; no allocation once the scratch has grown
// to the strip width. Not thread-safe per scratch: one per frame slot.
#include <cstdint>
#include <limits>
#include <vector>

#include <opencv2/core.hpp>

#include "core/rut_measurement.hpp"
#include "engines/disparity_engine.hpp"
#include "geometry/stereo_geometry.hpp"
#include "rut/extract.hpp"

namespace rutd {

struct ConditionConfig {
  bool enabled = true;
  // Column blocks (px of the rectified strip) in which the two cameras' views of the same ground are
  // compared. A block's texture is its RMS horizontal intensity gradient, grey levels per pixel (8-bit).
  int block_px = 16;
  // Lens obstruction. Only a left block that DIC did not match (under half of its pixels) can be
  // obstructed: one matched saw the same texture through both lenses. A camera is obstructed in such a
  // block when, looking at the same ground as the other camera (the right strip's window at the
  // block's own median disparity, to the pixel; the strip's where it has none), it sees less than obstruction_ratio of
  // the other's mean brightness (an opaque blob is dark: it is lit from behind the lens), or less than
  // obstruction_ratio of its texture while it is not the brighter one and the other sees at least
  // min_texture (a blob is out of focus: flat; the edge of a blob in the other camera is a steep step,
  // not texture this camera misses). Flagged when at least obstruction_min_fraction of the compared blocks are
  // obstructed.
  // A block DIC matched can still be veiled (frost, snow, a film on the window, lit from the side): the
  // ground shows through, brighter by at least veil_brightening (a share) and with less than
  // obstruction_ratio of the texture the other camera sees there (two clean lenses see the same ground
  // within a few percent of each other in both). It counts as obstructed with the others.
  double obstruction_ratio = 0.4;
  double min_texture = 3.0;  // about 2x the gradient that read noise alone gives (1.5 grey levels: 2.1)
  double obstruction_min_fraction = 0.05;
  double veil_brightening = 0.1;
  // Exposure, over both strips: low light when the median grey level is below low_light_level of full
  // scale (the texture is then a few grey levels, drowned by read and quantisation noise); overexposed
  // when more than overexposed_fraction of the pixels are at or above saturated_level of full scale
  // (clipped pixels carry no texture). Clipping alone refuses no depth extract_rut measured OK: the
  // clipped patches go unmatched and the depth's coverage term counts them (measured on rendered sand,
  // mud and grass clipped at exposures 2-3: errors 0.23 mm at most; at 1.6, under the 15 %: 0.08 mm).
  double low_light_level = 0.06;
  // Low light under auto exposure and gain, which hold the median grey level up whatever the light: in
  // the raw images (ImageSignal), neither camera's texture reaches low_light_texture_to_noise of its
  // noise, and the noise of both is at least low_light_noise of full scale. That much noise is high gain's
  // (at gain 1 read and shot noise stay near 1 % of full scale); a bright scene poor in texture (snow)
  // has the low ratio without it, and is the depth uncertainty's to judge, not the light's.
  double low_light_texture_to_noise = 0.5;
  double low_light_noise = 0.03;
  double saturated_level = 0.98;
  double overexposed_fraction = 0.15;
  // Standing water or a flat textureless patch in the rut: a run of blocks inside the rut opening where
  // the bottom is not seen, at least flat_min_width_mm wide on the ground: both cameras see less than
  // flat_ratio of the texture of the ground outside the rut, and DIC matched under half of the block.
  // Still water reflects a smooth sky and has no texture of its own, so nothing on it matches (its
  // texture is the cameras' read noise); soil, snow and mud match wherever both cameras see them, even
  // in shadow, where their texture drops with the light (a shadowed sand wall: 0.3 of the ground's).
  // The texture test keeps a rough unmatched surface (vegetation, which keeps most of the ground's
  // texture) out; it must pass snow's water, whose ground has little more texture than noise (still
  // water in snow: 0.34 of the ground's).
  // ... and only where the bottom is hidden: the profile's walls still descend into the unmatched part
  // of the rut, so that it could be deeper than measured by more than flat_min_unseen_mm
  // (RutGeometry::unseen_depth_mm; the 1 mm tolerance). A smooth patch of mud or tread marks in the
  // bottom, flanked by bottom seen level on both sides, hides nothing.
  double flat_ratio = 0.5;
  double flat_min_width_mm = 8.0;
  double flat_min_unseen_mm = 1.0;
  // Water seen by its reflection: the sun and sky reflected in a level surface lie at infinity, so each
  // camera sees them at the same columns (disparity 0), not where it sees the ground below, and the
  // ripples that break them up into glints send each camera other ones. A lens blob sits where the lens
  // puts it, over the rut or not. So where every obstructed block (as above) lies inside the rut
  // opening, over the unmatched blocks there (at least specular_min_blocks): the views disagree at the
  // ground's disparity (sum of |left - right| brightness over the sum of both, at least
  // specular_min_disagreement), agree at the same columns (the same share, under specular_coherence of
  // that at the ground's), and the block both views see brightest at the same columns is brighter than
  // the ground outside the rut by specular_brightening (a share) and at least as textured (a glint, not
  // the same dark or smooth dirt on both lenses): Water, the lens flags not raised, and the bottom hidden
  // where the walls descend into the unmatched part (flat_min_unseen_mm).
  double specular_coherence = 0.6;
  double specular_min_disagreement = 0.2;
  double specular_brightening = 0.3;
  int specular_min_blocks = 3;
  // Calibration: the vertical offset of the right strip's features against the left's, measured by
  // normalised cross-correlation of vertical_blocks blocks spread over the middle 60 % of the strip,
  // over +-vertical_search_px rows (sub-pixel by a parabola). Rectification leaves a few hundredths of
  // a pixel with a calibration that fits; DIC windows do not follow a vertical offset, so one above
  // max_vertical_disparity_px both loses matches and biases the disparity of oblique texture. Drift is
  // flagged when at least a third of the correlating blocks exceed it, and two unless only one
  // correlates (a roll moves the strip's ends in opposite directions); vertical_disparity_px
  // (RutMeasurement) is the largest offset. Blocks over the rut opening are left out: a wall's
  // disparity changes across a block, which a rigid block cannot follow (a steep wall's edge lets the
  // rows slide along it), and a calibration shows on the ground.
  double max_vertical_disparity_px = 0.7;
  int vertical_search_px = 8;
  int vertical_blocks = 5;
  int vertical_block_px = 24;
  double min_vertical_correlation = 0.6;  // a block whose best correlation is lower is not used
  // ... nor one whose correlation at the best column falls less than this below its peak over the rows
  // searched: texture that varies along the columns only (a steep rut wall's edge or its shadow's, along
  // travel, where the rut was not found) lets the rows slide along it, and where its peak lies is chance
  // (measured on steep snow ruts: 0.01-0.14 below the peak at an edge, 0.75-0.85 on the snow beside it).
  double min_vertical_contrast = 0.3;
  // Free-running cameras: a pair whose cameras exposed at least unsynchronised_skew_ms apart
  // (StereoFrame::skew_ns, where the source knows it) shows the ground moved by speed x skew between
  // the two views, off the epipolar lines as a drifted calibration is. There, offsets beyond the limit,
  // or none found at all, are the motion's: the pair is refused as UNSYNCHRONISED, and the conditions
  // that compare the two views (CalibrationDrift, the lens checks, Vegetation) are not raised from it.
  // Offsets within the limit (the vehicle standing) leave the checks as they are. 0.1 ms: well above
  // hardware-triggered cameras' skew (microseconds), and a tenth of a millimetre's motion at 1 m/s.
  double unsynchronised_skew_ms = 0.1;
  // Vegetation: blades standing above the soil are seen by both cameras (texture in both) but do not
  // match as one surface (each camera sees other blades in front of other soil), so DIC refuses them.
  // Soil, snow and mud match wherever both cameras see texture. Flagged when more than
  // vegetation_unmatched_share of the blocks with texture in both cameras (at least min_texture and, in
  // an image whose texture is under its noise, twice the neighbour difference the camera's own read noise
  // gives, PairSignal: under gain, snow's noise alone passes min_texture, and DIC leaves such blocks
  // unconverged) have under half of their pixels matched, and at least vegetation_min_blocks do: one or
  // two unmatched blocks are a pile's steep flank or a window that did not converge, and on a ground
  // with few textured blocks (snow) they alone would make the share. Only blocks outside the rut opening
  // count (the tyre flattened the rut).
  // (A cross-section rough at scales soil is not also flags it: RutConfig.)
  double vegetation_unmatched_share = 0.2;
  int vegetation_min_blocks = 3;
};

// Throws std::invalid_argument naming the field when `config` is unusable.
void validate(const ConditionConfig& config);

// OpenCV's TM_CCOEFF_NORMED of an 8-bit template over an 8-bit area (both CV_8UC1), into `result`
// ((area.rows - templ.rows + 1) x (area.cols - templ.cols + 1), CV_32F; 0 where the area's patch or the
// template is flat). The calibration check's correlation: written out because cv::matchTemplate
// allocates its work buffers on every call and this runs on every frame, at sizes (a few thousand
// pixels, a few dozen offsets) that need no FFT. `result` keeps its buffer from one call to the next.
void normalized_correlation(const cv::Mat& area, const cv::Mat& templ, cv::Mat& result);

// What a camera's image holds for matching against its own noise, from the raw image (the rectified
// strips' resampling correlates the noise and hides it from a neighbour statistic).
struct ImageSignal {
  double noise = std::numeric_limits<double>::quiet_NaN();    // deviation, fraction of full scale
  double texture = std::numeric_limits<double>::quiet_NaN();  // RMS horizontal neighbour difference, same
  // The texture without the noise's share, over the noise's share of the same difference:
  // sqrt(texture^2 - 2 noise^2) / (sqrt(2) noise); NaN when unknown.
  double texture_to_noise = std::numeric_limits<double>::quiet_NaN();
};

// raw: a camera's unrectified image (CV_8UC1 or CV_16UC1); rows [row_begin, row_end) are read, at most
// max_rows of them evenly spaced, every second column. Noise by Immerkaer's Laplacian, taken as the median of its
// absolute value (robust to texture edges, unlike the mean). Never throws; NaN figures on unusable input.
ImageSignal image_signal(const cv::Mat& raw, int row_begin, int row_end, int max_rows,
                         std::vector<std::uint32_t>& histogram) noexcept;

// Both cameras' ImageSignal of one pair (unknown, NaN, where the raw images were not looked at).
struct PairSignal {
  ImageSignal left, right;
};

// Reused between frames; contents unspecified.
struct FrameCheckScratch {
  std::vector<double> sum[2], grad2[2];
  std::vector<int> count[2];
  std::vector<double> texture[2], brightness[2];
  std::vector<double> column_sum, column_grad2;  // the right strip's, prefix sums over columns
  std::vector<int> matched, sampled;
  std::vector<float> values;
  std::vector<std::uint32_t> histogram;  // image_signal's
  cv::Mat result;
};

// strips: the rectified CV_8UC1 strips the match stage used (StereoGeometry::roi() rows); disparity:
// their refined disparity (CV_32FC1, NaN invalid); rows [row_begin, row_end) are the measured strip.
// rut: extract_rut's geometry of this frame. Updates m (conditions, vertical_disparity_px,
// obstructed_left/right, status). Never throws.
// band: the disparity band the frame was matched in (where to look for the right strip's features
// when no disparity was found).
// skew_ns: the pair's StereoFrame::skew_ns (0: synchronised or unknown).
// signal: the raw images' texture and noise (ConditionConfig::low_light_texture_to_noise, and the
// vegetation check's least texture; unknown skips the first and leaves min_texture to the second).
void check_frame(const cv::Mat& left_strip, const cv::Mat& right_strip, const cv::Mat& disparity, int row_begin,
                 int row_end, const StereoGeometry& geometry, const RutGeometry& rut, DisparityBand band,
                 std::int64_t skew_ns, const PairSignal& signal, const ConditionConfig& config,
                 FrameCheckScratch& scratch, RutMeasurement& m) noexcept;

}  // namespace rutd
