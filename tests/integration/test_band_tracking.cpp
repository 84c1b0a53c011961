// The match stage keeps the last frame's disparity band while it fits (BandTracker) and estimates a new
// one when the terrain jumps. Against the renderer's truth: a measurer fed frames from two rigs that
// share one calibration but stand 350 and 270 mm above the ground (a jump of about 30 % in disparity,
// far outside any kept band) measures every frame as well as a measurer that estimates every band.
#include <cmath>
#include <cstdio>
#include <vector>

#include <gtest/gtest.h>

#include "pipeline/measurer.hpp"
#include "synthetic/synthetic_renderer.hpp"

namespace rutd {
namespace {

TEST(BandTracking, KeepsTheBandWhileItFitsAndFollowsAJump) {
  SynthConfig high;
  high.rut.depth_mm = 45;
  SynthConfig low = high;
  low.rig.height_mm = 270;
  low.rut.depth_mm = 30;
  const SyntheticRenderer high_renderer(high), low_renderer(low);
  ASSERT_EQ(cv::norm(cv::Mat(high_renderer.calibration().M1), cv::Mat(low_renderer.calibration().M1)), 0.0);

  StereoMeasurer tracking(high_renderer.calibration(), MeasurerConfig{});
  // Frames 0-3 high, 4-7 low, 8-9 high again.
  const std::vector<bool> is_low = {false, false, false, false, true, true, true, true, false, false};
  std::vector<bool> estimated;
  int checked = 0;
  for (std::size_t i = 0; i < is_low.size(); ++i) {
    const SyntheticRenderer& r = is_low[i] ? low_renderer : high_renderer;
    StereoFrame frame;
    r.render(i, frame);
    const RutMeasurement m = tracking.measure(frame.left, frame.right);
    estimated.push_back(tracking.diagnostics().band_estimated);
    // The reference: a fresh measurer estimates the band of its only frame.
    StereoMeasurer fresh(r.calibration(), MeasurerConfig{});
    const RutMeasurement reference = fresh.measure(frame.left, frame.right);
    const double truth = r.truth(i).depth_mm;
    std::printf("frame %zu (%s): band %d+%d %s, depth %.3f mm (fresh estimate %.3f, truth %.3f)\n", i,
                is_low[i] ? "low" : "high", tracking.diagnostics().band.min_disparity,
                tracking.diagnostics().band.num_disparities, estimated.back() ? "estimated" : "kept", m.depth_mm,
                reference.depth_mm, truth);
    ASSERT_EQ(m.status, RutStatus::Ok) << "frame " << i;
    EXPECT_NEAR(m.depth_mm, truth, 0.5) << "frame " << i;
    EXPECT_NEAR(m.depth_mm, reference.depth_mm, 0.1) << "frame " << i;
    ++checked;
  }
  EXPECT_EQ(checked, 10);
  // Estimated on the first frame and at both jumps, kept on the frames between.
  EXPECT_EQ(estimated, (std::vector<bool>{true, false, false, false, true, false, false, false, true, false}));
}

}  // namespace
}  // namespace rutd
