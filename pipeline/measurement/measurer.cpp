#include "measurement/measurer.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <mutex>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>

#include <opencv2/imgproc.hpp>

#include "engines/engine_factory.hpp"
#include "measurement/depth_readings.hpp"

namespace rutd {

struct StereoMeasurer::Guards {
  std::mutex mutex;
  std::vector<StereoMeasurer> strips;
};

namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

bool uses_column_windows(const MeasurerConfig& config) { return config.dic && config.column_windows; }

int column_block_rows(StripRoi strip) {
  return strip.rows <= MeasurerConfig::kMaxColumnWindowRows ? 0 : MeasurerConfig::kColumnBlockRows;
}

// Rows matched beyond the measured strip on each side, so the engines' blocks and the DIC window see
// real image rows rather than a replicated border. Column windows read only the measured rows.
int margin_for(const MeasurerConfig& config) {
  const int block = config.engine_config.block_size > 0 ? config.engine_config.block_size : 11;
  if (uses_column_windows(config)) return block / 2 + 2;
  return std::max({block / 2, config.dic_config.half_window, config.dic_config.half_height}) + 2;
}

StripRoi measured_strip(const StereoCalibration& calibration, const MeasurerConfig& config) {
  // stereoRectify keeps the raw image size, so the strip is resolved before the geometry exists.
  const int height = calibration.image_size.height;
  StripRoi strip = default_strip(calibration.image_size);
  if (config.strip.rows > 0) strip = StripRoi{(height - config.strip.rows) / 2, config.strip.rows};
  if (config.strip.first_row) strip.row0 = *config.strip.first_row;
  if (strip.row0 < 0 || strip.rows <= 0 || strip.row0 + strip.rows > height)
    throw std::invalid_argument("measurement.strip first_row/rows (--strip-first-row, --strip-rows): rows " +
                                std::to_string(strip.row0) + ".." + std::to_string(strip.row0 + strip.rows) +
                                " lie outside the calibration's image height " + std::to_string(height));
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
    : config_(config),
      strip_(measured_strip(calibration, config)),
      image_size_(calibration.image_size),
      geometry_(calibration, matched_strip(calibration, config)) {
  validate(config_.conditions);
  // measure()'s engine is made on its first call: the real-time pipeline and replay make their own, and a
  // GPU engine made here too would open the device twice. Bad parameters still throw here.
  check_engine(config_.engine, config_.engine_config);
  if (const std::string problem = gap_fill_window_problem(config_.gap_fill_half_window, config_.dic_config.half_window);
      !problem.empty())
    throw std::invalid_argument("gap_fill_half_window: " + problem);
  if (config_.water.enabled && config_.strip.guards > 0) {
    if (config_.strip.guards > 2 || !(config_.strip.guard_spacing > 0.0 && config_.strip.guard_spacing <= 0.5) ||
        !(config_.strip.guard_after_water_s >= 0.0))
      throw std::invalid_argument(
          "strip guards must be 0..2, guard_spacing within (0, 0.5] and guard_after_water_s at least 0");
    const int height = calibration.image_size.height;
    const int offset = static_cast<int>(std::lround(config_.strip.guard_spacing * height));
    auto guards = std::make_unique<Guards>();
    for (int i = 0; i < config_.strip.guards; ++i) {
      const int row0 = strip_.row0 + (i == 0 ? -offset : offset);
      if (row0 < 0 || row0 + strip_.rows > height || std::abs(row0 - strip_.row0) < strip_.rows) continue;
      MeasurerConfig g = config_;
      g.strip = StripConfig{.rows = strip_.rows, .first_row = row0, .guards = 0};
      // A guard is measured only on the frames the strip finds OK: the frame before is not its last
      // one, so it judges each frame alone.
      g.water.memory_s = 0.0;
      // A GPU engine's guards match on the CPU: a device opened twice more for a strip each is dearer
      // than the CPU's few milliseconds, and the GPU's fallback is the match stage's to log.
      if (g.engine == EngineKind::Gpu) g.engine = EngineKind::Sgbm3Way;
      guards->strips.emplace_back(calibration, g);
    }
    if (!guards->strips.empty()) guards_ = std::move(guards);
  }
}

StereoMeasurer::~StereoMeasurer() = default;
StereoMeasurer::StereoMeasurer(StereoMeasurer&&) noexcept = default;
StereoMeasurer& StereoMeasurer::operator=(StereoMeasurer&&) noexcept = default;

std::vector<StripRoi> StereoMeasurer::guard_strips() const {
  std::vector<StripRoi> out;
  if (guards_)
    for (const StereoMeasurer& g : guards_->strips) out.push_back(g.strip());
  return out;
}

namespace {

// Captured at then_ns, at most window_s before t_ns (and not after it).
bool within_s(std::int64_t then_ns, std::int64_t t_ns, double window_s) {
  const double age_s = 1e-9 * static_cast<double>(t_ns - then_ns);
  return age_s >= 0.0 && age_s <= window_s;
}

// Remembers the capture time of a frame flagged Water (StripConfig::guard_after_water_s).
void note_water(const RutMeasurement& m, std::int64_t t_ns, RutWorkspace& workspace) {
  if ((m.conditions & kConditionWater) == 0) return;
  workspace.water_seen = true;
  workspace.water_seen_ns = t_ns;
}

}  // namespace

bool StereoMeasurer::guards_asked(const RutWorkspace& workspace, std::int64_t t_ns) const {
  return config_.strip.guards_always ||
         (workspace.water_seen && within_s(workspace.water_seen_ns, t_ns, config_.strip.guard_after_water_s));
}

void StereoMeasurer::check_guards(FrameWork& w, RutWorkspace& workspace) const {
  RutMeasurement& m = w.measurement;
  note_water(m, w.frame.t_ns, workspace);
  if (!guards_ || m.status != RutStatus::Ok || !guards_asked(workspace, w.frame.t_ns)) return;
  const bool read_through = (m.conditions & kConditionWater) != 0;
  std::array<std::pair<double, double>, 3> depths;  // the strip's and up to two guards' (StripConfig::guards)
  std::size_t n = 0;
  depths[n++] = {m.depth_mm, m.depth_uncertainty_mm};
  const std::lock_guard lock(guards_->mutex);
  bool refused = false;
  for (StereoMeasurer& guard : guards_->strips) {
    const RutMeasurement g = guard.measure(w.frame.left, w.frame.right, w.frame.skew_ns, w.frame.t_ns);
    ++w.diag.guard_strips;
    if (g.status == RutStatus::Ok && n < depths.size()) depths[n++] = {g.depth_mm, g.depth_uncertainty_mm};
    // Read through clear water here, the bottom must not be hidden there: a lid over clear water is
    // read through where the strip falls on its gaps. Dry here, no water found there: read through it,
    // or the bottom hidden by it (a candidate waterline, read both ways and UNCERTAIN, is no finding: it
    // is how a blotchy soil's shading looks to the waterline's tests).
    const bool water = (g.conditions & kConditionWater) != 0;
    refused = read_through ? g.status == RutStatus::BottomNotSeen
                           : water && (g.status == RutStatus::Ok || g.status == RutStatus::BottomNotSeen);
    if (refused) break;
  }
  // No guard refusing it, but one strip's deepest point at the level of a lid two strips found a moment
  // ago: the lid, lit here like the soil (leaves floating on turbid water were published 25 mm shallow
  // so, each strip having found the lid once, none twice running).
  if (refused || at_lid_of_two_strips(workspace, w.frame.t_ns, {depths.data(), n})) {
    w.diag.water_rule = WaterRule::GuardStrip;
    m.conditions |= kConditionWater;
    m.status = RutStatus::BottomNotSeen;
    note_water(m, w.frame.t_ns, workspace);
  }
}

void StereoMeasurer::read_strips_together(FrameWork& w, const RutWorkspace& workspace) const {
  RutMeasurement& m = w.measurement;
  const double limit = config_.rut.max_depth_uncertainty_mm;
  // Each strip's own uncertainty at most this: a strip far noisier could not contradict the other two.
  const double most = 3.0 * limit;
  const auto usable = [most](double u) { return std::isfinite(u) && u > 0.0 && u <= most; };
  // Only a depth Uncertain and nothing else (no condition but DepthUncertain), and away from water: where
  // the guards are asked for water (guards_asked), check_guards measures them, and a lid's memory must not
  // see one frame twice. The guards are measured even when the strip itself is too noisy: each carries
  // its engine's start and band from the frame before, so the frames they see shape their next readings.
  // A depth found OK only by the low-texture reading (read_low_texture) is read together too: on such
  // ground the profile's noise estimate is least sure (measured: errors beyond 3 u on 5 of 92 frames in
  // snow), so it is published only where the guards confirm it, as their weighted mean, and else refused.
  const bool confirm = w.diag.low_texture_read && m.status == RutStatus::Ok;
  const auto refuse = [&] {
    if (!confirm) return;
    m.status = RutStatus::Uncertain;
    m.conditions |= kConditionUncertain;
  };
  // Nothing confirms it without guards, or near water (where check_guards measures them for water alone);
  // nor is it published with a condition (Overexposed: clipping takes the texture the noise judge counts
  // on; measured: 1.5 mm off on a clipped sand frame).
  const bool asked = guards_asked(workspace, w.frame.t_ns);
  if (confirm && (!guards_ || asked || m.conditions != 0)) return refuse();
  if (!confirm && (!guards_ || asked || m.status != RutStatus::Uncertain || m.conditions != kConditionUncertain))
    return;
  if (!std::isfinite(m.depth_uncertainty_mm) || !(m.depth_uncertainty_mm > 0.0)) return refuse();
  // The strip's and up to two guards' depths (kStrips), then up to kRecentDepths of the last frames'.
  constexpr std::size_t kStrips = 3;
  std::array<DepthReading, kStrips + RutWorkspace::kRecentDepths> depths;
  std::size_t n = 0;
  depths[n++] = {m.depth_mm, m.depth_uncertainty_mm, m.depth_systematic_mm};
  {
    const std::lock_guard lock(guards_->mutex);
    for (StereoMeasurer& guard : guards_->strips) {
      const RutMeasurement g = guard.measure(w.frame.left, w.frame.right, w.frame.skew_ns, w.frame.t_ns);
      ++w.diag.guard_strips;
      const bool clean = g.conditions == 0 || g.conditions == kConditionUncertain;
      if ((g.status == RutStatus::Ok || g.status == RutStatus::Uncertain) && clean && usable(g.depth_uncertainty_mm) &&
          n < kStrips)
        depths[n++] = {g.depth_mm, g.depth_uncertainty_mm, g.depth_systematic_mm};
    }
  }
  if (!usable(m.depth_uncertainty_mm)) return refuse();
  // Readings that agree are read as their weighted mean (combine_depth_readings): only the noise averages
  // out, the shape's parts (a gap beside a wall lost in shadow, the selection at its edge) are the same in
  // every strip and frame over the rut. Readings that scatter beyond their uncertainties widen the mean's:
  // one reading's u too small (a guard with little ground beside the rut, measured 3.1 mm off at u 0.70)
  // must not pull the mean and shrink its u at once. Published where together they are precise enough.
  const auto publish = [&](const std::optional<DepthReading>& together) {
    if (!together || !(together->u_mm <= limit)) return false;
    m.depth_mm = together->depth_mm;
    m.depth_uncertainty_mm = together->u_mm;
    m.depth_systematic_mm = together->systematic_mm;
    m.status = RutStatus::Ok;
    m.conditions = 0;
    m.quality = depth_quality(together->u_mm, limit);
    w.diag.strips_together = true;
    return true;
  };
  // The last frames' own depths, newest first, captured at most frames_together_s before, from depths[n]
  // on: the rut along that stretch of travel. Not a frame a moment after water (guards_asked returned
  // above). Returns how many.
  const double window_s = config_.strip.frames_together_s;
  const auto add_recent = [&](std::size_t from) {
    std::size_t added = 0;
    for (std::size_t k = 0; k < workspace.recent_count && window_s > 0.0; ++k) {
      const auto& r =
          workspace.recent[(workspace.recent_next + RutWorkspace::kRecentDepths - 1 - k) % RutWorkspace::kRecentDepths];
      if (within_s(r.t_ns, w.frame.t_ns, window_s) && from + added < depths.size())
        depths[from + added++] = {r.depth_mm, r.u_mm, r.systematic_mm};
    }
    return added;
  };
  // A depth the low-texture reading alone found needs both guards; one found Uncertain by the first
  // reading, whose noise estimate holds, one guard at least (a guard in a gap or at the image's edge
  // need not cost the frame).
  const std::size_t strips = n;
  const std::size_t recent = add_recent(strips);
  const auto together = n >= (confirm ? 3u : 2u) ? combine_depth_readings(std::span(depths).first(n)) : std::nullopt;
  if (together) {
    // The strips read one frame, and may share its error where the noise estimate fails (measured in
    // snow: a strip and a guard both 1.2-1.4 mm deep at u 0.45-0.53, agreeing; a guard 1.3 mm off at
    // u 0.39 beside a noisier strip): their mean must also agree with the last frames' own depths where
    // these agree among themselves (another stretch of the same rut, other noise), against their
    // weighted mean. It is the strips' mean that is published.
    const auto before =
        recent == 1 ? std::optional{depths[strips]} : combine_depth_readings(std::span(depths).subspan(strips, recent));
    if (before && !combine_depth_readings(std::array{*together, *before})) return refuse();
    if (publish(together)) {
      w.diag.strips_read = static_cast<int>(n);
      return;
    }
  }
  if (confirm) return refuse();
  // Else with the last frames' own depths: the rut along that stretch of travel, where it has not
  // changed by more than the readings' noise (which the chi-square test asks).
  n += recent;
  if (n > strips && publish(combine_depth_readings(std::span(depths).first(n)))) {
    w.diag.strips_read = static_cast<int>(strips);
    w.diag.frames_read = static_cast<int>(n - strips);
  }
}

MatchContext StereoMeasurer::make_match_context() const {
  MatchContext context;
  context.engine = make_engine(config_.engine, config_.engine_config);
  return context;
}

bool StereoMeasurer::rectify(FrameWork& w) const {
  w.diag = MeasurementDiagnostics{};
  w.measurement = RutMeasurement{};  // status NoMeasurement until extract() says otherwise
  w.geometry = RutGeometry{};
  w.measured = false;
  w.strip_row0 = geometry_.roi().row0;
  w.measured_row0 = strip_.row0;
  w.measured_rows = strip_.rows;
  const cv::Mat& l = w.frame.left;
  const cv::Mat& r = w.frame.right;
  if (l.size() != image_size_ || r.size() != image_size_ || l.type() != r.type() || l.channels() != 1 ||
      (l.depth() != CV_8U && l.depth() != CV_16U))
    return false;
  w.strips_ready = false;
  if (device_rectifies(w.frame)) return true;
  const auto t0 = Clock::now();
  geometry_.rectify(l, r, w.left_strip, w.right_strip);
  w.diag.rectify_ms = ms_since(t0);
  w.strips_ready = true;
  return true;
}

bool StereoMeasurer::device_rectifies(const StereoFrame& frame) const {
  return config_.engine == EngineKind::Gpu && config_.rectify_on_device && frame.left.depth() == CV_8U;
}

DicConfig StereoMeasurer::strip_dic_config() const {
  // Only the measured rows are refined; the margin rows were matched as context for the windows.
  DicConfig dic = config_.dic_config;
  dic.row_begin = strip_.row0 - geometry_.roi().row0;
  dic.row_end = dic.row_begin + strip_.rows;
  dic.column_windows = uses_column_windows(config_);
  dic.column_block_rows = column_block_rows(strip_);
  return dic;
}

bool StereoMeasurer::match_raw(FrameWork& w, MatchContext& context, DisparityBand band) const {
  const auto t0 = Clock::now();
  const DicConfig dic = strip_dic_config();
  if (!context.engine->rectify_and_match(w.frame.left, w.frame.right, geometry_, &band, config_.dic ? &dic : nullptr,
                                         w.left_strip, w.right_strip, w.disparity, w.diag.dic))
    return false;
  w.strips_ready = true;
  w.diag.rectified_on_device = true;
  w.diag.disparity_ms = ms_since(t0);
  w.diag.dic_ms = 0;
  w.diag.starts_reused = false;
  return true;
}

void StereoMeasurer::rectify_late(FrameWork& w, MatchContext& context) const {
  const auto t0 = Clock::now();
  DicStats unused;
  w.diag.rectified_on_device = context.engine->rectify_and_match(
      w.frame.left, w.frame.right, geometry_, nullptr, nullptr, w.left_strip, w.right_strip, w.disparity, unused);
  if (!w.diag.rectified_on_device) geometry_.rectify(w.frame.left, w.frame.right, w.left_strip, w.right_strip);
  w.strips_ready = true;
  w.diag.rectify_ms += ms_since(t0);
}

namespace {

// Rows averaged in pairs (2k, 2k + 1): rectified rows stay epipolar lines, so the binned strips match as
// the originals do, in half the rows. An odd last row is dropped.
void bin_rows(const cv::Mat& strip, cv::Mat& binned) {
  cv::resize(strip, binned, cv::Size(strip.cols, std::max(1, strip.rows / 2)), 0, 0, cv::INTER_AREA);
}

// Row y of `disparity` (rows x binned.cols) takes binned row y / 2.
void unbin_rows(const cv::Mat& binned, int rows, cv::Mat& disparity) {
  disparity.create(rows, binned.cols, CV_32FC1);
  for (int y = 0; y < rows; ++y) binned.row(std::min(y / 2, binned.rows - 1)).copyTo(disparity.row(y));
}

}  // namespace

DisparityBand StereoMeasurer::estimate_band(FrameWork& w, MatchContext& context) const {
  if (device_rectifies(w.frame)) {
    const std::optional<DisparityBand> band = context.band.estimate_on_device(
        *context.engine, w.frame.left, w.frame.right, geometry_, config_.range, w.left_strip, w.right_strip);
    if (band) {
      w.strips_ready = true;
      w.diag.rectified_on_device = true;
      w.diag.band_on_device = true;
      return *band;
    }
  }
  if (!w.strips_ready) rectify_late(w, context);
  return context.band.estimate(w.left_strip, w.right_strip, geometry_, config_.range);
}

void StereoMeasurer::match(FrameWork& w, MatchContext& context) const {
  std::optional<DisparityBand> kept = config_.fixed_band ? config_.fixed_band : context.band_tracker.band();
  // Strips left to the engine: with a known band one device submission does everything; a band to
  // estimate is found on the device too (rectifying there), or from strips rectified here.
  const bool matched = !w.strips_ready && kept && match_raw(w, context, *kept);
  if (!w.strips_ready && kept) rectify_late(w, context);
  auto t0 = Clock::now();
  w.diag.band_estimated = !kept;
  w.diag.band = kept ? *kept : estimate_band(w, context);
  w.diag.band_ms = ms_since(t0);
  const int row_begin = strip_.row0 - geometry_.roi().row0;
  const int row_end = row_begin + strip_.rows;

  // Starts from the last frame need a band that still fits, and nothing to be matched afresh.
  const bool reuse = !matched && config_.dic && config_.reuse_starts && !w.diag.band_estimated &&
                     context.previous.size() == w.left_strip.size() &&
                     context.reused_frames < MeasurerConfig::kMaxReusedFrames && context.engine_refined > 0;
  if (!matched) match_in_band(w, context, reuse);
  if (reuse && w.diag.dic.refined < MeasurerConfig::kMinReusedShare * context.engine_refined) {
    // The last frame's disparity no longer starts this one well (the terrain changed): match it again
    // from the engine, so that a reused start never costs a measurement.
    const MeasurementDiagnostics first = w.diag;
    match_in_band(w, context, false);
    w.diag.dic_ms += first.dic_ms;
  }

  if (!config_.fixed_band) {
    context.band_tracker.update(w.diag.band, w.diag.band_estimated, w.disparity, row_begin, row_end);
    if (!w.diag.band_estimated && !context.band_tracker.band()) {
      // The last frame's band no longer fits this one (the terrain jumped): match it again in a band
      // estimated for it, so that a kept band never costs a measurement.
      t0 = Clock::now();
      w.diag.band_estimated = true;
      w.diag.band = estimate_band(w, context);
      w.diag.band_ms += ms_since(t0);
      const MeasurementDiagnostics first = w.diag;
      match_in_band(w, context, false);
      w.diag.disparity_ms += first.disparity_ms;
      w.diag.dic_ms += first.dic_ms;
      context.band_tracker.update(w.diag.band, true, w.disparity, row_begin, row_end);
    }
  }
  if (config_.dic && config_.reuse_starts) w.disparity.copyTo(context.previous);
}

namespace {

// Gaps of at most kReuseGapPx columns in a row of the last refined disparity take the nearer valid
// neighbour as their start (a window rejected on one frame can refine on the next).
constexpr int kReuseGapPx = 4;

void fill_starts(const cv::Mat& previous, cv::Mat& starts) {
  previous.copyTo(starts);
  for (int y = 0; y < starts.rows; ++y) {
    const float* src = previous.ptr<float>(y);
    float* dst = starts.ptr<float>(y);
    for (int x = 0; x < starts.cols; ++x) {
      if (std::isfinite(src[x])) continue;
      for (int k = 1; k <= kReuseGapPx; ++k) {
        if (x - k >= 0 && std::isfinite(src[x - k])) {
          dst[x] = src[x - k];
          break;
        }
        if (x + k < starts.cols && std::isfinite(src[x + k])) {
          dst[x] = src[x + k];
          break;
        }
      }
    }
  }
}

}  // namespace

void StereoMeasurer::match_in_band(FrameWork& w, MatchContext& context, bool reuse) const {
  const DicConfig dic = strip_dic_config();

  auto t0 = Clock::now();
  w.diag.starts_reused = false;
  if (config_.dic) {
    // The GPU engine matches and refines on its device, with the same windows as the CPU DIC below
    // (column windows included; it matches the strips unbinned): disparity_ms covers both, dic_ms stays
    // 0, and its starts are never reused (engine_refined stays 0).
    if (context.engine->compute_refined(w.left_strip, w.right_strip, w.diag.band, dic, w.disparity, w.diag.dic)) {
      w.diag.disparity_ms = ms_since(t0);
      w.diag.dic_ms = 0;
      return;
    }
  }
  w.diag.starts_reused = reuse;
  if (reuse) {
    fill_starts(context.previous, w.disparity);
  } else if (dic.column_windows) {
    // A column window needs only a start within its convergence range (the median of its column), so
    // the engine matches the strips binned 2:1 along columns: half the work.
    bin_rows(w.left_strip, context.left_binned);
    bin_rows(w.right_strip, context.right_binned);
    context.engine->compute(context.left_binned, context.right_binned, w.diag.band, context.disparity_binned);
    unbin_rows(context.disparity_binned, w.left_strip.rows, w.disparity);
  } else {
    context.engine->compute(w.left_strip, w.right_strip, w.diag.band, w.disparity);
  }
  w.diag.disparity_ms = ms_since(t0);

  w.diag.dic = DicStats{};
  w.diag.dic_ms = 0;
  if (config_.dic) {
    t0 = Clock::now();
    w.diag.dic = refine_disparity_dic(w.left_strip, w.right_strip, w.disparity, dic, context.dic);
    w.diag.dic_ms = ms_since(t0);
    if (reuse) {
      ++context.reused_frames;
    } else {
      context.reused_frames = 0;
      context.engine_refined = w.diag.dic.refined;
    }
  }
}

namespace {

bool depth_found(RutStatus status) {
  return status == RutStatus::Ok || status == RutStatus::Uncertain || status == RutStatus::Vegetation;
}

// Marks standing water on the geometry the sinks see: its surface level_mm below the ground line,
// meeting the walls (or a lid's ends) at left_x_mm and right_x_mm.
void mark_water(RutGeometry& g, double level_mm, double left_x_mm, double right_x_mm) {
  g.has_water = true;
  g.water_level_mm = level_mm;
  g.waterline_left_x_mm = left_x_mm;
  g.waterline_right_x_mm = right_x_mm;
}

// Per cross-section bin, of the left strip's pixels that reduce_to_cross_section averaged into it (the
// same rule: the nearest bin to the point's X): the mean grey level, and the texture of
// WaterlineConfig::lid_texture_step, sqrt(mean squared difference to the next row (the previous one on
// the strip's last row) - 2 noise^2) / mean grey level (noise_grey: the strip's noise deviation, grey levels; the
// root's argument is floored at a quarter grey level squared); NaN where none. Returns the mean Y of those points, mm.
double bin_appearance(const cv::Mat& xyz, const cv::Mat& left, int first, const CrossSection& section,
                      double noise_grey, std::vector<double>& brightness, std::vector<double>& texture,
                      std::vector<int>& pixels) {
  const std::size_t bins = section.z_mm.size();
  brightness.assign(bins, 0.0);
  texture.assign(bins, 0.0);  // sums of squared row differences until the end
  pixels.assign(bins, 0);
  double y_sum = 0.0;
  long points = 0;
  for (int r = 0; r < xyz.rows; ++r) {
    const cv::Vec3f* p = xyz.ptr<cv::Vec3f>(r);
    const std::uint8_t* g = left.ptr<std::uint8_t>(first + r);
    const int neighbour = first + r + 1 < left.rows ? first + r + 1 : std::max(first + r - 1, 0);
    const std::uint8_t* next = left.ptr<std::uint8_t>(neighbour);
    for (int u = 0; u < xyz.cols && u < left.cols; ++u) {
      const cv::Vec3f& q = p[u];
      if (!std::isfinite(q[0]) || !std::isfinite(q[1]) || !(q[2] > 0.0f)) continue;
      const long b = std::lround((q[0] - section.x0_mm) / section.dx_mm);
      if (b < 0 || b >= static_cast<long>(bins)) continue;
      const auto k = static_cast<std::size_t>(b);
      const double d = double(next[u]) - double(g[u]);
      brightness[k] += g[u];
      texture[k] += d * d;
      ++pixels[k];
      y_sum += q[1];
      ++points;
    }
  }
  const double noise2 = 2.0 * noise_grey * noise_grey;
  for (std::size_t b = 0; b < bins; ++b) {
    if (pixels[b] == 0) {
      brightness[b] = texture[b] = std::numeric_limits<double>::quiet_NaN();
      continue;
    }
    brightness[b] /= pixels[b];
    texture[b] = std::sqrt(std::max(texture[b] / pixels[b] - noise2, 0.25)) / std::max(brightness[b], 1.0);
  }
  return points > 0 ? y_sum / double(points) : 0.0;
}

// Captured at then_ns, at most memory_s before t_ns (WaterlineConfig::memory_s; 0: never).
bool within_memory(std::int64_t then_ns, std::int64_t t_ns, const WaterlineConfig& c) {
  return c.memory_s > 0.0 && within_s(then_ns, t_ns, c.memory_s);
}

// How far below a waterline (level uncertainty level_u, mm) a depth of uncertainty u must lie to be seen
// below the surface, not at it: min_seen_below_mm, or twice their combined uncertainty.
double seen_below_margin(const WaterlineConfig& c, double u, double level_u) {
  return std::max(c.min_seen_below_mm, 2.0 * std::hypot(u, level_u));
}

// The last frame confirmed a waterline at most memory_s before t_ns.
bool recent(const WaterlineMemory& last, std::int64_t t_ns, const WaterlineConfig& c) {
  return last.line.found && within_memory(last.t_ns, t_ns, c);
}

// A recent waterline (above) at the level of `line`, within twice their combined standard uncertainty and
// level_tolerance_mm.
bool recalls_waterline(const WaterlineMemory& last, const Waterline& line, std::int64_t t_ns,
                       const WaterlineConfig& c) {
  const double tolerance = c.level_tolerance_mm + 2.0 * std::hypot(line.level_u_mm, last.line.level_u_mm);
  return recent(last, t_ns, c) && std::abs(line.level_mm - last.line.level_mm) <= tolerance;
}

// The standard uncertainty of a level span's mean level: its bins' scatter over the root of their number.
double span_level_u(const LevelSpan& span, double bin_mm) {
  const double bins = bin_mm > 0.0 ? std::max(1.0, (span.right_x_mm - span.left_x_mm) / bin_mm + 1.0) : 1.0;
  return span.roughness_mm / std::sqrt(bins);
}

// A lid found at most memory_s before t_ns at level_mm (standard uncertainty level_u_mm), within
// level_tolerance_mm and twice their combined standard uncertainty.
bool lid_at_level(const LidMemory& last, double level_mm, double level_u_mm, std::int64_t t_ns,
                  const WaterlineConfig& c) {
  const double tolerance = c.level_tolerance_mm + 2.0 * std::hypot(level_u_mm, last.level_u_mm);
  return last.found && within_memory(last.t_ns, t_ns, c) && std::abs(level_mm - last.level_mm) <= tolerance;
}

// A lid found at most memory_s before t_ns (WaterlineConfig::memory_s), at the level of `span` within
// level_tolerance_mm and twice their combined standard uncertainty, `span` as wide as a lid must be and
// stepping at one end by what a candidate waterline's steps must reach. Its roughness is not judged: the
// level is the lid's, and against ground as smooth as rendered sand and grass (0.01-0.02 mm from bin to
// bin) foam and leaves lit like the soil scatter 5-10 times more.
bool recalls_lid(const LidMemory& last, const LevelSpan& span, double span_u, std::int64_t t_ns,
                 const WaterlineConfig& c) {
  if (span.right_x_mm - span.left_x_mm < c.lid_min_width_mm) return false;
  // An end without a wall beyond it (NaN) leaves the other to judge.
  const double edge = std::fmax(std::abs(span.left_step), std::abs(span.right_step));
  const double need = c.candidate_step_over_ground / c.step_over_ground * span.step_threshold;
  return edge >= need && lid_at_level(last, span.level_mm, span_u, t_ns, c);
}

// A lid found at `level_mm` at t_ns, `before` the memory as the frame before left it: confirmed where
// that frame, at most memory_s before, found a lid at the same level.
LidMemory lid_found(const LidMemory& before, std::int64_t t_ns, double level_mm, double level_u_mm,
                    const WaterlineConfig& c) {
  return LidMemory{t_ns, true, level_mm, level_u_mm, lid_at_level(before, level_mm, level_u_mm, t_ns, c)};
}

}  // namespace

bool StereoMeasurer::at_lid_of_two_strips(const RutWorkspace& workspace, std::int64_t t_ns,
                                          std::span<const std::pair<double, double>> depths) const {
  const WaterlineConfig& c = config_.water;
  std::array<const LidMemory*, 3> lids{};
  std::size_t n = 0;
  lids[n++] = &workspace.last_lid;
  for (const StereoMeasurer& guard : guards_->strips)
    if (n < lids.size()) lids[n++] = &guard.rut_ws_.last_lid;
  for (std::size_t a = 0; a < n; ++a) {
    for (std::size_t b = 0; b < n; ++b) {
      // Lid a, found within memory_s (lid_at_level asks), at the level of lid b, found within it too.
      if (a == b || !lid_at_level(*lids[b], lids[a]->level_mm, lids[a]->level_u_mm, t_ns, c)) continue;
      for (const auto& [depth, u] : depths)
        if (lid_at_level(*lids[a], depth, u, t_ns, c)) return true;
    }
  }
  return false;
}

namespace {

// A surface at level_mm, meeting the walls at left_x_mm and right_x_mm, hides the bottom.
void refuse_hidden(RutMeasurement& m, RutGeometry& g, double level_mm, double left_x_mm, double right_x_mm) {
  m.conditions |= kConditionWater;
  mark_water(g, level_mm, left_x_mm, right_x_mm);
  m.status = RutStatus::BottomNotSeen;
}

// A level span taken for a floating lid: the bottom is not seen.
void refuse_as_lid(RutMeasurement& m, RutGeometry& g, const LevelSpan& lid) {
  refuse_hidden(m, g, lid.level_mm, lid.left_x_mm, lid.right_x_mm);
}

}  // namespace

// Standing water (rut/waterline.hpp): a level span at the bottom, not much rougher than the ground, lit
// unlike a wall beside it, textured unlike the soil or brighter than it all round is a floating lid,
// refused first; with a waterline on both walls, a profile that stops at it (a lid, opaque water) or
// follows it over most of the span (a lid with gaps) hides the bottom and is refused; one that goes on
// below it is the bottom seen through the water, measured again on the section corrected for refraction and published
// flagged Water, its uncertainty widened by the refraction model's (the index, and the waterline's level). With no
// waterline, a level span unlike the flat ground is a lid after all (LevelSpan::unlike_ground): the bottom seen through
// clear water is unlike the ground too, but under a waterline.
void StereoMeasurer::read_through_water(FrameWork& w, RutWorkspace& workspace, const cv::Mat& measured,
                                        int first) const {
  RutMeasurement& m = w.measurement;
  const WaterlineConfig& c = config_.water;
  if (!c.enabled || !depth_found(m.status) || !workspace.geometry.has_rut || !workspace.geometry.has_line) return;
  // The strip's noise for the texture, from sixteen of its rows (its own: rectification's interpolation
  // smooths the raw images' noise).
  const ImageSignal strip = image_signal(w.left_strip, first, first + strip_.rows, 16, w.checks.histogram);
  const double noise_grey = std::isfinite(strip.noise) ? 255.0 * strip.noise : 0.0;
  const double y_mm = bin_appearance(measured, w.left_strip, first, w.section, noise_grey, w.bin_brightness,
                                     w.bin_texture, w.bin_pixels);
  const LevelSpan lid = find_level_span(w.section, w.bin_brightness, w.bin_texture, workspace.geometry, c, w.water);
  const double lid_u = span_level_u(lid, w.section.dx_mm);
  // Lit unlike a wall, of another material than the soil, or brighter all round than soil there can be:
  // floating debris at that level.
  if (lid.found || lid.other_material || lid.brighter_all_round) {
    refuse_as_lid(m, workspace.geometry, lid);
    w.diag.water_rule = WaterRule::Lid;
    workspace.last_waterline = WaterlineMemory{};
    workspace.last_lid = lid_found(workspace.last_lid, w.frame.t_ns, lid.level_mm, lid_u, c);
    return;
  }
  // Taken out: a frame that confirms no waterline of its own passes none on. The lid is put back unless
  // this frame finds one of its own: a frame that only recalls it does not renew it (one chance finding
  // would carry on for ever), and one that finds it renews it though it would be recalled.
  const WaterlineMemory last = std::exchange(workspace.last_waterline, WaterlineMemory{});
  const LidMemory last_lid = std::exchange(workspace.last_lid, LidMemory{});
  read_waterline(w, workspace, last, last_lid, lid, lid_u, y_mm);
  if (workspace.last_lid.found) return;
  workspace.last_lid = last_lid;
  if (m.status != RutStatus::Ok) return;
  // Published at the level of the lid a frame found a moment ago, stepping at an end by a candidate's
  // share: that lid, lit here more like the soil. A lid found on two frames running is recalled by a
  // profile whose deepest point lies at its level, however narrow its level span and faint its steps.
  if (recalls_lid(last_lid, lid, lid_u, w.frame.t_ns, c)) {
    refuse_as_lid(m, workspace.geometry, lid);
    w.diag.water_rule = WaterRule::LidRecalled;
  } else if (last_lid.confirmed && lid_at_level(last_lid, m.depth_mm, m.depth_uncertainty_mm, w.frame.t_ns, c)) {
    // Where the surface meets the walls is not known here: the level span's ends, or the deepest point.
    RutGeometry& g = workspace.geometry;
    const bool span = lid.right_x_mm > lid.left_x_mm;
    refuse_hidden(m, g, last_lid.level_mm, span ? lid.left_x_mm : g.deepest_x_mm,
                  span ? lid.right_x_mm : g.deepest_x_mm);
    w.diag.water_rule = WaterRule::LidRecalled;
  }
}

// The waterline part of read_through_water: `last` and `last_lid` are the waterline's and the lid's memory
// as the frame before left them, `lid` this frame's level span (no lid by its own evidence). A lid this frame finds (a
// level span unlike the ground under no waterline, a waterline the profile stops at) goes to workspace.last_lid.
void StereoMeasurer::read_waterline(FrameWork& w, RutWorkspace& workspace, const WaterlineMemory& last,
                                    const LidMemory& last_lid, const LevelSpan& lid, double lid_u, double y_mm) const {
  RutMeasurement& m = w.measurement;
  const WaterlineConfig& c = config_.water;
  Waterline line = find_waterline(w.section, w.bin_brightness, workspace.geometry, c, w.water);
  // Short of a waterline, a candidate (WaterlineConfig::candidate_step_over_ground): darkening below on
  // both walls and over the whole span between them by at least wetting's least (min_step), as wet soil
  // or the water's body colour darkens (a lid that brightens is the lid check's); a waterline after all
  // where that span darkens by a waterline's threshold.
  bool candidate = false, recalled = false;
  if (!line.found && c.candidate_step_over_ground > 0.0) {
    WaterlineConfig relaxed = c;
    relaxed.step_over_ground = c.candidate_step_over_ground;
    relaxed.min_submerged_step = std::max(c.min_submerged_step, c.min_step);  // all of it wet
    const Waterline weak = find_waterline(w.section, w.bin_brightness, workspace.geometry, relaxed, w.water);
    // ... with each step's window above it on its wall, inside the opening: at the rim the window
    // holds the crest, which turns from the light (a rut in shade is darker all the way down).
    const RutGeometry& g = workspace.geometry;
    if (weak.found && weak.left_step < 0.0 && weak.right_step < 0.0 &&
        weak.left_x_mm - g.left_x_mm >= c.step_window_mm && g.right_x_mm - weak.right_x_mm >= c.step_window_mm) {
      line = weak;
      // The whole submerged span darker by what a confirmed line's steps must reach, than the walls
      // above it and than the dry flat ground on both sides of the rut (a mud blotched on a larger scale
      // than the rut darkens a span against its walls by chance): the water is there, and the steps,
      // short of it on one wall or both, only place its level.
      const double need = waterline_step_threshold(c, weak.ground_spread);
      candidate = !(-weak.submerged_step >= need && -weak.submerged_ground_step >= need);
      recalled = candidate && recalls_waterline(last, weak, w.frame.t_ns, c);
      candidate = candidate && !recalled;
    }
  }
  if (line.found && !candidate && !recalled) workspace.last_waterline = WaterlineMemory{w.frame.t_ns, line};
  // No steps here, but a level span unlike the ground deeper than the waterline confirmed a moment ago:
  // debris floats at the surface, so what lies deeper than that surface by more than the two levels'
  // margin is the bottom seen through the water, and is read through it at that line (measured: 19 mm of
  // clear water on snow, a frame whose walls showed no steps took the bottom it saw through the water,
  // lit unlike the snow, for a lid and was refused; read through, it is 0.4 mm off the truth).
  if (!line.found && lid.unlike_ground && recent(last, w.frame.t_ns, c) &&
      lid.level_mm - last.line.level_mm >= seen_below_margin(c, lid_u, last.line.level_u_mm))
    line = last.line;
  if (!line.found) {
    // No waterline above a level span unlike the ground: a lid whose edges the walls do not show.
    if (lid.unlike_ground) {
      refuse_as_lid(m, workspace.geometry, lid);
      w.diag.water_rule = WaterRule::LidUnlikeGround;
      workspace.last_lid = lid_found(last_lid, w.frame.t_ns, lid.level_mm, lid_u, c);
    } else if (recent(last, w.frame.t_ns, c)) {
      // No steps at all, a moment after the last frame confirmed a waterline: the water may well be
      // there, its steps too faint on these walls. Read both ways at its level, as a candidate is (so
      // is a frame whose candidate lies at another level, below).
      weigh_candidate_waterline(w, workspace, last.line, y_mm);
    }
    return;
  }
  if (candidate) {
    weigh_candidate_waterline(w, workspace, line, y_mm);
    // Steps at another level than the waterline confirmed a moment ago: that one is weighed too.
    if (recent(last, w.frame.t_ns, c)) weigh_candidate_waterline(w, workspace, last.line, y_mm);
    return;
  }
  const auto mark = [&](RutGeometry& g) { mark_water(g, line.level_mm, line.left_x_mm, line.right_x_mm); };
  m.conditions |= kConditionWater;
  const double seen_below = m.depth_mm - line.level_mm;
  const double u = std::isfinite(m.depth_uncertainty_mm) ? m.depth_uncertainty_mm : 0.0;
  // Water darkens what is seen through it (wet soil, the body colour; the surface reflects a few per cent
  // looking down): a span brighter than the walls above its waterline is a lid at that level, and what
  // stereo finds deeper is a gap in it or a leak of the matching windows, not the bottom.
  const bool brightens = line.left_step > 0.0 && line.right_step > 0.0;
  const double margin = seen_below_margin(c, u, line.level_u_mm);
  // So is one that follows the surface over most of its width (WaterlineConfig::min_share_seen_below):
  // a lid, the bottom glimpsed through its gaps.
  if (brightens || seen_below < margin ||
      share_seen_below(w.section, workspace.geometry, line, margin) < c.min_share_seen_below) {
    mark(workspace.geometry);
    w.diag.water_rule = WaterRule::WaterlineHides;
    m.status = RutStatus::BottomNotSeen;
    // The surface hides the bottom at the waterline's level: a lid (or opaque water) the next frames may
    // show lit like the soil.
    workspace.last_lid = lid_found(last_lid, w.frame.t_ns, line.level_mm, line.level_u_mm, c);
    return;
  }
  // A waterline at the level of a lid found a moment ago: the same debris, the bottom seen in its gaps.
  if (lid_at_level(last_lid, line.level_mm, line.level_u_mm, w.frame.t_ns, c)) {
    mark(workspace.geometry);
    w.diag.water_rule = WaterRule::WaterlineAtLid;
    m.status = RutStatus::BottomNotSeen;
    return;
  }
  const RutGeometry apparent = workspace.geometry;
  w.diag.water_rule = WaterRule::ReadThrough;  // a bottom the corrected section lacks too: BOTTOM_NOT_SEEN
  refract_section(w.section, apparent, line.level_mm, c.refractive_index, geometry_.baseline_mm(), y_mm, w.refracted,
                  w.water);
  RutMeasurement r = extract_rut(w.refracted, config_.rut, workspace);
  if (!depth_found(r.status) || !workspace.geometry.has_rut) {
    workspace.geometry = apparent;
    mark(workspace.geometry);
    m.status = RutStatus::BottomNotSeen;
    return;
  }
  // depth ~ level + n (apparent depth - level): the index's share and the level's, (1 - n) per mm.
  const double u_model = std::hypot(seen_below * c.refractive_index_u, (c.refractive_index - 1.0) * line.level_u_mm);
  r.depth_uncertainty_mm = std::hypot(r.depth_uncertainty_mm, u_model);
  r.conditions |= m.conditions;
  const double limit = config_.rut.max_depth_uncertainty_mm;
  if (r.status == RutStatus::Ok || r.status == RutStatus::Uncertain) {
    r.quality = depth_quality(r.depth_uncertainty_mm, limit);
    if (r.depth_uncertainty_mm > limit) {
      r.status = RutStatus::Uncertain;
      r.conditions |= kConditionUncertain;
    }
  }
  r.vertical_disparity_px = m.vertical_disparity_px;
  m = r;
  mark(workspace.geometry);
  workspace.geometry.refracted = true;
  std::swap(w.section, w.refracted);
}

// A candidate waterline: the frame is read either dry or through water at that level, and the evidence
// does not decide. The two readings are two hypotheses, so their half difference is a standard
// uncertainty of the depth (a two-point distribution's): where it takes the depth's uncertainty over
// max_depth_uncertainty_mm the frame is refused as UNCERTAIN with the Water condition (the dry depth
// kept); where the readings agree that closely, the dry reading stands unflagged.
void StereoMeasurer::weigh_candidate_waterline(FrameWork& w, RutWorkspace& workspace, const Waterline& line,
                                               double y_mm) const {
  RutMeasurement& m = w.measurement;
  const WaterlineConfig& c = config_.water;
  if (m.status != RutStatus::Ok || m.depth_mm - line.level_mm < c.min_seen_below_mm) return;
  const RutGeometry dry = workspace.geometry;
  refract_section(w.section, dry, line.level_mm, c.refractive_index, geometry_.baseline_mm(), y_mm, w.refracted,
                  w.water);
  const RutMeasurement wet = extract_rut(w.refracted, config_.rut, workspace);
  workspace.geometry = dry;
  if (!depth_found(wet.status)) return;
  const double u = std::hypot(m.depth_uncertainty_mm, 0.5 * (wet.depth_mm - m.depth_mm));
  const double limit = config_.rut.max_depth_uncertainty_mm;
  if (!(u > limit)) return;
  m.depth_uncertainty_mm = u;
  m.status = RutStatus::Uncertain;
  m.conditions |= kConditionWater | kConditionUncertain;
  m.quality = depth_quality(u, limit);
  w.diag.water_rule = WaterRule::Candidate;
  mark_water(workspace.geometry, line.level_mm, line.left_x_mm, line.right_x_mm);
}

namespace {

// A depth (standard uncertainty u) within twice its combined uncertainty with the remembered dry one's,
// and within dry_tolerance_mm.
bool agree_dry(const DryMemory& last, double depth_mm, double u, const WaterlineConfig& c) {
  const double tolerance = std::min(c.dry_tolerance_mm, 2.0 * std::hypot(u, last.depth_u_mm));
  return std::abs(depth_mm - last.depth_mm) <= tolerance;
}

// The rules that judge the strip by its own looks on one frame (or recall a lid one such frame found): a
// level span taken for a lid, a waterline the profile stops at, a candidate read both ways. Not a
// waterline at a lid's level, a reading through the water, nor the frame checks'.
bool judged_by_looks(WaterRule rule) {
  return rule == WaterRule::Lid || rule == WaterRule::LidUnlikeGround || rule == WaterRule::WaterlineHides ||
         rule == WaterRule::Candidate || rule == WaterRule::LidRecalled;
}

}  // namespace

// A flat rut bottom can look like a lid to one strip on one frame: its brightness steps where the walls'
// slope changes, its span is level and smooth, and every single-frame feature of it overlaps with real
// lids' (see WaterlineConfig). What a lid cannot do is lie where the rut's bottom was read, dry, on the
// frames just before, unless the rut ran into the water between them. So a looks rule's finding is
// overruled, and the frame's dry reading published, where
//   - its dry reading was OK with no condition;
//   - the last frame dry by its own looks (no water rule, not overruled) is at most memory_s old and was
//     steady: its depth agreed with the dry frame's before it (agree_dry), so the rut was not deepening by
//     more than that from frame to frame (a rut plunging 2 mm a frame into a pool whose lid lies at the
//     last dry depth was read 1.9 mm short without this test);
//   - this dry reading agrees with that depth (agree_dry);
//   - both guard strips, measured on this frame alone, find the bottom dry by their own looks: water lies
//     along the rut, and a strip entering a pool has a guard ahead of it already in it (a rut deepening
//     into a pool while its frames read the surface steadily was read 1.2 mm short with the strip alone).
// The frame is then as it was before read_through_water: its geometry, and the waterline's and the lid's
// memory, so that the overruled finding is recalled by no later frame. It does not renew the dry memory.
void StereoMeasurer::recall_dry(FrameWork& w, RutWorkspace& workspace, const DryReading& before) const {
  const WaterlineConfig& c = config_.water;
  const DryMemory& last = workspace.last_dry;
  const RutMeasurement& m = before.measurement;
  if (!(c.dry_tolerance_mm > 0.0) || !judged_by_looks(w.diag.water_rule) || m.status != RutStatus::Ok ||
      m.conditions != 0 || !last.found || !last.steady || !within_memory(last.t_ns, w.frame.t_ns, c) ||
      !agree_dry(last, m.depth_mm, m.depth_uncertainty_mm, c) || !guards_dry(w))
    return;
  w.measurement = m;
  workspace.geometry = before.geometry;
  workspace.last_waterline = before.last_waterline;
  workspace.last_lid = before.last_lid;
  w.diag.dry_overruled = w.diag.water_rule;
  w.diag.water_rule = WaterRule::None;
}

bool StereoMeasurer::guards_dry(FrameWork& w) const {
  if (!guards_ || guards_->strips.size() < 2) return false;
  const std::lock_guard lock(guards_->mutex);
  for (StereoMeasurer& guard : guards_->strips) {
    const RutMeasurement g = guard.measure(w.frame.left, w.frame.right, w.frame.skew_ns, w.frame.t_ns);
    ++w.diag.guard_strips;
    if (g.status != RutStatus::Ok || g.conditions != 0) return false;
  }
  return true;
}

void StereoMeasurer::remember_frame(const FrameWork& w, RutWorkspace& workspace) const {
  const RutMeasurement& m = w.measurement;
  DryMemory& last = workspace.last_dry;
  // The frame's depth, for the next frames to be read with (read_strips_together): an OK frame's measured
  // by its strips (alone or together), or an UNCERTAIN one's for its noise alone (as the strip read it).
  // Not one read with the frames before already (each reading counts once in a mean), nor one the dry
  // memory published.
  const double limit = config_.rut.max_depth_uncertainty_mm;
  const double u = m.depth_uncertainty_mm;
  // A frame flagged Water clears both memories.
  if ((m.conditions & kConditionWater) != 0) {
    workspace.recent_count = 0;
    last = DryMemory{};
    return;
  }
  const bool not_overruled = w.diag.dry_overruled == WaterRule::None;
  const bool ok_alone = m.status == RutStatus::Ok && m.conditions == 0;
  const bool noisy = m.status == RutStatus::Uncertain && m.conditions == kConditionUncertain;
  if (w.diag.frames_read == 0 && not_overruled && (ok_alone || noisy) && std::isfinite(u) && u > 0.0 &&
      u <= 3.0 * limit) {
    workspace.recent[workspace.recent_next] = {w.frame.t_ns, m.depth_mm, u, m.depth_systematic_mm};
    workspace.recent_next = (workspace.recent_next + 1) % RutWorkspace::kRecentDepths;
    workspace.recent_count = std::min(workspace.recent_count + 1, RutWorkspace::kRecentDepths);
  }
  if (ok_alone && not_overruled) {
    const bool steady = last.found && within_memory(last.t_ns, w.frame.t_ns, config_.water) &&
                        agree_dry(last, m.depth_mm, m.depth_uncertainty_mm, config_.water);
    last = DryMemory{w.frame.t_ns, true, m.depth_mm, m.depth_uncertainty_mm, steady};
  }
}

const char* water_rule_name(WaterRule rule) {
  switch (rule) {
    case WaterRule::None: return "";
    case WaterRule::Lid: return "lid";
    case WaterRule::LidRecalled: return "lid_recalled";
    case WaterRule::LidUnlikeGround: return "lid_unlike_ground";
    case WaterRule::WaterlineHides: return "waterline_hides";
    case WaterRule::WaterlineAtLid: return "waterline_at_lid";
    case WaterRule::ReadThrough: return "read_through";
    case WaterRule::Candidate: return "candidate";
    case WaterRule::GuardStrip: return "guard_strip";
    case WaterRule::FrameCheck: return "frame_check";
  }
  return "";
}

std::string gap_fill_window_problem(int half_window, int narrow_half_window) {
  if (half_window == 0 || (half_window > narrow_half_window && half_window <= 15)) return {};
  return "expected 0 (off) or " + std::to_string(narrow_half_window + 1) + "..15, got " + std::to_string(half_window);
}

namespace {

// dst: src with each row's runs of NaN between two valid values, in rows [row_begin, row_end), filled by
// linear interpolation between them; runs at a row's ends stay NaN unless to_ends, which carries the
// outermost value out to them; other rows NaN. The start of a second DIC reading of the gaps: a wall the
// windows rejected lies between the values at its ends to within the DIC's convergence range far more
// often than the engine's start there exists (reused starts carry the last frame's gaps, and a GPU
// engine keeps its start on the device). to_ends for the low-texture reading: on plain snow the engine
// may match only the rut's shaded walls, and the ground beyond, near a plane, lies within the DIC's reach
// of their outer edges.
void carry_across_gaps(const cv::Mat& src, int row_begin, int row_end, cv::Mat& dst, bool to_ends = false) {
  dst.create(src.size(), CV_32FC1);
  dst.setTo(std::numeric_limits<float>::quiet_NaN());
  for (int r = std::max(row_begin, 0); r < std::min(row_end, src.rows); ++r) {
    const float* in = src.ptr<float>(r);
    float* out = dst.ptr<float>(r);
    int first = -1, last = -1;
    for (int c = 0; c < src.cols; ++c) {
      if (std::isnan(in[c])) continue;
      out[c] = in[c];
      if (last >= 0 && c - last > 1) {
        const float step = (in[c] - in[last]) / static_cast<float>(c - last);
        for (int k = last + 1; k < c; ++k) out[k] = in[last] + step * static_cast<float>(k - last);
      }
      if (first < 0) first = c;
      last = c;
    }
    if (to_ends && first >= 0) {
      for (int k = 0; k < first; ++k) out[k] = in[first];
      for (int k = last + 1; k < src.cols; ++k) out[k] = in[last];
    }
  }
}

}  // namespace

void StereoMeasurer::read_gaps(FrameWork& w, RutWorkspace& workspace, int first) const {
  const RutMeasurement& m = w.measurement;
  const RutGeometry& g = workspace.geometry;
  const double limit = config_.rut.max_depth_uncertainty_mm;
  if (config_.gap_fill_half_window <= 0 || !config_.dic || m.status != RutStatus::Uncertain || !g.has_rut ||
      !(g.unseen_depth_mm > 0.0) || w.disparity.empty())
    return;
  // Only where the gaps alone push u over the limit: the rest of u is the narrow windows' own.
  const double u_gap = g.unseen_depth_mm / std::sqrt(3.0);
  const double u = m.depth_uncertainty_mm;
  if (!(u * u - u_gap * u_gap <= limit * limit)) return;
  DicConfig wide = strip_dic_config();
  wide.half_window = config_.gap_fill_half_window;
  // A wall of slope s (dZ/dX) at range Z changes the disparity by B s / Z px a pixel (0.5, the first
  // reading's bound, at about 65 degrees with 117 mm of baseline at 500 mm): windows started from a
  // line across a gap reach steep snow walls only through steeper warps on the way (measured: with 0.5
  // they converge on a fraction of the gap's columns, with 2 on nearly all).
  wide.max_gradient = 2.0;
  // Started from a line across the gap, a window converges in more steps than from the engine's start.
  wide.max_iterations = 60;
  carry_across_gaps(w.disparity, wide.row_begin, wide.row_end, w.gap_disparity);
  refine_disparity_dic(w.left_strip, w.right_strip, w.gap_disparity, wide, w.gap_dic);
  geometry_.reproject(w.gap_disparity, w.gap_xyz);
  reduce_to_cross_section(w.gap_xyz.rowRange(first, first + strip_.rows), config_.rut, w.gap_section);
  w.measurement = extract_rut(w.section, config_.rut, workspace, &w.gap_section);
  w.diag.gaps_read = true;
}

void StereoMeasurer::read_low_texture(FrameWork& w, RutWorkspace& workspace, const PairSignal& signal,
                                      int first) const {
  const RutStatus s = w.measurement.status;
  if (!config_.low_texture_read || !config_.dic || w.disparity.empty() ||
      (s != RutStatus::TooFewPoints && s != RutStatus::NoGround && s != RutStatus::Uncertain))
    return;
  // The raw images' noise, in the strips' 8-bit grey levels. Rectification's interpolation leaves the
  // strips less noisy than the raw pixels (bilinear: down to a quarter of the variance), so the bound errs
  // on the side of keeping a window; the correlation floor (min_noise_zncc) still holds.
  const double noise = 255.0 * std::max(signal.left.noise, signal.right.noise);
  if (!(noise > 0.0)) return;
  DicConfig dic = strip_dic_config();
  dic.noise_grey = noise;
  carry_across_gaps(w.disparity, dic.row_begin, dic.row_end, w.low_disparity, true);
  const DicStats stats = refine_disparity_dic(w.left_strip, w.right_strip, w.low_disparity, dic, w.gap_dic);
  if (stats.refined <= w.diag.dic.refined) return;  // the noise kept no window the first reading lost
  geometry_.reproject(w.low_disparity, w.xyz);
  reduce_to_cross_section(w.xyz.rowRange(first, first + strip_.rows), config_.rut, w.section);
  cv::swap(w.disparity, w.low_disparity);
  w.measurement = extract_rut(w.section, config_.rut, workspace);
  w.diag.low_texture_read = true;
  w.diag.gaps_read = false;
  read_gaps(w, workspace, first);
}

void StereoMeasurer::extract(FrameWork& w, RutWorkspace& workspace) const {
  auto t0 = Clock::now();
  geometry_.reproject(w.disparity, w.xyz);
  // Only the configured strip is measured: the margin rows were matched for context.
  const int first = strip_.row0 - geometry_.roi().row0;
  const cv::Mat measured = w.xyz.rowRange(first, first + strip_.rows);
  w.diag.reproject_ms = ms_since(t0);

  t0 = Clock::now();
  reduce_to_cross_section(measured, config_.rut, w.section);
  w.measurement = extract_rut(w.section, config_.rut, workspace);
  // The raw rows numbered as the measured strip's (near them: rectification moves rows little about the
  // principal row, and the light is the same a few rows away): sixteen of them per camera tell the light
  // (ConditionConfig::low_light_texture_to_noise) and the noise (read_low_texture).
  PairSignal signal;
  if (config_.conditions.enabled || config_.low_texture_read) {
    signal.left = image_signal(w.frame.left, strip_.row0, strip_.row0 + strip_.rows, 16, w.checks.histogram);
    signal.right = image_signal(w.frame.right, strip_.row0, strip_.row0 + strip_.rows, 16, w.checks.histogram);
  }
  read_gaps(w, workspace, first);
  read_low_texture(w, workspace, signal, first);
  const cv::Mat points = w.xyz.rowRange(first, first + strip_.rows);  // read_low_texture may have read it again
  const DryReading dry{w.measurement, workspace.geometry, workspace.last_waterline, workspace.last_lid};
  read_through_water(w, workspace, points, first);
  recall_dry(w, workspace, dry);
  if (!config_.conditions.enabled) signal = PairSignal{};
  check_frame(w.left_strip, w.right_strip, w.disparity, first, first + strip_.rows, geometry_, workspace.geometry,
              w.diag.band, w.frame.skew_ns, signal, config_.conditions, w.checks, w.measurement);
  if ((w.measurement.conditions & kConditionWater) != 0 && w.diag.water_rule == WaterRule::None)
    w.diag.water_rule = WaterRule::FrameCheck;
  read_strips_together(w, workspace);
  check_guards(w, workspace);
  remember_frame(w, workspace);
  w.geometry = workspace.geometry;
  w.measured = true;
  w.diag.rut_ms = ms_since(t0);
}

PublishedFrame published_frame(const FrameWork& w, const SensorHealth& health) {
  PublishedFrame f;
  f.seq = w.frame.seq;
  f.t_ns = w.frame.t_ns;
  f.clock = w.frame.clock;
  f.skew_ns = w.frame.skew_ns;
  f.measurement = w.measurement;
  f.health = health;
  if (!w.frame.left.empty()) {
    f.left_raw = &w.frame.left;
    f.right_raw = &w.frame.right;
  }
  f.times = StageTimes{w.diag.rectify_ms, w.diag.band_ms,      w.diag.disparity_ms,
                       w.diag.dic_ms,     w.diag.reproject_ms, w.diag.rut_ms};
  if (!w.measured) return f;
  f.left_strip = &w.left_strip;
  f.right_strip = &w.right_strip;
  f.strip_row0 = w.strip_row0;
  f.measured_row0 = w.measured_row0;
  f.measured_rows = w.measured_rows;
  f.disparity = &w.disparity;
  f.section = &w.section;
  f.geometry = &w.geometry;
  return f;
}

RutMeasurement StereoMeasurer::measure(const cv::Mat& left_raw, const cv::Mat& right_raw, std::int64_t skew_ns,
                                       std::int64_t t_ns) {
  // Shallow copies: the pixels stay the caller's.
  work_.frame.left = left_raw;
  work_.frame.right = right_raw;
  work_.frame.skew_ns = skew_ns;
  work_.frame.t_ns = t_ns;
  if (rectify(work_)) {
    if (!context_.engine) context_ = make_match_context();
    match(work_, context_);
    extract(work_, rut_ws_);
  }
  return work_.measurement;
}

}  // namespace rutd
