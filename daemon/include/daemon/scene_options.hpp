#pragma once
// Command-line options describing a synthetic scene (rig, rut, texture, motion), shared by `synth`
// (which writes a recording) and `run` (whose default source is the same renderer, live).
#include <string>

#include <CLI/CLI.hpp>

#include "synthetic/synthetic_renderer.hpp"

namespace rutd {

struct SceneOptions {
  SyntheticRendererConfig params;
  std::string size = "640x480";
  std::string texture = "sand";
  std::string depth_profile;  // "frame:depth,frame:depth,..."
  std::string splash_camera = "left";
};

void add_scene_options(CLI::App& cmd, SceneOptions& options);
// Parses the textual options into options.params; throws CLI::ValidationError naming the option.
SyntheticRendererConfig resolve_scene_options(const SceneOptions& options);

}  // namespace rutd
