#include "daemon/scene_options.hpp"

#include <charconv>
#include <sstream>

#include "daemon/dimensions.hpp"

namespace rutd {
namespace {

cv::Size parse_size(const std::string& text) {
  const auto size = parse_dimensions(text, 64, 8192);
  if (!size)
    throw CLI::ValidationError("--size", "expected WIDTHxHEIGHT between 64x64 and 8192x8192, got '" + text + "'");
  return *size;
}

// "0:30,100:60" -> knots (frame 0: 30 mm, frame 100: 60 mm), frames strictly increasing.
std::vector<std::pair<std::uint64_t, double>> parse_profile(const std::string& text) {
  std::vector<std::pair<std::uint64_t, double>> knots;
  std::istringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    const auto colon = item.find(':');
    std::uint64_t frame = 0;
    double depth = 0;
    std::istringstream depth_in(colon == std::string::npos ? "" : item.substr(colon + 1));
    const auto [p, ec] = std::from_chars(item.data(), item.data() + (colon == std::string::npos ? 0 : colon), frame);
    if (colon == std::string::npos || ec != std::errc() || p != item.data() + colon || !(depth_in >> depth) ||
        depth < 0 || (!knots.empty() && frame <= knots.back().first))
      throw CLI::ValidationError(
          "--depth-profile",
          "expected FRAME:DEPTH_MM pairs with increasing frames, e.g. 0:30,100:60; bad item '" + item + "'");
    knots.emplace_back(frame, depth);
  }
  return knots;
}

// The cameras' exposure: manual or auto, the pair's mismatch, free-running exposures, the light.
void add_camera_options(CLI::App& cmd, SyntheticRendererConfig& p) {
  const std::string camera = "Camera";
  cmd.add_option("--exposure", p.exposure,
                 "Exposure: radiance 1 maps to EXPOSURE x full scale at gain 1 (0.05: dark, 4: saturated)")
      ->check(CLI::Range(0.001, 100.0))
      ->capture_default_str()
      ->group(camera);
  CLI::Option* gain = cmd.add_option("--gain", p.gain, "Analog gain: amplifies the signal, shot and read noise alike")
                          ->check(CLI::Range(1.0, 256.0))
                          ->capture_default_str()
                          ->group(camera);
  cmd.add_option("--light", p.light,
                 "Scene illuminance relative to daylight (dusk 0.05): every radiance, sky and sun scale by it")
      ->check(CLI::Range(1e-4, 100.0))
      ->capture_default_str()
      ->group(camera);
  AutoExposureConfig& ae = p.auto_exposure;
  cmd.add_flag("--auto-exposure", ae.enabled,
               "Hold the left image's median grey level at --ae-target by exposure (up to --max-exposure), then "
               "gain (up to --max-gain); the right camera takes the same settings")
      ->excludes(gain)
      ->group(camera);
  cmd.add_option("--ae-target", ae.target, "Auto exposure's median grey level, fraction of full scale")
      ->check(CLI::Range(0.01, 0.99))
      ->capture_default_str()
      ->group(camera);
  cmd.add_option("--max-exposure", ae.max_exposure,
                 "Longest exposure auto exposure may use (what the vehicle's motion allows), units of --exposure")
      ->check(CLI::Range(0.001, 100.0))
      ->capture_default_str()
      ->group(camera);
  cmd.add_option("--max-gain", ae.max_gain, "Highest gain auto exposure may use")
      ->check(CLI::Range(1.0, 256.0))
      ->capture_default_str()
      ->group(camera);
  cmd.add_option("--right-response", p.right_response,
                 "Right camera's response relative to the left's (1.04: the right image 4 % brighter)")
      ->check(CLI::Range(0.7, 1.3))
      ->capture_default_str()
      ->group(camera);
  cmd.add_option("--right-delay-ms", p.right_delay_ms,
                 "Free-running cameras: the right exposure this many ms after the left (negative: before); the "
                 "ground moves --speed x delay between them")
      ->check(CLI::Range(-500.0, 500.0))
      ->capture_default_str()
      ->group(camera);
}

}  // namespace

void add_scene_options(CLI::App& cmd, SceneOptions& o) {
  SyntheticRendererConfig& p = o.params;
  const std::string rig = "Rig", rut = "Rut", scene = "Scene";
  cmd.add_option("--size", o.size, "Image size WIDTHxHEIGHT")->capture_default_str()->group(rig);
  cmd.add_option("--baseline", p.rig.baseline_mm, "Stereo baseline, mm")
      ->check(CLI::Range(5.0, 1000.0))
      ->capture_default_str()
      ->group(rig);
  cmd.add_option("--height", p.rig.height_mm, "Camera height above undisturbed ground, mm")
      ->check(CLI::Range(50.0, 5000.0))
      ->capture_default_str()
      ->group(rig);
  cmd.add_option("--roll", p.rig.roll_deg, "Rig roll about the travel axis, degrees")
      ->check(CLI::Range(-30.0, 30.0))
      ->capture_default_str()
      ->group(rig);
  cmd.add_option("--pitch", p.rig.pitch_deg, "Rig pitch, degrees")
      ->check(CLI::Range(-30.0, 30.0))
      ->capture_default_str()
      ->group(rig);
  cmd.add_option("--hfov", p.rig.hfov_deg, "Horizontal field of view, degrees")
      ->check(CLI::Range(10.0, 120.0))
      ->capture_default_str()
      ->group(rig);
  cmd.add_option("--depth", p.rut.depth_mm, "Rut depth, mm")
      ->check(CLI::Range(0.0, 500.0))
      ->capture_default_str()
      ->group(rut);
  cmd.add_option("--depth-profile", o.depth_profile, "Depth over time: FRAME:DEPTH_MM,... (linear between knots)")
      ->group(rut);
  cmd.add_option("--width", p.rut.width_mm, "Rut top width (where it crosses ground level), mm")
      ->check(CLI::Range(10.0, 2000.0))
      ->capture_default_str()
      ->group(rut);
  cmd.add_option("--bottom-width", p.rut.bottom_width_mm, "Flat rut bottom width, mm")
      ->check(CLI::Range(0.0, 2000.0))
      ->capture_default_str()
      ->group(rut);
  cmd.add_option("--pile-left", p.rut.pile_left_mm, "Left pile height, mm (0: none)")
      ->check(CLI::Range(0.0, 300.0))
      ->capture_default_str()
      ->group(rut);
  cmd.add_option("--pile-right", p.rut.pile_right_mm, "Right pile height, mm (0: none)")
      ->check(CLI::Range(0.0, 300.0))
      ->capture_default_str()
      ->group(rut);
  cmd.add_option("--pile-width", p.rut.pile_width_mm, "Width of each pile, mm")
      ->check(CLI::Range(1.0, 1000.0))
      ->capture_default_str()
      ->group(rut);
  cmd.add_option("--offset", p.rut.lateral_offset_mm, "Lateral offset of the rut from the rig centre, mm")
      ->capture_default_str()
      ->group(rut);
  cmd.add_option("--wander", p.rut.wander_amplitude_mm, "Lateral wander amplitude, mm")
      ->check(CLI::Range(0.0, 1000.0))
      ->capture_default_str()
      ->group(rut);
  cmd.add_option("--wander-wavelength", p.rut.wander_wavelength_mm, "Lateral wander wavelength along travel, mm")
      ->check(CLI::Range(10.0, 1e6))
      ->capture_default_str()
      ->group(rut);
  cmd.add_flag("--tread", p.rut.tread, "Imprint tread marks in the rut bottom")->group(rut);
  cmd.add_option("--texture", o.texture, "Terrain: sand, mud, snow, grass")
      ->check(CLI::IsMember({"sand", "mud", "snow", "grass"}))
      ->capture_default_str()
      ->group(scene);
  cmd.add_option("--fps", p.fps, "Frame rate, frames per second")
      ->check(CLI::Range(0.1, 1000.0))
      ->capture_default_str()
      ->group(scene);
  cmd.add_option("--speed", p.speed_mm_s, "Vehicle speed, mm/s")
      ->check(CLI::Range(0.0, 1e5))
      ->capture_default_str()
      ->group(scene);
  cmd.add_option("--noise", p.noise_sigma, "Sensor read noise, grey levels (8-bit)")
      ->check(CLI::Range(0.0, 50.0))
      ->capture_default_str()
      ->group(scene);
  cmd.add_option("--seed", p.seed, "Random seed (texture and noise)")->capture_default_str()->group(scene);
  add_camera_options(cmd, p);
  add_condition_options(cmd, o);
}

SyntheticRendererConfig resolve_scene_options(const SceneOptions& o) {
  SyntheticRendererConfig p = o.params;
  p.rig.image_size = parse_size(o.size);
  p.texture = *parse_texture(o.texture);  // IsMember above guarantees a known name
  if (!o.depth_profile.empty()) p.depth_profile = parse_profile(o.depth_profile);
  if (p.rut.bottom_width_mm >= p.rut.width_mm)
    throw CLI::ValidationError("--bottom-width", "must be smaller than --width");
  if (std::abs(p.right_delay_ms) * p.fps >= 1000)
    throw CLI::ValidationError("--right-delay-ms", "must be shorter than a frame period (1000 / --fps ms)");
  resolve_condition_options(o, p);
  return p;
}

SyntheticRendererConfig parse_scene_line(const std::string& line) {
  CLI::App app;
  SceneOptions options;
  add_scene_options(app, options);
  app.parse(line, false);
  return resolve_scene_options(options);
}

}  // namespace rutd
