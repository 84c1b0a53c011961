// The match stage keeps the last frame's disparity band while it fits (BandTracker) and starts the DIC
// from the last frame's disparity instead of running the engine (MeasurerConfig::reuse_starts); when
// the terrain jumps it estimates a new band and matches afresh. Against the renderer's truth: a
// measurer fed frames from two rigs that share one calibration but stand 350 and 270 mm above the
// ground (a jump of about 30 % in disparity, far outside any kept band or start) measures every frame
// as well as a measurer that estimates every band and runs the engine on every frame.
#include <cmath>
#include <cstdio>
#include <vector>

#include <gtest/gtest.h>

#include "jump_rigs.hpp"
#include "measurement/measurer.hpp"
#include "synthetic/synthetic_renderer.hpp"

namespace rutd {
namespace {

TEST(BandTracking, KeepsTheBandWhileItFitsAndFollowsAJump) {
  const test::JumpRigs rigs;
  const SyntheticRenderer &high_renderer = rigs.high, &low_renderer = rigs.low;
  ASSERT_EQ(cv::norm(cv::Mat(high_renderer.calibration().M1), cv::Mat(low_renderer.calibration().M1)), 0.0);

  StereoMeasurer tracking(high_renderer.calibration(), MeasurerConfig{});
  // Frames 0-3 high, 4-7 low, 8-9 high again.
  const std::vector<bool> is_low = {false, false, false, false, true, true, true, true, false, false};
  std::vector<bool> estimated, reused;
  int checked = 0;
  for (std::size_t i = 0; i < is_low.size(); ++i) {
    const SyntheticRenderer& r = is_low[i] ? low_renderer : high_renderer;
    StereoFrame frame;
    r.render(i, frame);
    const RutMeasurement m = tracking.measure(frame.left, frame.right);
    estimated.push_back(tracking.diagnostics().band_estimated);
    reused.push_back(tracking.diagnostics().starts_reused);
    // The reference: a fresh measurer estimates the band of its only frame.
    StereoMeasurer fresh(r.calibration(), MeasurerConfig{});
    const RutMeasurement reference = fresh.measure(frame.left, frame.right);
    const double truth = r.truth(i).depth_mm;
    std::printf("frame %zu (%s): band %d+%d %s, start %s, depth %.3f mm (fresh %.3f, truth %.3f)\n", i,
                is_low[i] ? "low" : "high", tracking.diagnostics().band.min_disparity,
                tracking.diagnostics().band.num_disparities, estimated.back() ? "estimated" : "kept",
                reused.back() ? "reused" : "engine", m.depth_mm, reference.depth_mm, truth);
    ASSERT_EQ(m.status, RutStatus::Ok) << "frame " << i;
    EXPECT_NEAR(m.depth_mm, truth, 0.5) << "frame " << i;
    EXPECT_NEAR(m.depth_mm, reference.depth_mm, 0.1) << "frame " << i;
    ++checked;
  }
  EXPECT_EQ(checked, 10);
  // Estimated on the first frame and at both jumps, kept on the frames between.
  EXPECT_EQ(estimated, (std::vector<bool>{true, false, false, false, true, false, false, false, true, false}));
  // The engine runs where the band is new, the last frame's disparity starts the others.
  EXPECT_EQ(reused, (std::vector<bool>{false, true, true, true, false, true, true, true, false, true}));
}

// A step of about 2.5 px in disparity that stays inside the kept band: the last frame's disparity is
// then too far off to start the windows (most are rejected), and the frame is matched again from the
// engine rather than measured from what little refined.
TEST(BandTracking, AStartThatNoLongerFitsIsMatchedAgainFromTheEngine) {
  SyntheticRendererConfig near_config;
  near_config.rut.depth_mm = 45;
  SyntheticRendererConfig far_config = near_config;
  far_config.rig.height_mm = 362;
  const SyntheticRenderer near_renderer(near_config), far_renderer(far_config);
  StereoMeasurer tracking(near_renderer.calibration(), MeasurerConfig{});
  std::vector<bool> reused, estimated;
  for (std::uint64_t i = 0; i < 4; ++i) {
    const SyntheticRenderer& r = i < 2 ? near_renderer : far_renderer;
    StereoFrame frame;
    r.render(i, frame);
    const RutMeasurement m = tracking.measure(frame.left, frame.right);
    reused.push_back(tracking.diagnostics().starts_reused);
    estimated.push_back(tracking.diagnostics().band_estimated);
    std::printf("frame %llu: band %s, start %s, %d columns refined, depth %.3f mm (truth %.3f)\n",
                static_cast<unsigned long long>(i), estimated.back() ? "estimated" : "kept",
                reused.back() ? "reused" : "engine", tracking.diagnostics().dic.refined, m.depth_mm,
                r.truth(i).depth_mm);
    ASSERT_EQ(m.status, RutStatus::Ok) << "frame " << i;
    EXPECT_NEAR(m.depth_mm, r.truth(i).depth_mm, 0.5) << "frame " << i;
  }
  EXPECT_TRUE(reused[1]);
  EXPECT_FALSE(estimated[2]) << "the step was meant to stay inside the band";
  EXPECT_FALSE(reused[2]) << "frame 2 should have been matched again from the engine";
  EXPECT_TRUE(reused[3]);
}

}  // namespace
}  // namespace rutd
