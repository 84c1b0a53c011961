#include "web/web_view.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "web/web_overlay.hpp"

namespace rutd {
namespace {

constexpr std::int64_t kBinNs = 100'000'000;  // 100 ms
constexpr std::size_t kBins = 600;            // one minute
constexpr std::size_t kSegments = 100;

std::string num(double v, int decimals) { return std::isfinite(v) ? fmt::format("{:.{}f}", v, decimals) : "null"; }

// What each status means, for the installer (names as on CAN: config/rutd.dbc, RutStatusTable).
const char* status_meaning(RutStatus s) {
  switch (s) {
    case RutStatus::Ok: return "depth measured and trusted";
    case RutStatus::NoRut: return "ground seen, no rut between two piles";
    case RutStatus::TooFewPoints: return "too little of the cross-section matched";
    case RutStatus::NoGround: return "no undisturbed ground beside the rut to fit the ground line";
    case RutStatus::RutAtEdge: return "the rut reaches the edge of the view: aim the cameras at its middle";
    case RutStatus::NoMeasurement: return "no pair could be measured";
    case RutStatus::LensObstructed: return "a lens is covered or dirty";
    case RutStatus::BadExposure: return "the strip is too dark or saturated: adjust exposure or gain";
    case RutStatus::CalibrationDrift: return "the cameras moved against each other: calibrate again";
    case RutStatus::BottomNotSeen: return "water or a flat patch hides the rut bottom";
    case RutStatus::Vegetation: return "vegetation above the soil";
    case RutStatus::Uncertain: return "the depth's uncertainty is above the limit";
    case RutStatus::Unsynchronised: return "the cameras exposed too far apart: check the trigger";
  }
  return "unknown status";
}

struct Bit {
  const char* name;  // the CAN signal's name (config/rutd.dbc)
  bool set;
  const char* meaning;
};

std::string bits_json(std::initializer_list<Bit> bits) {
  std::string out = "[";
  for (const Bit& b : bits)
    out += fmt::format(R"({}{{"name":"{}","set":{},"meaning":"{}"}})", out.size() > 1 ? "," : "", b.name,
                       b.set ? "true" : "false", b.meaning);
  return out + "]";
}

std::string conditions_json(std::uint8_t c) {
  return bits_json({
      {"Water", (c & kConditionWater) != 0, "standing water or a flat textureless patch in the rut"},
      {"LeftLensObstructed", (c & kConditionLeftObstructed) != 0, "the left lens is (partly) covered"},
      {"RightLensObstructed", (c & kConditionRightObstructed) != 0, "the right lens is (partly) covered"},
      {"LowLight", (c & kConditionLowLight) != 0, "the strip is too dark"},
      {"Overexposed", (c & kConditionOverexposed) != 0, "the strip is saturated"},
      {"Vegetation", (c & kConditionVegetation) != 0, "vegetation above the soil"},
      {"CalibrationDrift", (c & kConditionCalibrationDrift) != 0, "features off the epipolar lines"},
      {"DepthUncertain", (c & kConditionUncertain) != 0, "depth uncertainty above the limit"},
  });
}

std::string health_json(const SensorHealth& h) {
  return bits_json({
      {"NoCamera", h.no_camera, "no pair from the cameras for too long"},
      {"StaleFrames", h.stale_frames, "pairs arrived too old to publish"},
      {"CalibrationInvalid", h.calibration_invalid, "the calibration does not fit the cameras"},
      {"LowTexture", h.low_texture, "too little texture to match"},
      {"FrameDrops", h.frame_drops, "pairs dropped: the pipeline is behind the cameras"},
      {"CanTxDrops", h.can_tx_drops, "CAN frames not sent"},
      {"BusOff", h.bus_off, "the CAN controller is bus-off"},
      {"RecordingError", h.recording_error, "the recording or the measurement CSV failed"},
  });
}

std::string aiming_json(const CameraAiming& a) {
  std::string hist;
  for (std::size_t i = 0; i < a.histogram.size(); ++i) hist += fmt::format("{}{}", i ? "," : "", a.histogram[i]);
  return fmt::format(R"({{"focus":{},"top":{},"mean":{},"saturated_share":{},"dark_share":{},"histogram":[{}]}})",
                     num(a.focus, 1), a.top, num(a.mean, 4), num(a.saturated_share, 5), num(a.dark_share, 5), hist);
}

std::string section_json(const WebFrame& f) {
  if (!f.has_strips) return "null";
  std::string x, z;
  const CrossSection& s = f.section;
  for (std::size_t i = 0; i < s.z_mm.size(); ++i) {
    x += fmt::format("{}{}", i ? "," : "", num(s.x0_mm + s.dx_mm * static_cast<double>(i), 2));
    z += fmt::format("{}{}", i ? "," : "", num(s.z_mm[i], 2));
  }
  const RutGeometry& g = f.geometry;
  std::string out = fmt::format(R"({{"x_mm":[{}],"z_mm":[{}])", x, z);
  if (g.has_line) out += fmt::format(R"(,"ground_line":{{"m":{},"c_mm":{}}})", num(g.line_m, 6), num(g.line_c, 3));
  if (g.has_rut) {
    const double deepest_z = deepest_z_mm(g, f.measurement.depth_mm);
    out += fmt::format(R"(,"rut":{{"left_x_mm":{},"right_x_mm":{},"deepest_x_mm":{},"deepest_z_mm":{}}})",
                       num(g.left_x_mm, 2), num(g.right_x_mm, 2), num(g.deepest_x_mm, 2), num(deepest_z, 2));
  }
  if (g.has_water)
    out += fmt::format(R"(,"water":{{"level_mm":{},"left_x_mm":{},"right_x_mm":{},"refracted":{}}})",
                       num(g.water_level_mm, 2), num(g.waterline_left_x_mm, 2), num(g.waterline_right_x_mm, 2),
                       g.refracted ? "true" : "false");
  return out + "}";
}

std::string segment_json(const Segment& s) {
  return fmt::format(
      R"({{"index":{},"start_m":{},"end_m":{},"t_start_s":{},"t_end_s":{},"frames":{},"refused":{},)"
      R"("mean_depth_mm":{},"p95_depth_mm":{},"max_depth_mm":{},"worst_status":"{}","advisory":"{}","pass":{}}})",
      s.index, num(s.start_m, 2), num(s.end_m, 2), num(static_cast<double>(s.t_start_ns) * 1e-9, 3),
      num(static_cast<double>(s.t_end_ns) * 1e-9, 3), s.frames, s.refused, num(s.mean_depth_mm, 2),
      num(s.p95_depth_mm, 2), num(s.max_depth_mm, 2), to_string(s.worst_status), to_string(s.advisory), s.pass);
}

}  // namespace

WebView::WebView(WebContext context) : context_(std::move(context)) {}

void WebView::add_sample(const WebSample& s) {
  newest_t_ns_ = std::max(newest_t_ns_, s.t_ns);
  recent_.push_back(s.t_ns);
  while (!recent_.empty() && recent_.front() <= newest_t_ns_ - 1'000'000'000) recent_.pop_front();
  const std::int64_t key = s.t_ns / kBinNs;
  if (bins_.empty() || bins_.back().key < key) {
    bins_.push_back(Bin{});
    bins_.back().key = key;
  }
  Bin& b = bins_.back();  // a sample older than the newest bin (never, from one source) joins it
  ++b.frames;
  b.conditions |= s.conditions;
  if (status_severity(s.status) > status_severity(b.worst) || b.frames == 1) b.worst = s.status;
  if (s.status == RutStatus::Ok) {
    ++b.ok;
    b.depth_max = b.has_depth ? std::max(b.depth_max, s.depth_mm) : s.depth_mm;
    b.depth_last = s.depth_mm;
    b.has_depth = true;
  }
  while (!bins_.empty() && bins_.front().key <= key - static_cast<std::int64_t>(kBins)) bins_.pop_front();
}

void WebView::add_status(const SensorHealth& health, std::int64_t t_ns) {
  health_ = health;
  health_t_ns_ = t_ns;
  have_health_ = true;
}

void WebView::add_segment(const Segment& segment) {
  segments_.push_back(segment);
  ++segments_seen_;
  if (segments_.size() > kSegments) segments_.pop_front();
}

void WebView::add_frame(const WebFrame& f) {
  // The figures are copied (the slot goes back to the publish thread); the images are encoded now.
  frame_.seq = f.seq;
  frame_.t_ns = f.t_ns;
  frame_.skew_ns = f.skew_ns;
  frame_.measurement = f.measurement;
  frame_.health = f.health;
  frame_.motion = f.motion;
  frame_.position = f.position;
  frame_.times = f.times;
  frame_.has_images = f.has_images;
  frame_.has_strips = f.has_strips;
  frame_.strip_row0 = f.strip_row0;
  frame_.measured_row0 = f.measured_row0;
  frame_.measured_rows = f.measured_rows;
  frame_.section.x0_mm = f.section.x0_mm;
  frame_.section.dx_mm = f.section.dx_mm;
  frame_.section.z_mm = f.section.z_mm;
  frame_.geometry = f.geometry;
  have_frame_ = true;
  if (f.has_images) {
    left_aiming_ = exposure_figures(f.left_raw);
    right_aiming_ = exposure_figures(f.right_raw);
    left_jpeg_ = camera_jpeg(context_, f, true, left_aiming_.top);
    right_jpeg_ = camera_jpeg(context_, f, false, right_aiming_.top);
  }
  if (f.has_strips) {
    const int row0 = f.measured_row0 - f.strip_row0;
    left_aiming_.focus = focus_measure(f.left_strip, row0, f.measured_rows);
    right_aiming_.focus = focus_measure(f.right_strip, row0, f.measured_rows);
    strip_png_ = strip_png(context_, f);
  } else {
    left_aiming_.focus = right_aiming_.focus = std::numeric_limits<double>::quiet_NaN();
    strip_png_.clear();
  }
}

std::shared_ptr<const WebContent> WebView::build(std::int64_t now_ns, const WebHandoff& handoff) const {
  auto c = std::make_shared<WebContent>();
  c->seq = have_frame_ ? frame_.seq : 0;
  c->live_json = live_json(now_ns, handoff);
  c->history_json = history_json(now_ns);
  c->left_jpeg = left_jpeg_;
  c->right_jpeg = right_jpeg_;
  c->strip_png = strip_png_;
  return c;
}

std::string WebView::live_json(std::int64_t now_ns, const WebHandoff& h) const {
  const WebFrame& f = frame_;
  const RutMeasurement& m = f.measurement;
  const SensorHealth& health = have_health_ ? health_ : f.health;
  std::string out =
      fmt::format(R"({{"seq":{},"t_s":{},"age_s":{},"status":"{}","status_code":{},"status_meaning":"{}",)",
                  have_frame_ ? f.seq : 0, have_frame_ ? num(static_cast<double>(f.t_ns) * 1e-9, 3) : "null",
                  have_frame_ ? num(static_cast<double>(now_ns - f.t_ns) * 1e-9, 3) : "null", to_string(m.status),
                  static_cast<int>(m.status), status_meaning(m.status));
  const bool ok = m.status == RutStatus::Ok;
  out += fmt::format(
      R"("measurement":{{"depth_mm":{},"width_mm":{},"left_pile_mm":{},"right_pile_mm":{},"area_mm2":{},)"
      R"("ground_slope_deg":{},"center_x_mm":{},"quality":{},"valid_fraction":{},"depth_uncertainty_mm":{},)"
      R"("vertical_disparity_px":{},"obstructed_left":{},"obstructed_right":{}}},)",
      ok ? num(m.depth_mm, 2) : "null", ok ? num(m.width_mm, 1) : "null", ok ? num(m.left_pile_mm, 2) : "null",
      ok ? num(m.right_pile_mm, 2) : "null", ok ? num(m.area_mm2, 0) : "null", num(m.ground_slope_deg, 2),
      ok ? num(m.center_x_mm, 1) : "null", num(m.quality, 3), num(m.valid_fraction, 3), num(m.depth_uncertainty_mm, 3),
      num(m.vertical_disparity_px, 3), num(m.obstructed_left, 3), num(m.obstructed_right, 3));
  out += fmt::format(R"("conditions":{},"health":{},"frame_rate_hz":{},"dropped_frames":{},"last_status":"{}",)",
                     conditions_json(m.conditions), health_json(health), num(health.frame_rate_hz, 2),
                     health.dropped_frames, to_string(health.last_status));
  const double rate = recent_.size() >= 2 ? static_cast<double>(recent_.size() - 1) /
                                                (static_cast<double>(recent_.back() - recent_.front()) * 1e-9)
                                          : 0.0;
  out += fmt::format(R"("aiming":{{"left":{},"right":{},"skew_ms":{},"published_rate_hz":{}}},)",
                     aiming_json(left_aiming_), aiming_json(right_aiming_),
                     num(static_cast<double>(f.skew_ns) * 1e-6, 3), num(rate, 2));
  out += fmt::format(R"("section":{},)", section_json(f));
  out += fmt::format(R"("motion":{{"speed":"{}","speed_km_h":{},"distance_m":{}}},)", to_string(f.motion.state),
                     f.motion.state == SpeedState::Ok ? num(f.motion.speed_mm_s * 3.6e-3, 2) : "null",
                     num(f.motion.distance_m, 2));
  out += f.position.valid()
             ? fmt::format(R"("position":{{"latitude_deg":{},"longitude_deg":{},"horizontal_error_m":{}}},)",
                           num(f.position.latitude_deg, 8), num(f.position.longitude_deg, 8),
                           num(f.position.horizontal_error_m, 2))
             : std::string(R"("position":null,)");
  out += fmt::format(R"("advisory":"{}","last_segment":{},"segments":{},)",
                     segments_.empty() ? "UNKNOWN" : to_string(segments_.back().advisory),
                     segments_.empty() ? "null" : segment_json(segments_.back()), segments_seen_);
  out += fmt::format(R"("stage_ms":{{"rectify":{},"band":{},"disparity":{},"dic":{},"reproject":{},"rut":{}}},)",
                     num(f.times.rectify_ms, 2), num(f.times.band_ms, 2), num(f.times.disparity_ms, 2),
                     num(f.times.dic_ms, 2), num(f.times.reproject_ms, 2), num(f.times.rut_ms, 2));
  out += fmt::format(R"("images":{{"left":{},"right":{},"strip":{}}},)",
                     left_jpeg_.empty() ? "null" : "\"/api/image/left.jpg\"",
                     right_jpeg_.empty() ? "null" : "\"/api/image/right.jpg\"",
                     strip_png_.empty() ? "null" : "\"/api/image/strip.png\"");
  out += fmt::format(
      R"("view":{{"pairs_offered":{},"pairs_dropped":{},"samples_dropped":{},"requests":{},"refused":{},"status_age_s":{}}}}})",
      h.pairs_offered, h.pairs_dropped, h.samples_dropped, h.requests, h.refused,
      have_health_ ? num(static_cast<double>(now_ns - health_t_ns_) * 1e-9, 3) : "null");
  return out;
}

std::string WebView::history_json(std::int64_t now_ns) const {
  std::string out = fmt::format(R"({{"bin_s":0.1,"now_s":{},"bins":[)", num(static_cast<double>(now_ns) * 1e-9, 3));
  bool first = true;
  for (const Bin& b : bins_) {
    out += fmt::format(
        R"({}{{"t_s":{},"frames":{},"ok":{},"depth_max_mm":{},"depth_last_mm":{},"worst_status":"{}","conditions":{}}})",
        first ? "" : ",", num(static_cast<double>(b.key * kBinNs) * 1e-9, 1), b.frames, b.ok,
        b.has_depth ? num(b.depth_max, 2) : "null", b.has_depth ? num(b.depth_last, 2) : "null", to_string(b.worst),
        b.conditions);
    first = false;
  }
  out += R"(],"segments":[)";
  first = true;
  for (const Segment& s : segments_) {
    out += (first ? "" : ",") + segment_json(s);
    first = false;
  }
  return out + "]}";
}

}  // namespace rutd
