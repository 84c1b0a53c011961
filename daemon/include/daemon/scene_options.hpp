#pragma once
// Command-line options describing a synthetic scene (rig, rut, texture, motion, the cameras' exposure,
// and the conditions: water, sky, faults on the lenses, grass, a turned camera), for `synth`.
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "synthetic/synthetic_renderer.hpp"

namespace rutd {

struct SceneOptions {
  SyntheticRendererConfig params;
  std::string size = "640x480";
  std::string texture = "sand";
  std::string depth_profile;  // "frame:depth,frame:depth,..."
  // Conditions given as text, or as a shorthand for a fault (--splash: mud on one lens).
  std::string debris_kind = "foam";
  std::string ripple_kind = "wind";
  std::vector<std::string> lens;  // KIND:CAMERA:AMOUNT[:CENTRE]
  double splash_fraction = 0;
  double splash_centre = 0.5;
  std::string splash_camera = "left";
  // Unset (NaN): the default sun (SkyConfig::sun).
  double sun_elevation_deg = std::numeric_limits<double>::quiet_NaN();
  double sun_azimuth_deg = std::numeric_limits<double>::quiet_NaN();
};

void add_scene_options(CLI::App& cmd, SceneOptions& options);
// Parses the textual options into options.params; throws CLI::ValidationError naming the option.
SyntheticRendererConfig resolve_scene_options(const SceneOptions& options);
// A whole `rutd synth` option line (no folder, no --frames), as the scene matrix writes its scenes:
// parsed and resolved by the two above; throws CLI::ParseError (unknown option) or ValidationError.
SyntheticRendererConfig parse_scene_line(const std::string& line);

// The conditions' half of the two above (daemon/scene_condition_options.cpp).
void add_condition_options(CLI::App& cmd, SceneOptions& options);
void resolve_condition_options(const SceneOptions& options, SyntheticRendererConfig& params);

}  // namespace rutd
