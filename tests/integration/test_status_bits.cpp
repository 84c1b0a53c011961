// The status frame's health bits, end to end through `rutd run` as a vehicle sees them: the candump log
// the daemon writes is decoded with config/rutd.dbc by canmatrix (tests/can/decode_candump.py). Each
// test makes the condition happen to the daemon (a silent source, a pipeline slower than the frames'
// age limit, pairs faster than they are measured, a featureless or a half-blind scene) and reads the bit off the
// decoded frames. BusOff and CanTxDrops come from the CAN sink's bus: tests/can/test_can_sink_status.cpp.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "decoded_candump.hpp"
#include "recording/recording.hpp"
#include "synthetic/synthetic_renderer.hpp"
#include "test_support.hpp"

namespace rutd {
namespace {

std::vector<test::DecodedFrame> run_and_decode(const std::string& args, const test::TempDir& tmp) {
  const auto log = tmp.path() / "can.log";
  EXPECT_EQ(test::run_rutd("run " + args + " --candump " + log.string()), 0);
  bool ok = false;
  auto frames = test::decode_candump(log, ok);
  EXPECT_TRUE(ok) << "decoder reported CRC, counter or format errors";
  return frames;
}

// `rutd synth` with `synth_args` into tmp/rec, then `rutd run` on it as a paced replay source with
// `more_yaml` appended to the configuration; the decoded CAN frames.
std::vector<test::DecodedFrame> run_paced_replay(const std::string& synth_args, const std::string& more_yaml,
                                                 const test::TempDir& tmp) {
  const std::string rec = (tmp.path() / "rec").string();
  EXPECT_EQ(test::run_rutd("synth " + rec + " " + synth_args), 0);
  const auto config = tmp.path() / "rutd.yaml";
  std::ofstream(config) << "source:\n  type: replay\n  replay:\n    dir: " << rec << "\n    paced: true\n" << more_yaml;
  return run_and_decode("--config " + config.string(), tmp);
}

// A recording of `count` pairs 1/30 s apart: the renderer's calibration, the left image from `left`
// (empty: rendered), the right image from `right` (empty: rendered).
void write_recording(const std::string& dir, int count, const cv::Mat& left, const cv::Mat& right) {
  const SyntheticRenderer renderer(SyntheticRendererConfig{});
  RecordingWriter writer(dir, renderer.calibration());
  StereoFrame frame;
  for (int i = 0; i < count; ++i) {
    renderer.render(static_cast<std::uint64_t>(i), frame);
    if (!left.empty()) left.copyTo(frame.left);
    if (!right.empty()) right.copyTo(frame.right);
    frame.t_ns = static_cast<std::int64_t>(i) * 33'333'333;
    ASSERT_TRUE(writer.append(frame)) << writer.error();
  }
}

TEST(StatusBits, NoCameraRaisedWhileThePairsStopAndClearedWhenTheyResume) {
  if (!test::have_canmatrix()) RUTD_SKIP_NEEDS_INSTALLED("needs /usr/bin/python3 with canmatrix (python3-canmatrix)");
  const test::TempDir tmp;
  const std::string rec = (tmp.path() / "rec").string();
  // Pairs 2.5 s apart, replayed at their own pace: the source is silent for longer than the 1 s after
  // which no_camera is raised, then delivers again.
  ASSERT_EQ(test::run_rutd("synth " + rec + " --frames 3 --fps 0.4 --seed 3"), 0);
  const auto frames = run_and_decode("--replay " + rec + " --frames 3", tmp);
  int measurements = 0, raised_after = -1, cleared_after = -1;
  for (const auto& f : frames) {
    if (f.message == "RutMeasurement1") ++measurements;
    if (f.message != "RutSensorStatus") continue;
    const bool no_camera = f.phys.at("NoCamera") == 1;
    if (no_camera && measurements >= 1 && raised_after < 0) raised_after = measurements;
    if (!no_camera && raised_after >= 0 && measurements > raised_after && cleared_after < 0)
      cleared_after = measurements;
  }
  EXPECT_GE(measurements, 2);
  EXPECT_GE(raised_after, 1) << "NoCamera never raised while the source was silent";
  EXPECT_GT(cleared_after, raised_after) << "NoCamera not cleared once pairs came again";
}

TEST(StatusBits, StaleFramesRaisedWhenMeasuringIsSlowerThanTheAgeLimit) {
  if (!test::have_canmatrix()) RUTD_SKIP_NEEDS_INSTALLED("needs /usr/bin/python3 with canmatrix (python3-canmatrix)");
  const test::TempDir tmp;
  // Frames older than 1 ms when they reach a stage are refused: matching alone takes longer.
  const auto frames = run_paced_replay("--frames 20 --fps 30 --seed 4", "pipeline:\n  max_frame_age_ms: 1\n", tmp);
  const std::string rec = (tmp.path() / "rec").string();
  int stale = 0, status = 0;
  for (const auto& f : frames) {
    if (f.message != "RutSensorStatus") continue;
    ++status;
    stale += f.phys.at("StaleFrames") == 1;
  }
  EXPECT_GT(status, 0);
  EXPECT_GT(stale, 0) << "StaleFrames never raised on " << status << " status frames";

  // The same recording within the default limit: never raised.
  const test::TempDir tmp2;
  const auto clean = run_and_decode("--replay " + rec + " --frames 20", tmp2);
  for (const auto& f : clean) {
    if (f.message == "RutSensorStatus") {
      EXPECT_EQ(f.phys.at("StaleFrames"), 0);
    }
  }
}

// Pairs 1 ms apart, replayed at their own pace (as fast as their images decode) and measured on 400
// rows with the slowest matcher: far faster than the stages measure them, so the pipeline drops pairs
// at its full queues. FrameDrops goes up, and every pair is accounted for: the measurements published
// plus the last status frame's DroppedFrames (drops and stale refusals) make the recording's 40 pairs.
TEST(StatusBits, FrameDropsRaisedWhenPairsComeFasterThanTheyAreMeasured) {
  if (!test::have_canmatrix()) RUTD_SKIP_NEEDS_INSTALLED("needs /usr/bin/python3 with canmatrix (python3-canmatrix)");
  const test::TempDir tmp;
  const auto frames =
      run_paced_replay("--frames 40 --fps 1000 --seed 5", "measurement:\n  engine: hh\n  strip:\n    rows: 400\n", tmp);
  int measurements = 0, status = 0, raised = 0;
  double last_dropped = -1;
  for (const auto& f : frames) {
    measurements += f.message == "RutMeasurement1";
    if (f.message != "RutSensorStatus") continue;
    ++status;
    raised += f.phys.at("FrameDrops") == 1;
    last_dropped = f.phys.at("DroppedFrames");
  }
  std::printf("%d measurements published, %d status frames, FrameDrops on %d, DroppedFrames %.0f at the end\n",
              measurements, status, raised, last_dropped);
  EXPECT_GT(status, 0);
  EXPECT_GT(raised, 0) << "FrameDrops never raised";
  EXPECT_GE(last_dropped, 10);
  EXPECT_EQ(measurements + static_cast<int>(last_dropped), 40);
}

TEST(StatusBits, LowTextureRaisedOnAFeaturelessScene) {
  if (!test::have_canmatrix()) RUTD_SKIP_NEEDS_INSTALLED("needs /usr/bin/python3 with canmatrix (python3-canmatrix)");
  const test::TempDir tmp;
  const std::string rec = (tmp.path() / "rec").string();
  const cv::Mat grey(SyntheticRendererConfig{}.rig.image_size, CV_8UC1, cv::Scalar(128));
  write_recording(rec, 12, grey, grey);
  const auto frames = run_and_decode("--replay " + rec + " --frames 12", tmp);
  int measurements = 0, low_texture = 0;
  double last_dropped = -1;
  for (const auto& f : frames) {
    if (f.message == "RutMeasurement1") {
      ++measurements;
      EXPECT_EQ(f.named.at("RutM1_Status"), "TOO_FEW_POINTS");
    }
    if (f.message != "RutSensorStatus") continue;
    if (measurements > 0) low_texture += f.phys.at("LowTexture") == 1;
    last_dropped = f.phys.at("DroppedFrames");
  }
  // Real-time mode: freshest wins, so a pair is dropped whenever matching lags (how many depends on the
  // machine's load: most of them under a sanitizer on a busy machine). Every pair is accounted for.
  EXPECT_GE(measurements, 1);
  EXPECT_EQ(measurements + static_cast<int>(last_dropped), 12) << measurements << " measured";
  EXPECT_GT(low_texture, 0) << "LowTexture never raised";
}

TEST(StatusBits, ARefusedDepthNamesItsConditionOnTheStatusFrame) {
  if (!test::have_canmatrix()) RUTD_SKIP_NEEDS_INSTALLED("needs /usr/bin/python3 with canmatrix (python3-canmatrix)");
  const test::TempDir tmp;
  const std::string rec = (tmp.path() / "rec").string();
  // The left lens covered by something dark and flat; the right camera sees the rut.
  const cv::Mat dark(SyntheticRendererConfig{}.rig.image_size, CV_8UC1, cv::Scalar(20));
  write_recording(rec, 12, dark, cv::Mat());
  const auto frames = run_and_decode("--replay " + rec + " --frames 12", tmp);
  int measurements = 0, named = 0, left_flag = 0;
  double last_dropped = -1;
  for (const auto& f : frames) {
    if (f.message == "RutMeasurement1") ++measurements;
    if (f.message == "RutConditions") left_flag += f.phys.at("LeftLensObstructed") == 1;
    if (f.message != "RutSensorStatus") continue;
    if (measurements > 0) named += f.named.at("RutS_LastStatus") == "LENS_OBSTRUCTED";
    last_dropped = f.phys.at("DroppedFrames");
  }
  // Real-time mode drops pairs while matching lags; every pair is accounted for.
  EXPECT_GE(measurements, 1);
  EXPECT_EQ(measurements + static_cast<int>(last_dropped), 12) << measurements << " measured";
  EXPECT_EQ(left_flag, measurements);
  EXPECT_GT(named, 0) << "the status frame never said LENS_OBSTRUCTED";
}

}  // namespace
}  // namespace rutd
