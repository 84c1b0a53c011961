#pragma once
// Command-line options describing a synthetic scene (rig, rut, texture, motion), shared by `synth`
// (which writes a recording) and `run` (whose default source is the same renderer, live).
#include <string>

#include <CLI/CLI.hpp>

#include "synthetic/synthetic_renderer.hpp"

namespace rutd {

struct SynthOptions {
  SynthConfig params;
  std::string size = "640x480";
  std::string texture = "sand";
  std::string depth_profile;  // "frame:depth,frame:depth,..."
  std::string splash_camera = "left";
};

void add_synth_options(CLI::App& cmd, SynthOptions& options);
// Parses the textual options into options.params; throws CLI::ValidationError naming the option.
SynthConfig resolve_synth_options(const SynthOptions& options);

}  // namespace rutd
