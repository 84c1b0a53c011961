#include "pipeline/measurer.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>

namespace rutd {
namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// Rows matched beyond the measured strip on each side, so the engines' blocks and the DIC window see
// real image rows rather than a replicated border.
int margin_for(const MeasurerConfig& config) {
  const int block = config.engine_config.block_size > 0 ? config.engine_config.block_size : 11;
  return std::max({block / 2, config.dic_config.half_window, config.dic_config.half_height}) + 2;
}

StripRoi measured_strip(const StereoCalibration& calibration, const MeasurerConfig& config) {
  // stereoRectify keeps the raw image size, so the strip is resolved before the geometry exists.
  StripRoi strip = config.strip.rows > 0 ? config.strip : default_strip(calibration.image_size);
  if (strip.row0 < 0) strip.row0 = (calibration.image_size.height - strip.rows) / 2;  // centred
  if (strip.row0 < 0 || strip.rows <= 0 || strip.row0 + strip.rows > calibration.image_size.height)
    throw std::invalid_argument("strip rows " + std::to_string(strip.row0) + ".." +
                                std::to_string(strip.row0 + strip.rows) + " outside the image height " +
                                std::to_string(calibration.image_size.height));
  return strip;
}

StripRoi matched_strip(const StereoCalibration& calibration, const MeasurerConfig& config) {
  const StripRoi strip = measured_strip(calibration, config);
  const int margin = margin_for(config);
  const int row0 = std::max(0, strip.row0 - margin);
  const int row1 = std::min(calibration.image_size.height, strip.row0 + strip.rows + margin);
  return StripRoi{row0, row1 - row0};
}

}  // namespace

StripRoi default_strip(cv::Size rectified_size) {
  const int rows = std::clamp(rectified_size.height / 10, 20, 64);
  return StripRoi{(rectified_size.height - rows) / 2, rows};
}

StereoMeasurer::StereoMeasurer(const StereoCalibration& calibration, const MeasurerConfig& config)
    : config_(config), image_size_(calibration.image_size), geometry_(calibration, matched_strip(calibration, config)) {
  config_.strip = measured_strip(calibration, config);
  context_ = make_match_context();
}

MatchContext StereoMeasurer::make_match_context() const {
  MatchContext context;
  context.engine = make_engine(config_.engine, config_.engine_config);
  return context;
}

bool StereoMeasurer::rectify(FrameWork& w) const {
  w.diag = MeasurementDiagnostics{};
  w.measurement = RutMeasurement{};  // status NoMeasurement until extract() says otherwise
  const cv::Mat& l = w.frame.left;
  const cv::Mat& r = w.frame.right;
  if (l.size() != image_size_ || r.size() != image_size_ || l.type() != r.type() || l.channels() != 1 ||
      (l.depth() != CV_8U && l.depth() != CV_16U))
    return false;
  const auto t0 = Clock::now();
  geometry_.rectify(l, r, w.left_strip, w.right_strip);
  w.diag.rectify_ms = ms_since(t0);
  return true;
}

void StereoMeasurer::match(FrameWork& w, MatchContext& context) const {
  auto t0 = Clock::now();
  w.diag.band = config_.fixed_band ? *config_.fixed_band
                                   : context.band.estimate(w.left_strip, w.right_strip, geometry_, config_.range);
  w.diag.band_ms = ms_since(t0);

  t0 = Clock::now();
  // Only the measured rows are refined; the margin rows were matched as context for the windows.
  DicConfig dic = config_.dic_config;
  dic.row_begin = config_.strip.row0 - geometry_.roi().row0;
  dic.row_end = dic.row_begin + config_.strip.rows;
  // The GPU engine refines on its device: disparity_ms then covers both, dic_ms stays 0.
  if (config_.dic &&
      context.engine->compute_refined(w.left_strip, w.right_strip, w.diag.band, dic, w.disparity, w.diag.dic)) {
    w.diag.disparity_ms = ms_since(t0);
    return;
  }
  context.engine->compute(w.left_strip, w.right_strip, w.diag.band, w.disparity);
  w.diag.disparity_ms = ms_since(t0);

  if (config_.dic) {
    t0 = Clock::now();
    w.diag.dic = refine_disparity_dic(w.left_strip, w.right_strip, w.disparity, dic, context.dic);
    w.diag.dic_ms = ms_since(t0);
  }
}

void StereoMeasurer::extract(FrameWork& w, RutWorkspace& workspace) const {
  auto t0 = Clock::now();
  geometry_.reproject(w.disparity, w.xyz);
  // Only the configured strip is measured: the margin rows were matched for context.
  const int first = config_.strip.row0 - geometry_.roi().row0;
  const cv::Mat measured = w.xyz.rowRange(first, first + config_.strip.rows);
  w.diag.reproject_ms = ms_since(t0);

  t0 = Clock::now();
  reduce_to_cross_section(measured, config_.rut, w.section);
  w.measurement = extract_rut(w.section, config_.rut, workspace);
  w.diag.rut_ms = ms_since(t0);
}

RutMeasurement StereoMeasurer::measure(const cv::Mat& left_raw, const cv::Mat& right_raw) {
  // Shallow copies: the pixels stay the caller's.
  work_.frame.left = left_raw;
  work_.frame.right = right_raw;
  if (rectify(work_)) {
    match(work_, context_);
    extract(work_, rut_ws_);
  }
  return work_.measurement;
}

}  // namespace rutd
