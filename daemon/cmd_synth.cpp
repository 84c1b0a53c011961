// rutd synth DIR: renders a synthetic stereo recording of a rut of known shape, in the recording format
// replay reads (DESIGN.md, Formats), with the exact ground truth per frame in truth.csv beside it.
#include <chrono>
#include <filesystem>
#include <memory>

#include <spdlog/spdlog.h>

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
};

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
  add_scene_options(*cmd, options->scene);
  cmd->callback([options, &exit_code] { exit_code = run_synth(*options); });
}

}  // namespace rutd
