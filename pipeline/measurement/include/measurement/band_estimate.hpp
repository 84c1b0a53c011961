#pragma once
// The disparity band a frame is matched in (DESIGN.md §3): the terrain is nearly a plane at a distance
// inside a plausible working range, so a coarse pass finds the narrow band of disparities present, and
// BandTracker keeps it while later frames still fit.
#include <memory>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "engines/disparity_engine.hpp"
#include "geometry/stereo_geometry.hpp"

namespace rutd {

// Plausible distances from the left camera to the terrain along the rectified optical axis, mm.
struct WorkingRange {
  double near_mm = 150.0;
  double far_mm = 1500.0;
};

// The band that covers every disparity of `range` (far end rounded down, near end up), min_disparity
// >= 0. Can be wide (hundreds of px) for a wide range; see estimate_band.
DisparityBand band_for_range(const StereoGeometry& g, WorkingRange range);

// The terrain is near a plane at an unknown distance in `range`: a coarse pass (strips downsampled
// horizontally by a power of two so the band of `range` fits in at most 128 coarse px, and to every second
// row; StereoSGBM 3-way) finds the disparities present at textured pixels; returns a narrow band around
// them (2nd..98th percentile plus a margin of max(4 px, 2 coarse px, 25% of the spread)), clamped to
// band_for_range(range). Returns band_for_range(range) when fewer than 5% of the coarse pixels get a
// disparity. Where that band would leave under half of the coarse strip matchable (a wide baseline and
// a near working range), the coarse pass searches only 0.5..1.5 times the dominant disparity (see
// dominant_disparity), and returns that band when it finds too little. BandEstimator keeps the coarse
// matcher and its buffers between calls, for the per-frame path (one per thread); estimate_band is the
// one-off form and builds them each call.
class BandEstimator {
 public:
  DisparityBand estimate(const cv::Mat& left_strip, const cv::Mat& right_strip, const StereoGeometry& g,
                         WorkingRange range);
  // The same estimate with the coarse pass on `engine`'s device from the raw pair (coarse_match: the
  // device's census matcher instead of StereoSGBM, the strips rectified there and returned in
  // left_strip/right_strip). std::nullopt when the engine cannot, or the range needs no coarse pass:
  // then rectify and call estimate().
  std::optional<DisparityBand> estimate_on_device(DisparityEngine& engine, const cv::Mat& left_raw,
                                                  const cv::Mat& right_raw, const StereoGeometry& g, WorkingRange range,
                                                  cv::Mat& left_strip, cv::Mat& right_strip);

 private:
  struct Plan {
    DisparityBand full;      // band_for_range
    DisparityBand fallback;  // the answer when the coarse pass finds too little: full, or the narrowed band
    int scale = 1;           // columns averaged per coarse pixel
    bool coarse = false;     // false: the full band is the answer
    bool narrow = false;     // coarse_band leaves under half the coarse strip matchable: narrow_to_dominant
    DisparityBand coarse_band;
    cv::Size coarse_size;
  };
  static Plan plan(const StereoGeometry& g, WorkingRange range, cv::Size strip);
  // From coarse_ and left_ (the coarse pair's disparity and left image).
  DisparityBand band_from_coarse(const Plan& p);
  // Narrows p.coarse_band (and p.fallback) around dominant_disparity of left_ and right_; unchanged when
  // none stands out.
  void narrow_to_dominant(Plan& p);

  std::unique_ptr<DisparityEngine> engine_;
  int engine_block_ = 0;  // block size engine_ was made with
  cv::Mat left_, right_, coarse_, texture_, grad_left_, grad_right_;
  std::vector<float> found_;
};

// Keeps the last estimated band while the frames measured in it say it still fits, so that the coarse
// pass of BandEstimator runs once every few frames instead of on every one (it costs about as much as
// the narrow-band match itself). Terrain moves little between frames at camera rates, and a band that
// stops fitting shows at once: matches pile up against its edges or disappear. One per match thread.
class BandTracker {
 public:
  // The most frames measured in one estimated band: a refresh that bounds how long a band chosen on
  // an unusual frame can stay.
  static constexpr int kMaxFrames = 30;

  // The band to match this frame in, if the last one still fits; std::nullopt: estimate a new one.
  std::optional<DisparityBand> band() const;
  // After matching in `band`: the frame's disparities (CV_32FC1 px, NaN invalid), rows
  // [row_begin, row_end) measured. Keeps the band for the next frame when their 2..98 percentiles stay
  // at least kEdgePx inside it and the valid share is at least 0.8 of the share on the band's first
  // frame (and at least 0.25 overall).
  void update(DisparityBand band, bool estimated, const cv::Mat& disparity, int row_begin, int row_end);

 private:
  static constexpr double kEdgePx = 2.0;
  DisparityBand band_;
  int frames_ = 0;  // frames measured in band_; 0: none to keep
  double first_valid_ = 0;
  std::vector<float> values_;
};

// The disparity (px of the given strips) in `band` at which the strips' horizontal gradients correlate
// best over their whole overlap (kept to at least a quarter of the width): the terrain's dominant
// disparity, found where StereoSGBM can look at only a margin of the image. -1 when the best correlation
// is under 0.15 or within chance for the pixels compared. grad_left, grad_right: scratch.
int dominant_disparity(const cv::Mat& left, const cv::Mat& right, DisparityBand band, cv::Mat& grad_left,
                       cv::Mat& grad_right);

DisparityBand estimate_band(const cv::Mat& left_strip, const cv::Mat& right_strip, const StereoGeometry& g,
                            WorkingRange range);

}  // namespace rutd
