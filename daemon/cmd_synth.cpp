// rutd synth DIR: renders a synthetic stereo recording of a rut of known shape, in the recording format
// replay reads (DESIGN.md, Formats), with the exact ground truth per frame in truth.csv beside it.
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <vector>

#include <spdlog/spdlog.h>

#include "can/candump_log.hpp"
#include "can/vehicle_speed.hpp"
#include "core/input_error.hpp"
#include "daemon/commands.hpp"
#include "daemon/progress.hpp"
#include "daemon/scene_options.hpp"
#include "recording/recording.hpp"
#include "synthetic/truth_csv.hpp"

namespace rutd {
namespace {

struct SynthOptions {
  std::string dir;
  std::uint64_t frames = 10;
  SceneOptions scene;
  std::string speed_profile;  // T_S:KMH,... ; empty: no vehicle.log
  double speed_rate_hz = 50;
  bool gear = false;  // also ETC2 gear frames (always with a reversing profile)
};

struct SpeedKnot {
  double t_s, kmh;
};

// "T_S:KMH,T_S:KMH,..." with T_S increasing; throws CLI::ValidationError naming the knot.
std::vector<SpeedKnot> parse_speed_profile(const std::string& text) {
  std::vector<SpeedKnot> knots;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    SpeedKnot k{};
    char colon = 0;
    std::istringstream is(item);
    if (!(is >> k.t_s >> colon >> k.kmh) || colon != ':' || !is.eof() || !std::isfinite(k.t_s) ||
        !std::isfinite(k.kmh) || k.t_s < 0 || std::abs(k.kmh) > 250 || (!knots.empty() && k.t_s <= knots.back().t_s))
      throw CLI::ValidationError("--speed-profile",
                                 "expected T_S:KMH,... with T_S increasing from 0 and |KMH| <= 250, "
                                 "got '" +
                                     item + "'");
    knots.push_back(k);
  }
  if (knots.empty()) throw CLI::ValidationError("--speed-profile", "no knots");
  return knots;
}

double speed_at(const std::vector<SpeedKnot>& k, double t) {
  if (t <= k.front().t_s) return k.front().kmh;
  for (std::size_t i = 1; i < k.size(); ++i)
    if (t <= k[i].t_s) return k[i - 1].kmh + (k[i].kmh - k[i - 1].kmh) * (t - k[i - 1].t_s) / (k[i].t_s - k[i - 1].t_s);
  return k.back().kmh;
}

// DIR/vehicle.log as a vehicle would have sent it over the recording: CCVS1 from address 0x00 at
// speed_rate_hz (and, with gears, ETC2 from 0x03 at 10 Hz), on the pairs' clock (pair i at i / fps).
bool write_vehicle_log(const SynthOptions& o, double fps) {
  const auto knots = parse_speed_profile(o.speed_profile);
  bool reversing = o.gear;
  for (const SpeedKnot& k : knots) reversing = reversing || k.kmh < 0;
  const std::string path = (std::filesystem::path(o.dir) / "vehicle.log").string();
  std::ofstream out(path);
  if (!out) throw InputError(path, "vehicle.log", "cannot create");
  CandumpLogWriter log(out, "can0");
  const double end_s = static_cast<double>(o.frames) / fps;
  const double period = 1.0 / o.speed_rate_hz;
  int gear = 1;
  // Speed frames half a period before the first pair, so the first pair has a speed.
  for (std::int64_t i = 0;; ++i) {
    const double t = (static_cast<double>(i) - 0.5) * period;
    if (t > end_s) break;
    const double kmh = speed_at(knots, std::max(t, 0.0));
    const auto t_ns = std::llround(std::max(t, 0.0) * 1e9);
    if (kmh < 0) gear = -1;
    else if (kmh > 0) gear = 1;
    const std::int64_t per_gear = std::max<std::int64_t>(1, std::llround(o.speed_rate_hz / 10));
    if (reversing && i % per_gear == 0) log.write(encode_etc2_gear(gear, 0x03), t_ns);
    log.write(encode_ccvs1(kmh, 0x00), t_ns);
  }
  return static_cast<bool>(out.flush());
}

int run_synth(const SynthOptions& o) {
  const SyntheticRendererConfig params = resolve_scene_options(o.scene);
  const SyntheticRenderer renderer(params);
  RecordingWriter writer(o.dir, renderer.calibration());  // throws InputError if the folder is unusable
  TruthCsvWriter truth((std::filesystem::path(o.dir) / "truth.csv").string());
  StereoFrame frame;
  const auto t0 = std::chrono::steady_clock::now();
  ProgressLine progress("synth", o.frames);
  for (std::uint64_t i = 0; i < o.frames; ++i) {
    progress.update(i);
    const CameraSettings used = renderer.render(i, frame);
    if (!writer.append(frame)) {
      spdlog::error("{}", writer.error());
      return 1;
    }
    RutTruth t = renderer.truth(i);
    t.exposure = used.exposure;  // auto exposure's choice for this pair
    t.gain = used.gain;
    if (!truth.append(t, frame.t_ns)) {
      spdlog::error("{}: cannot write the truth of pair {}", (std::filesystem::path(o.dir) / "truth.csv").string(), i);
      return 1;
    }
  }
  if (!o.speed_profile.empty() && !write_vehicle_log(o, params.fps)) {
    spdlog::error("{}/vehicle.log: cannot write", o.dir);
    return 1;
  }
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  progress.clear();
  spdlog::info("wrote {} pairs of {}x{} to {} ({:.1f} pairs/s)", o.frames, params.rig.image_size.width,
               params.rig.image_size.height, o.dir, s > 0 ? o.frames / s : 0.0);
  return 0;
}

}  // namespace

void add_synth_command(CLI::App& app, int& exit_code) {
  auto options = std::make_shared<SynthOptions>();
  CLI::App* cmd = app.add_subcommand("synth", "Render a synthetic stereo recording of a rut with ground truth");
  cmd->add_option("dir", options->dir, "Recording folder to create")->required();
  cmd->add_option("--frames", options->frames, "Number of stereo pairs")
      ->check(CLI::Range(1, 1000000))
      ->capture_default_str();
  cmd->add_option("--speed-profile", options->speed_profile,
                  "Also write vehicle.log: the vehicle's CAN speed frames (J1939 CCVS1) over the recording, from this "
                  "profile T_S:KMH,... (linear between knots; negative: reversing, sent with ETC2 gear frames)");
  cmd->add_option("--speed-rate", options->speed_rate_hz, "Speed frames per second in vehicle.log")
      ->check(CLI::Range(1.0, 1000.0))
      ->capture_default_str();
  cmd->add_flag("--speed-gear", options->gear, "Send ETC2 gear frames even when the profile never reverses");
  add_scene_options(*cmd, options->scene);
  cmd->callback([options, &exit_code] {
    if (!options->speed_profile.empty()) parse_speed_profile(options->speed_profile);  // before rendering
    exit_code = run_synth(*options);
  });
}

}  // namespace rutd
