// rutd bench --scenes: the scene matrix measured against the renderer's truth (daemon/bench_scenes.hpp).
#include "daemon/bench_scenes.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <regex>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "daemon/measure_options.hpp"
#include "daemon/progress.hpp"
#include "daemon/scene_matrix.hpp"
#include "daemon/scene_options.hpp"
#include "measurement/measurer.hpp"

namespace rutd {
namespace {

constexpr double kToleranceMm = 1.0;  // the accuracy a published OK depth owes the user

// RutConditions bits by their DBC signal names, and the letters of the table.
struct ConditionName {
  std::uint8_t bit;
  const char* signal;
  char letter;
};
constexpr ConditionName kConditions[] = {{kConditionWater, "Water", 'W'},
                                         {kConditionLeftObstructed, "LeftLensObstructed", 'L'},
                                         {kConditionRightObstructed, "RightLensObstructed", 'R'},
                                         {kConditionLowLight, "LowLight", 'D'},
                                         {kConditionOverexposed, "Overexposed", 'O'},
                                         {kConditionVegetation, "Vegetation", 'V'},
                                         {kConditionCalibrationDrift, "CalibrationDrift", 'C'},
                                         {kConditionUncertain, "DepthUncertain", 'U'}};

struct FrameOutcome {
  std::uint64_t index = 0;
  RutMeasurement m;
  RutTruth truth;
  CameraSettings settings;
  WaterRule water_rule = WaterRule::None;     // the rule that flagged it Water
  WaterRule dry_overruled = WaterRule::None;  // the rule the steady dry frames before overruled
};

struct SceneOutcome {
  std::vector<FrameOutcome> frames;
  double texture_to_noise = 0;  // of frame 0's left strip: what matching has to work with
  int ok_within = 0, ok_beyond = 0, refused = 0, refused_expected = 0;
  int refused_within = 0;  // refused, yet the depth it had found was within 1 mm: what a refusal cost
  double worst_ok_error = 0;
  std::map<std::string, int> refusals;  // status -> frames
  int flag_count[8] = {};               // refused frames carrying each condition
  double seconds = 0;
};

SyntheticRendererConfig scene_config(const MatrixScene& scene) { return parse_scene_line(scene.synth); }

std::uint8_t expected_bits(const MatrixScene& scene) {
  std::uint8_t bits = 0;
  for (const std::string& name : scene.expect)
    for (const ConditionName& c : kConditions)
      if (name == c.signal) bits |= c.bit;
  return bits;
}

// The texture a matcher has against the noise in the measured rows of frame 0's left image: the RMS
// difference of horizontal neighbours without noise (rendered again noise-free, same exposure), over that
// of the noise alone (sqrt(2) times its deviation, from the sensor model at the rows' median grey level,
// with 8-bit quantisation). The lower, the harder: DIC's windows integrate many pixels, yet under about 0.7
// matching fails on most frames, and a refusal there is no false alarm.
double texture_to_noise(const SyntheticRendererConfig& params) {
  SyntheticRendererConfig quiet = params;
  quiet.noise_sigma = 0;
  quiet.full_well_e = 0;
  StereoFrame frame;
  const CameraSettings s = SyntheticRenderer(quiet).render(0, frame);
  const int rows = std::clamp(frame.left.rows / 10, 20, 64), row0 = (frame.left.rows - rows) / 2;
  cv::Mat strip;
  frame.left.rowRange(row0, row0 + rows).convertTo(strip, CV_64F, frame.left.depth() == CV_16U ? 1.0 / 257 : 1.0);
  cv::Mat dx = strip.colRange(1, strip.cols) - strip.colRange(0, strip.cols - 1);
  const double gradient = std::sqrt(cv::mean(dx.mul(dx))[0]);
  std::vector<double> values(strip.begin<double>(), strip.end<double>());
  std::nth_element(values.begin(), values.begin() + static_cast<long>(values.size() / 2), values.end());
  const double at_gain_1 = values[values.size() / 2] / s.gain;
  const double shot = params.full_well_e > 0 ? 255.0 / params.full_well_e * at_gain_1 : 0.0;
  const double noise = std::sqrt(s.gain * s.gain * (params.noise_sigma * params.noise_sigma + shot) + 1.0 / 12);
  return gradient / (std::sqrt(2.0) * noise);
}

SceneOutcome measure_scene(const MatrixScene& scene, const BenchScenesOptions& o) {
  const auto start = std::chrono::steady_clock::now();
  const SyntheticRendererConfig params = scene_config(scene);
  const SyntheticRenderer renderer(params);
  MeasureOptions mo;
  mo.engine = o.engine;
  mo.no_dic = !o.dic;
  mo.config.strip.guards = o.guards;
  mo.config.strip.guards_always = o.guards_always;
  StereoMeasurer measurer(renderer.calibration(), resolve_measure_options(mo));
  const std::uint8_t expected = expected_bits(scene);
  SceneOutcome out;
  StereoFrame frame;
  for (int i = 0; i < o.frames; ++i) {
    FrameOutcome f;
    f.index = static_cast<std::uint64_t>(i);
    f.settings = renderer.render(f.index, frame);
    f.m = measurer.measure(frame.left, frame.right, frame.skew_ns, frame.t_ns);
    f.water_rule = measurer.diagnostics().water_rule;
    f.dry_overruled = measurer.diagnostics().dry_overruled;
    f.truth = renderer.truth(f.index);
    const double error = std::abs(f.m.depth_mm - f.truth.depth_mm);
    if (f.m.status == RutStatus::Ok) {
      ++(error <= kToleranceMm ? out.ok_within : out.ok_beyond);
      out.worst_ok_error = std::max(out.worst_ok_error, error);
    } else {
      ++out.refused;
      out.refused_within += error <= kToleranceMm;
      ++out.refusals[std::string(to_string(f.m.status))];
      // The expected condition, or a status the scene calls for (UNSYNCHRONISED: no condition bit).
      const std::string status(to_string(f.m.status));
      out.refused_expected += (f.m.conditions & expected) != 0 ||
                              std::find(scene.expect.begin(), scene.expect.end(), status) != scene.expect.end();
      for (int k = 0; k < 8; ++k) out.flag_count[k] += (f.m.conditions & kConditions[k].bit) != 0;
    }
    out.frames.push_back(f);
  }
  out.texture_to_noise = texture_to_noise(params);
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

// "BOTTOM_NOT_SEEN x3, UNCERTAIN x1 [W3 U1]"
std::string refusal_text(const SceneOutcome& s) {
  std::string text;
  for (const auto& [status, n] : s.refusals) text += fmt::format("{}{} x{}", text.empty() ? "" : ", ", status, n);
  std::string flags;
  for (int k = 0; k < 8; ++k)
    if (s.flag_count[k] > 0)
      flags += fmt::format("{}{}{}", flags.empty() ? "" : " ", kConditions[k].letter, s.flag_count[k]);
  if (!flags.empty()) text += " [" + flags + "]";
  return text.empty() ? "-" : text;
}

std::string json_number(double v) { return std::isfinite(v) ? fmt::format("{:.4f}", v) : "null"; }

std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (const char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    if (static_cast<unsigned char>(c) < 0x20) {
      out += fmt::format("\\u{:04x}", static_cast<int>(c));
      continue;
    }
    out += c;
  }
  return out + "\"";
}

std::string json_conditions(std::uint8_t bits) {
  std::string out = "[";
  for (const ConditionName& c : kConditions)
    if (bits & c.bit) out += (out.size() > 1 ? "," : "") + json_string(c.signal);
  return out + "]";
}

std::string rule_json(WaterRule rule) {
  return rule == WaterRule::None ? std::string("null") : json_string(water_rule_name(rule));
}

void print_json(const MatrixScene& scene, const SceneOutcome& s) {
  std::string expect = "[";
  for (const std::string& e : scene.expect) expect += (expect.size() > 1 ? "," : "") + json_string(e);
  expect += "]";
  std::string refusals = "{";
  for (const auto& [status, n] : s.refusals)
    refusals += fmt::format("{}{}:{}", refusals.size() > 1 ? "," : "", json_string(status), n);
  refusals += "}";
  std::string frames = "[";
  for (const FrameOutcome& f : s.frames) {
    frames += fmt::format(
        "{}{{\"index\":{},\"status\":{},\"depth_mm\":{},\"truth_mm\":{},\"error_mm\":{},\"uncertainty_mm\":{},"
        "\"conditions\":{},\"water_rule\":{},\"dry_overruled\":{},\"water_depth_mm\":{},\"waterline_depth_mm\":{},"
        "\"exposure\":{},"
        "\"gain\":{}}}",
        frames.size() > 1 ? "," : "", f.index, json_string(std::string(to_string(f.m.status))),
        json_number(f.m.depth_mm), json_number(f.truth.depth_mm), json_number(f.m.depth_mm - f.truth.depth_mm),
        json_number(f.m.depth_uncertainty_mm), json_conditions(f.m.conditions), rule_json(f.water_rule),
        rule_json(f.dry_overruled), json_number(f.truth.water_depth_mm), json_number(f.truth.waterline_depth_mm),
        json_number(f.settings.exposure), json_number(f.settings.gain));
  }
  frames += "]";
  std::printf(
      "{\"scene\":%s,\"group\":%s,\"kind\":%s,\"expect\":%s,\"synth\":%s,\"frames\":%zu,\"ok_within_1mm\":%d,"
      "\"ok_beyond_1mm\":%d,\"refused\":%d,\"refused_within_1mm\":%d,\"refused_with_expected\":%d,\"refusals\":%s,"
      "\"worst_ok_error_mm\":%s,"
      "\"texture_to_noise\":%.2f,\"seconds\":%.2f,\"per_frame\":%s}\n",
      json_string(scene.name).c_str(), json_string(scene.group).c_str(), json_string(scene.kind).c_str(),
      expect.c_str(), json_string(scene.synth).c_str(), s.frames.size(), s.ok_within, s.ok_beyond, s.refused,
      s.refused_within, s.refused_expected, refusals.c_str(), json_number(s.worst_ok_error).c_str(), s.texture_to_noise,
      s.seconds, frames.c_str());
  std::fflush(stdout);
}

struct GroupTotals {
  int scenes = 0, frames = 0, ok_within = 0, ok_beyond = 0, refused = 0, refused_within = 0, refused_expected = 0;
  int scenes_wrong = 0, scenes_refused = 0;  // scenes with any frame OK beyond 1 mm / any frame refused
};

// The counts of one scene added to a kind's (the scene matrix's `kind`: water-clear, lens-mud-left, clean-auto, ...);
// frames, texture and time are the scene's own and are left out.
void add_counts(SceneOutcome& kind, const SceneOutcome& s) {
  kind.ok_within += s.ok_within, kind.ok_beyond += s.ok_beyond, kind.refused += s.refused;
  kind.refused_expected += s.refused_expected, kind.refused_within += s.refused_within;
  kind.worst_ok_error = std::max(kind.worst_ok_error, s.worst_ok_error);
  for (const auto& [status, n] : s.refusals) kind.refusals[status] += n;
  for (int k = 0; k < 8; ++k) kind.flag_count[k] += s.flag_count[k];
}

// The scene x outcome table: per kind of scene, pairs OK within 1 mm, OK beyond it (the worst error), refused
// (how many with the flag the kind calls for, how many within 1 mm all the same) and the refusals' statuses
// and conditions, as the scene rows give them.
void print_kinds(std::FILE* text, const std::vector<MatrixScene>& scenes,
                 const std::map<std::string, SceneOutcome>& kinds) {
  std::fprintf(text, "\n%-18s %-7s %6s %6s %6s %6s %7s %7s %10s  %s\n", "kind", "group", "scenes", "ok<=1", "ok>1",
               "worst", "refused", "ref<=1", "right flag", "refusals");
  for (const auto& [kind, k] : kinds) {
    const auto first = std::find_if(scenes.begin(), scenes.end(), [&](const MatrixScene& s) { return s.kind == kind; });
    const auto n = std::count_if(scenes.begin(), scenes.end(), [&](const MatrixScene& s) { return s.kind == kind; });
    const std::string right = first->expect.empty() ? "-" : fmt::format("{}/{}", k.refused_expected, k.refused);
    std::fprintf(text, "%-18s %-7s %6td %6d %6d %6s %7d %7d %10s  %s\n", kind.c_str(), first->group.c_str(), n,
                 k.ok_within, k.ok_beyond,
                 k.ok_within + k.ok_beyond > 0 ? fmt::format("{:.2f}", k.worst_ok_error).c_str() : "-", k.refused,
                 k.refused_within, right.c_str(), refusal_text(k).c_str());
  }
}

}  // namespace

int run_bench_scenes(const BenchScenesOptions& o) {
  std::vector<MatrixScene> scenes;
  std::regex only;
  try {
    only = std::regex(o.only.empty() ? ".*" : o.only);
  } catch (const std::regex_error& e) {
    throw CLI::ValidationError("--only", std::string("not a regular expression: ") + e.what());
  }
  for (MatrixScene& s : scene_matrix())
    if (std::regex_search(s.name, only)) scenes.push_back(std::move(s));
  if (scenes.empty()) throw CLI::ValidationError("--only", "selects no scene of the matrix");

  std::FILE* text = o.json ? stderr : stdout;  // with --json, stdout carries only the JSON lines
  std::fprintf(text,
               "scene matrix: %zu scenes x %d pairs, engine %s%s, measured as rutd replay measures; OK within %.0f mm "
               "of the soil's depth, OK beyond it (worst error), refused: status x frames [conditions on the "
               "refused frames: W water, L/R left/right lens, D low light, O overexposed, V vegetation, C "
               "calibration drift, U uncertain]; t/n: texture over noise in frame 0's measured rows (the lower, the "
               "harder); ref<=1: refused frames whose depth was within 1 mm all the same; right flag: refused frames "
               "flagged with an expected condition\n",
               scenes.size(), o.frames, o.engine.c_str(), o.dic ? " + DIC" : "", kToleranceMm);
  if (!o.json)
    std::printf("%-30s %-7s %6s %6s %6s %7s %5s %7s %10s  %s\n", "scene", "group", "frames", "ok<=1", "ok>1", "worst",
                "t/n", "ref<=1", "right flag", "refused");
  std::map<std::string, GroupTotals> totals;
  std::map<std::string, SceneOutcome> kinds;
  ProgressLine progress("scenes", scenes.size());
  const auto start = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < scenes.size(); ++i) {
    progress.update(i);
    const MatrixScene& scene = scenes[i];
    const SceneOutcome s = measure_scene(scene, o);
    progress.clear();
    if (o.json) {
      print_json(scene, s);
    } else {
      const std::string right = scene.expect.empty() ? "-" : fmt::format("{}/{}", s.refused_expected, s.refused);
      std::printf("%-30s %-7s %6zu %6d %6d %7s %5.1f %7d %10s  %s\n", scene.name.c_str(), scene.group.c_str(),
                  s.frames.size(), s.ok_within, s.ok_beyond,
                  s.ok_within + s.ok_beyond > 0 ? fmt::format("{:.2f}", s.worst_ok_error).c_str() : "-",
                  s.texture_to_noise, s.refused_within, right.c_str(), refusal_text(s).c_str());
      std::fflush(stdout);
    }
    add_counts(kinds[scene.kind], s);
    GroupTotals& t = totals[scene.group];
    ++t.scenes;
    t.frames += static_cast<int>(s.frames.size());
    t.ok_within += s.ok_within, t.ok_beyond += s.ok_beyond, t.refused += s.refused;
    t.refused_expected += s.refused_expected;
    t.refused_within += s.refused_within;
    t.scenes_wrong += s.ok_beyond > 0;
    t.scenes_refused += s.refused > 0;
  }
  progress.clear();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  print_kinds(text, scenes, kinds);
  std::fprintf(text, "\n");
  for (const auto& [group, t] : totals) {
    std::fprintf(text,
                 "%-7s %3d scenes, %4d frames: OK within 1 mm %4d, OK beyond 1 mm %3d (%d scenes), refused %4d (%d "
                 "scenes; %d with an expected condition, %d with a depth within 1 mm)",
                 group.c_str(), t.scenes, t.frames, t.ok_within, t.ok_beyond, t.scenes_wrong, t.refused,
                 t.scenes_refused, t.refused_expected, t.refused_within);
    if (group == "clean" || group == "steep")
      std::fprintf(text, "; false alarms %.1f %% of frames", t.frames > 0 ? 100.0 * t.refused / t.frames : 0.0);
    std::fprintf(text, "\n");
  }
  std::fprintf(text, "%.0f s\n", seconds);
  if (!o.json) {
    std::printf("\nscenes as rutd synth options (rutd synth DIR --frames %d OPTIONS; rutd replay DIR):\n", o.frames);
    for (const MatrixScene& s : scenes) std::printf("%-30s %s\n", s.name.c_str(), s.synth.c_str());
  }
  return 0;
}

}  // namespace rutd
