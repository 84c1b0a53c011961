// AravisStereoSource against two of Aravis's fake GigE Vision cameras over loopback UDP (see
// fake_stereo_rig.hpp): discovery, configuration, pairing, measurement against the renderer's truth,
// software trigger, a camera lost and back, and configurations the cameras must refuse.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <thread>

#include <gtest/gtest.h>

#include "aravis/fake_stereo_rig.hpp"
#include "camera/aravis_stereo_source.hpp"
#include "measurement/measurer.hpp"

namespace rutd {
namespace {

using Clock = std::chrono::steady_clock;
constexpr int kViews = 6;

SyntheticRendererConfig scene() {
  SyntheticRendererConfig p;
  p.rig.image_size = {640, 480};
  p.rut.depth_mm = 45;
  p.seed = 11;
  return p;
}

AravisSourceConfig cameras() {
  AravisSourceConfig c;
  c.left = test::kFakeSerial[0];    // by serial number
  c.right = test::kFakeAddress[1];  // by IP address
  c.roi = {0, 0, 640, 480};
  c.fps = 25;
  // The fake cameras stamp frames when their thread wakes, so on a busy machine their timestamps jitter
  // by milliseconds (real PTP cameras: microseconds); and a loaded machine can delay a frame's delivery.
  c.pairing_window_ms = 8;
  c.stall_timeout_ms = 300;
  c.reconnect_min_ms = 50;
  c.reconnect_max_ms = 400;
  return c;
}

// Which rendered view `image` is, or -1: the fake cameras send the views byte for byte.
int view_index(const cv::Mat& image, const std::vector<cv::Mat>& views) {
  for (std::size_t i = 0; i < views.size(); ++i)
    if (image.size() == views[i].size() && image.type() == views[i].type() &&
        cv::norm(image, views[i], cv::NORM_INF) == 0)
      return static_cast<int>(i);
  return -1;
}

class AravisSource : public ::testing::Test {
 protected:
  void SetUp() override {
    if (const std::string why = test::fake_rig_unavailable(); !why.empty()) RUTD_SKIP_NEEDS_INSTALLED(why);
  }
};

// Collects `n` pairs. Source errors are counted and printed, not fatal: on a starved machine a stream
// can go silent past the stall timeout, and rutd then reopens the camera (which is what it should do);
// the tests bound how often that may happen.
std::vector<StereoFrame> collect(AravisStereoSource& source, int n, int* errors = nullptr, int max_calls = 400) {
  std::vector<StereoFrame> frames;
  int error_count = 0;
  for (int calls = 0; static_cast<int>(frames.size()) < n && calls < max_calls; ++calls) {
    StereoFrame f;
    const SourceStatus s = source.next(f);
    if (s == SourceStatus::Error) {
      if (error_count++ == 0) std::printf("source error (recovering): %s\n", source.error_message().c_str());
    }
    if (s == SourceStatus::Ok) frames.push_back(std::move(f));
  }
  if (errors != nullptr) *errors = error_count;
  return frames;
}

TEST_F(AravisSource, FreeRunningPairsAreSameInstantAndMeasureTheRenderedRut) {
  test::FakeStereoRig rig(scene(), kViews);
  AravisStereoSource source(cameras(), rig.calibration());
  const std::vector<cv::Mat>& left_views = rig.views(0);
  const std::vector<cv::Mat>& right_views = rig.views(1);
  int errors = 0;
  const std::vector<StereoFrame> frames = collect(source, 30, &errors);
  ASSERT_EQ(frames.size(), 30u);
  EXPECT_LT(errors, 40) << "more than one recovery";

  StereoMeasurer measurer(rig.calibration(), MeasurerConfig{});
  // The fake cameras stamp a frame when their thread wakes and pick its view from that stamp, so on a
  // loaded machine a wake-up late by half a period can stamp (and fill) one camera's frame with the next
  // instant. Real cameras stamp in hardware. So a few pairs may be off; most must be exact.
  double worst = 0;
  int mixed_pairs = 0, uneven_steps = 0;
  for (std::size_t k = 0; k < frames.size(); ++k) {
    const StereoFrame& f = frames[k];
    EXPECT_EQ(f.clock, ClockKind::Hardware);
    if (k > 0) {
      EXPECT_EQ(f.seq, frames[k - 1].seq + 1);
      EXPECT_GT(f.t_ns, frames[k - 1].t_ns);
      // Consecutive pairs are whole frame periods apart on the cameras' clock.
      const double periods = static_cast<double>(f.t_ns - frames[k - 1].t_ns) / test::kFakePeriodNs;
      if (std::abs(periods - std::round(periods)) > 0.25) ++uneven_steps;
    }
    // Left and right are the two views of one instant.
    const int li = view_index(f.left, left_views), ri = view_index(f.right, right_views);
    ASSERT_GE(li, 0) << "left image of pair " << k << " is not a rendered view";
    ASSERT_GE(ri, 0) << "right image of pair " << k << " is not a rendered view";
    if (li != ri) {
      ++mixed_pairs;
      continue;
    }
    if (k < 10) {
      const RutMeasurement m = measurer.measure(f.left, f.right);
      ASSERT_EQ(m.status, RutStatus::Ok) << k;
      const double error = m.depth_mm - rig.renderer().truth(static_cast<std::uint64_t>(li)).depth_mm;
      worst = std::max(worst, std::abs(error));
      EXPECT_LT(std::abs(error), 1.0) << "pair " << k;
    }
  }
  std::printf("%d of %zu pairs mixed two instants, %d steps not a whole number of periods\n", mixed_pairs,
              frames.size(), uneven_steps);
  EXPECT_LE(mixed_pairs, 3);
  EXPECT_LE(uneven_steps, 6);
  const AravisSourceStats s = source.stats();
  std::printf("free run: %s; worst depth error %.3f mm\n", describe(s).c_str(), worst);
  EXPECT_GE(s.pairing.pairs, 30u);
  EXPECT_LE(s.pairing.skew_max_ns, 8'000'000);
  EXPECT_EQ(s.convert_failures, 0u);

  // The check has teeth: two instants one period apart do not measure as the truth.
  const RutMeasurement mixed = measurer.measure(left_views[0], right_views[1]);
  std::printf("views 0/1 mixed: status %d depth %.2f mm (truth %.2f)\n", static_cast<int>(mixed.status), mixed.depth_mm,
              rig.renderer().truth(0).depth_mm);
  EXPECT_TRUE(mixed.status != RutStatus::Ok || std::abs(mixed.depth_mm - rig.renderer().truth(0).depth_mm) > 1.0);
}

TEST_F(AravisSource, SoftwareTriggerFiresBothCamerasAndPairsByFrameId) {
  test::FakeStereoRig rig(scene(), kViews);
  AravisSourceConfig c = cameras();
  c.sync = CameraSync::SoftwareTrigger;
  c.fps = 10;
  c.stall_timeout_ms = 300;
  AravisStereoSource source(c, rig.calibration());
  const std::vector<cv::Mat>& left_views = rig.views(0);
  const std::vector<cv::Mat>& right_views = rig.views(1);
  const auto t0 = Clock::now();
  int errors = 0;
  const std::vector<StereoFrame> frames = collect(source, 12, &errors);
  const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  ASSERT_EQ(frames.size(), 12u);
  EXPECT_LT(errors, 40) << "more than one recovery";
  int mixed_pairs = 0;
  for (const StereoFrame& f : frames) {
    const int li = view_index(f.left, left_views);
    ASSERT_GE(li, 0);
    if (li != view_index(f.right, right_views)) ++mixed_pairs;
  }
  EXPECT_LE(mixed_pairs, 1);
  const AravisSourceStats s = source.stats();
  std::printf("software trigger: %.1f pairs/s; %s\n", frames.size() / seconds, describe(s).c_str());
  EXPECT_EQ(s.trigger_failures, 0u);
  // One frame per trigger: pairs follow the trigger rate (10 Hz), not the cameras' own 25 Hz.
  EXPECT_LE(s.pairing.left.received, s.triggers + 1);
  if (errors == 0) {
    EXPECT_LT(frames.size() / seconds, 16.0);
  }
}

TEST_F(AravisSource, LostCameraIsReportedAndReconnectedWithoutRestart) {
  test::FakeStereoRig rig(scene(), kViews);
  AravisSourceConfig c = cameras();
  c.stall_timeout_ms = 150;
  AravisStereoSource source(c, rig.calibration());
  ASSERT_EQ(collect(source, 5).size(), 5u);
  // Counted from here: a starved test machine can stall a stream past 150 ms before the fault too.
  const AravisSourceStats before = source.stats();

  rig.stop(1);
  const auto stopped = Clock::now();
  StereoFrame f;
  SourceStatus s = SourceStatus::Ok;
  while (Clock::now() - stopped < std::chrono::seconds(3) && (s = source.next(f)) != SourceStatus::Error) {
  }
  const double detect_ms = std::chrono::duration<double, std::milli>(Clock::now() - stopped).count();
  ASSERT_EQ(s, SourceStatus::Error);
  EXPECT_NE(source.error_message().find("right camera 127.0.0.2"), std::string::npos) << source.error_message();
  std::printf("right camera stopped: Error after %.0f ms: %s\n", detect_ms, source.error_message().c_str());
  EXPECT_LT(detect_ms, 1000.0);

  // Stays in Error (never a pair from one camera) until it is back.
  for (int i = 0; i < 10; ++i) EXPECT_EQ(source.next(f), SourceStatus::Error);
  std::printf("while lost: %s\n", source.error_message().c_str());

  rig.start(1);
  const auto restarted = Clock::now();
  while (Clock::now() - restarted < std::chrono::seconds(5) && source.next(f) != SourceStatus::Ok) {
  }
  const double resume_ms = std::chrono::duration<double, std::milli>(Clock::now() - restarted).count();
  std::printf("right camera restarted: pairs again after %.0f ms\n", resume_ms);
  EXPECT_LT(resume_ms, 2000.0);
  ASSERT_EQ(collect(source, 5).size(), 5u);
  const AravisSourceStats stats = source.stats();
  EXPECT_EQ(stats.losses[1] - before.losses[1], 1u);
  EXPECT_EQ(stats.reconnects[1] - before.reconnects[1], 1u);
  EXPECT_EQ(stats.losses[0], before.losses[0]);
}

TEST_F(AravisSource, CameraNotFoundAtStartIsWaitedFor) {
  test::FakeStereoRig rig(scene(), kViews);
  rig.stop(0);
  AravisStereoSource source(cameras(), rig.calibration());
  ASSERT_FALSE(source.warnings().empty());
  EXPECT_NE(source.warnings()[0].find("left camera RUTDL01: not found"), std::string::npos) << source.warnings()[0];
  StereoFrame f;
  EXPECT_EQ(source.next(f), SourceStatus::Error);
  EXPECT_NE(source.error_message().find("left camera RUTDL01"), std::string::npos) << source.error_message();
  rig.start(0);
  const auto started = Clock::now();
  while (Clock::now() - started < std::chrono::seconds(5) && source.next(f) != SourceStatus::Ok) {
  }
  EXPECT_EQ(f.left.size(), cv::Size(640, 480));
  std::printf("left camera appeared: first pair after %.0f ms\n",
              std::chrono::duration<double, std::milli>(Clock::now() - started).count());
}

TEST_F(AravisSource, Mono16ArrivesAsSixteenBitImagesExactly) {
  test::FakeStereoRig rig(scene(), kViews);
  AravisSourceConfig c = cameras();
  c.pixel_format = CameraPixelFormat::Mono16;
  AravisStereoSource source(c, rig.calibration());
  const std::vector<cv::Mat>& left16 = rig.views16(0);
  const std::vector<StereoFrame> frames = collect(source, 4);
  ASSERT_EQ(frames.size(), 4u);
  for (const StereoFrame& f : frames) {
    EXPECT_EQ(f.left.type(), CV_16UC1);
    EXPECT_GE(view_index(f.left, left16), 0);
  }
}

TEST_F(AravisSource, ConfigurationTheCamerasCannotMeetIsRefusedNamingTheKey) {
  test::FakeStereoRig rig(scene(), 1);
  AravisSourceConfig whole = cameras();
  whole.roi = {};  // the fake sensor's 2048 x 2048, not the calibration's 640 x 480
  try {
    AravisStereoSource source(whole, rig.calibration());
    FAIL() << "a region of another size than the calibration was accepted";
  } catch (const CameraError& e) {
    EXPECT_EQ(e.field(), "roi");
    EXPECT_NE(std::string(e.what()).find("2048x2048"), std::string::npos) << e.what();
    std::printf("%s\n", e.what());
  }
  AravisSourceConfig hw = cameras();
  hw.sync = CameraSync::HardwareTrigger;
  hw.trigger_line = "Line7";  // the fake camera's trigger sources are Line1 and Software
  try {
    AravisStereoSource source(hw, rig.calibration());
    FAIL() << "a trigger line the camera lacks was accepted";
  } catch (const CameraError& e) {
    EXPECT_EQ(e.field(), "trigger_line");
    std::printf("%s\n", e.what());
  }
  AravisSourceConfig same = cameras();
  same.right = same.left;
  EXPECT_THROW(AravisStereoSource(same, rig.calibration()), std::invalid_argument);
}

}  // namespace
}  // namespace rutd
