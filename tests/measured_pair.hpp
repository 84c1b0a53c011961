#pragma once
// One rendered pair (320x240; the renderer's rig, with lens distortion and a misaligned right camera)
// measured stage by stage, as the pipeline hands it to its sinks: what the sink tests publish
// (published_frame(work, ...)).
#include <memory>

#include "measurement/measurer.hpp"
#include "synthetic/synthetic_renderer.hpp"

namespace rutd::test {

struct MeasuredPair {
  SyntheticRendererConfig config;
  std::unique_ptr<SyntheticRenderer> renderer;
  std::unique_ptr<StereoMeasurer> measurer;
  FrameWork work;
  MeasuredPair() {
    config.rig.image_size = {320, 240};
    renderer = std::make_unique<SyntheticRenderer>(config);
    measurer = std::make_unique<StereoMeasurer>(renderer->calibration(), MeasurerConfig{});
    renderer->render(0, work.frame);
    MatchContext ctx = measurer->make_match_context();
    RutWorkspace ws;
    measurer->rectify(work);
    measurer->match(work, ctx);
    measurer->extract(work, ws);
  }
};

}  // namespace rutd::test
