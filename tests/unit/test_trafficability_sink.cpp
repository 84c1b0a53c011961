// TrafficabilitySink's ordering contract: live, the periodic status can come between a pair's capture and
// its publication (the pipeline's latency), and it drains the speed queue; it must not feed the odometer a
// sample received after the capture of a pair still to be published, or that pair's distance would differ
// from the one a replay of the same recording computes (there statuses follow the pairs' times).
#include <cstdint>
#include <vector>

#include <gtest/gtest.h>

#include "daemon/trafficability_sink.hpp"

namespace rutd {
namespace {

// Keeps the motion of every frame handed on.
class MotionLog final : public MeasurementSink {
 public:
  void publish(const PublishedFrame& frame) override { motions.push_back(frame.motion); }
  void publish_status(const SensorHealth&, std::int64_t) override {}
  std::vector<VehicleMotion> motions;
};

// 2 m/s, one sample every 20 ms from t = 0, in the order received.
struct SpeedFeed {
  std::vector<SpeedSample> samples;
  std::size_t next = 0;
  SpeedFeed() {
    for (int k = 0; k <= 150; ++k) samples.push_back({k * 20'000'000LL, SpeedState::Ok, 2000.0});
  }
  SpeedSamplePull pull() {
    return [this](std::int64_t up_to, SpeedSample& out) {
      if (next >= samples.size() || samples[next].t_ns > up_to) return false;
      out = samples[next++];
      return true;
    };
  }
};

constexpr std::int64_t kMs = 1'000'000;

// Pairs captured every 33 ms; each published 90 ms after capture, with a status every 100 ms in between
// (as a loaded publish thread sees them). Returns the motions published.
std::vector<VehicleMotion> run_live(std::int64_t status_lag_ns) {
  SpeedFeed feed;
  MotionLog log;
  TrafficabilitySink sink(log, feed.pull(), OdometerConfig{}, SegmentConfig{}, status_lag_ns);
  std::int64_t next_status = 100 * kMs;
  for (int i = 0; i < 60; ++i) {
    const std::int64_t capture = 500 * kMs + i * 33 * kMs, published = capture + 90 * kMs;
    for (; next_status <= published; next_status += 100 * kMs) sink.publish_status(SensorHealth{}, next_status);
    PublishedFrame frame;
    frame.t_ns = capture;
    frame.measurement.status = RutStatus::Ok;
    frame.measurement.depth_mm = 40;
    sink.publish(frame);
  }
  return log.motions;
}

// The replay of the same pairs: statuses at the pairs' times, before each.
std::vector<VehicleMotion> run_replay() {
  SpeedFeed feed;
  MotionLog log;
  TrafficabilitySink sink(log, feed.pull(), OdometerConfig{}, SegmentConfig{});
  for (int i = 0; i < 60; ++i) {
    PublishedFrame frame;
    frame.t_ns = 500 * kMs + i * 33 * kMs;
    sink.publish_status(SensorHealth{}, frame.t_ns);
    frame.measurement.status = RutStatus::Ok;
    sink.publish(frame);
  }
  return log.motions;
}

TEST(TrafficabilitySink, AStatusBetweenCaptureAndPublicationLeavesThePairsDistanceAsReplayHasIt) {
  const auto live = run_live(600 * kMs);  // the daemon's lag: max_frame_age 500 ms + 100 ms
  const auto replay = run_replay();
  ASSERT_EQ(live.size(), 60u);
  ASSERT_EQ(replay.size(), 60u);
  for (std::size_t i = 0; i < live.size(); ++i) {
    EXPECT_EQ(live[i].state, SpeedState::Ok) << i;
    EXPECT_EQ(live[i].distance_m, replay[i].distance_m) << "pair " << i;
    // The independent value: 2 m/s up to the last sample at or before the capture (no extrapolation).
    const std::int64_t capture = 500 * kMs + static_cast<std::int64_t>(i) * 33 * kMs;
    EXPECT_NEAR(live[i].distance_m, 2.0 * static_cast<double>(capture / (20 * kMs)) * 0.02, 1e-9) << "pair " << i;
  }
}

TEST(TrafficabilitySink, WithoutTheLagAStatusRunsThePairsDistanceAhead) {
  // The behaviour the lag prevents, so the test above cannot pass by accident: draining up to the status's
  // own time gives pairs published after a status a distance from samples received after their capture.
  const auto live = run_live(0);
  const auto replay = run_replay();
  ASSERT_EQ(live.size(), replay.size());
  std::size_t ahead = 0;
  for (std::size_t i = 0; i < live.size(); ++i) ahead += live[i].distance_m > replay[i].distance_m;
  EXPECT_GT(ahead, 10u);
}

}  // namespace
}  // namespace rutd
