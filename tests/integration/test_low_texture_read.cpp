// Low-texture frames read again with the images' noise judging the DIC windows' correlation
// (MeasurerConfig::low_texture_read), end to end as a user runs it: `rutd synth` renders clean ruts in
// snow under gain, whose texture the noise rivals (a correct window correlates under min_zncc), and
// `rutd replay` measures them with the second reading and without it (--no-low-texture-read). Against the
// renderer's truth, the second reading must publish more of the frames, and every frame published OK,
// with it or without, must be within 1 mm.
#include <cmath>
#include <cstdio>
#include <string>

#include <gtest/gtest.h>

#include "replay_outcomes.hpp"
#include "test_support.hpp"

namespace rutd {
namespace {

// Two of the scene matrix's clean snow scenes (`rutd bench --scenes`: clean-gain-snow-06, gain 2.2, and
// clean-auto-snow-26, auto exposure on a 40 mm baseline), and one rendered for this test alone (another
// rig, seed and gain).
constexpr const char* kScenes[] = {
    "--texture snow --depth 25.3 --width 201 --bottom-width 96 --pile-left 11.8 --pile-right 6.4 --offset -32 "
    "--baseline 106 --height 482 --hfov 75 --roll 3.3 --pitch -5.2 --noise 1.39 --speed 1049 --right-response 1.020 "
    "--seed 2006 --exposure 0.369 --gain 2.21",
    "--texture snow --depth 23.4 --width 157 --bottom-width 53 --pile-left 10.9 --pile-right 12.3 --offset 26 "
    "--baseline 40 --height 373 --hfov 75 --roll -3.0 --pitch -2.3 --noise 1.87 --speed 1077 --right-response 1.009 "
    "--seed 2026 --auto-exposure --ae-target 0.39 --light 0.94",
    "--texture snow --depth 48 --width 220 --bottom-width 80 --pile-left 8 --pile-right 9 --offset 10 "
    "--baseline 80 --height 450 --hfov 80 --roll 1.5 --pitch 3 --noise 1.6 --speed 900 --right-response 1.03 "
    "--seed 9107 --exposure 0.40 --gain 2.4",
};
constexpr int kFrames = 8;

TEST(LowTextureRead, NoiseJudgedWindowsPublishMoreSnowFramesAndNoneWrong) {
  test::ReplayOutcomes with, without;
  test::replay_with_and_without(kScenes, kFrames, "--no-low-texture-read", with, without);
  if (HasFatalFailure()) return;
  std::printf("OK of %d frames: %d with the low-texture reading, %d without\n", with.frames, with.ok, without.ok);
  EXPECT_EQ(with.ok_beyond_1mm, 0);
  EXPECT_EQ(without.ok_beyond_1mm, 0);
  // Measured: 22 of 24 with, 4 without.
  EXPECT_GE(with.ok, without.ok + 8);
  // The run's summary says how many pairs the second reading measured.
  const std::string said = "read again with the noise judging the windows on ";
  EXPECT_NE(with.logs.find(said), std::string::npos) << with.logs;
  EXPECT_EQ(without.logs.find(said), std::string::npos) << without.logs;
}

// Snow so plain under gain that the engine matched only the rut's shaded walls: no disparity on the ground
// on either side, so the second reading has no start there unless it carries the outermost values to the
// strip's ends (the ground is near a plane; DIC converges from there). Three of the scene matrix's
// scenes (clean-gain-snow-38, steep-gain-snow-06, steep-auto-dim-snow-12): before the carry, 1 of the 24
// frames was published, the rest TOO_FEW_POINTS or NO_GROUND.
constexpr const char* kPlainGroundScenes[] = {
    "--texture snow --depth 36.1 --width 146 --bottom-width 76 --pile-left 17.4 --pile-right 12.4 --offset -1 "
    "--baseline 53 --height 330 --hfov 75 --roll -0.3 --pitch 8.3 --noise 2.07 --speed 1746 --right-response 1.010 "
    "--seed 2038 --wander 35 --wander-wavelength 2120 --exposure 0.369 --gain 1.91",
    "--texture snow --depth 65.6 --width 126 --bottom-width 51 --pile-left 0.6 --pile-right 5.0 --offset -39 "
    "--baseline 89 --height 327 --hfov 90 --roll 1.1 --pitch -0.9 --noise 1.96 --speed 2326 --right-response 1.031 "
    "--seed 2606 --exposure 0.319 --gain 2.80",
    "--texture snow --depth 78.8 --width 135 --bottom-width 45 --pile-left 3.9 --pile-right 12.8 --offset 33 "
    "--baseline 111 --height 431 --hfov 75 --roll -1.1 --pitch 2.0 --noise 2.22 --speed 1436 --right-response 0.981 "
    "--seed 2612 --auto-exposure --ae-target 0.54 --light 0.169",
};

TEST(LowTextureRead, GroundTheEngineLeftUnmatchedIsReadFromTheOutermostMatches) {
  test::ReplayOutcomes with, without;
  test::replay_with_and_without(kPlainGroundScenes, kFrames, "--no-low-texture-read", with, without);
  if (HasFatalFailure()) return;
  std::printf("OK of %d frames: %d with the low-texture reading, %d without\n", with.frames, with.ok, without.ok);
  EXPECT_EQ(with.ok_beyond_1mm, 0);
  EXPECT_EQ(without.ok_beyond_1mm, 0);
  // Measured: 15 of 24 with, 0 without.
  EXPECT_GE(with.ok, 12);
}

}  // namespace
}  // namespace rutd
