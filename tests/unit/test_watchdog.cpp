// systemd's watchdog is fed only while the pipeline really works: a stage that hangs stops the pings (so
// systemd restarts rutd), a lost camera does not. Tested against a real sd_notify socket (no systemd).
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <string>
#include <thread>
#include <utility>

#include <gtest/gtest.h>

#include "daemon/latest_measurement_sink.hpp"
#include "daemon/no_output_status_sink.hpp"
#include "daemon/service_notifier.hpp"
#include "daemon/supervisor.hpp"
#include "runtime/realtime_pipeline.hpp"
#include "synthetic/cycling_source.hpp"
#include "test_support.hpp"

namespace rutd {
namespace {

using namespace std::chrono_literals;
constexpr std::int64_t kMs = 1000000;

TEST(LivenessMonitor, AliveWhileFramesAreHandled) {
  LivenessMonitor m(200ms);
  std::uint64_t acquired = 0, handled = 0, status = 0;
  for (std::int64_t t = 0; t < 2000 * kMs; t += 20 * kMs) {
    ++acquired, ++handled, ++status;
    EXPECT_TRUE(m.update(acquired, handled, status, t));
  }
}

TEST(LivenessMonitor, LostCameraIsNotAStall) {
  LivenessMonitor m(200ms);
  for (std::int64_t t = 0, status = 0; t < 2000 * kMs; t += 20 * kMs) EXPECT_TRUE(m.update(5, 5, ++status, t));
}

TEST(LivenessMonitor, HungStageIsAStallAfterTheTimeout) {
  LivenessMonitor m(200ms);
  std::uint64_t acquired = 10, status = 0;
  EXPECT_TRUE(m.update(acquired, 10, status, 0));
  std::int64_t t = 0;
  for (; t <= 200 * kMs; t += 20 * kMs) EXPECT_TRUE(m.update(++acquired, 10, ++status, t)) << t;
  EXPECT_FALSE(m.update(++acquired, 10, ++status, t));
  EXPECT_TRUE(m.update(++acquired, 11, ++status, t + kMs)) << "handled again: alive again";
}

TEST(LivenessMonitor, SilentPublisherIsAStall) {
  LivenessMonitor m(200ms);
  EXPECT_TRUE(m.update(0, 0, 7, 0));
  EXPECT_TRUE(m.update(0, 0, 7, 150 * kMs));
  EXPECT_FALSE(m.update(0, 0, 7, 250 * kMs));
}

// Stages whose match blocks while `hang` is set, as a stage stuck in a driver call would.
class HangableStages final : public PipelineStages {
 public:
  std::atomic<bool> hang{false};
  bool rectify(FrameWork&) override { return true; }
  void match(FrameWork&) override {
    while (hang.load()) std::this_thread::sleep_for(1ms);
  }
  void extract(FrameWork& w) override {
    w.measurement.status = RutStatus::Ok;
    w.measurement.depth_mm = 42.0;
  }
};

// Receives what the process sends to NOTIFY_SOCKET.
class NotifySocket {
 public:
  explicit NotifySocket(const std::string& path) : fd_(socket(AF_UNIX, SOCK_DGRAM | SOCK_NONBLOCK, 0)) {
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    path.copy(addr.sun_path, sizeof(addr.sun_path) - 1);
    if (fd_ < 0 || bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0) throw std::runtime_error("bind");
  }
  ~NotifySocket() { close(fd_); }
  // Reads what has arrived; must be called often: a unix datagram queue holds only a few messages and
  // sd_notify blocks when it is full.
  void poll() {
    char buf[512];
    for (ssize_t len; (len = recv(fd_, buf, sizeof(buf), 0)) > 0;) {
      const std::string msg(buf, static_cast<std::size_t>(len));
      if (msg.find("WATCHDOG=1") != std::string::npos) ++watchdog_;
      if (msg.find("READY=1") != std::string::npos) ++ready_;
    }
  }
  // Messages of each kind since the last take.
  int take_watchdog() { return std::exchange(watchdog_, 0); }
  int take_ready() { return std::exchange(ready_, 0); }

 private:
  int fd_;
  int watchdog_ = 0, ready_ = 0;
};

TEST(Watchdog, HungStageStopsThePingsAndRecoveryResumesThem) {
  const test::TempDir tmp;
  const std::string path = (tmp.path() / "notify").string();
  NotifySocket sock(path);
  // systemd's protocol: these variables are how it hands a service its socket and watchdog interval.
  setenv("NOTIFY_SOCKET", path.c_str(), 1);
  setenv("WATCHDOG_USEC", "200000", 1);
  setenv("WATCHDOG_PID", std::to_string(getpid()).c_str(), 1);
  ServiceNotifier notifier;
  ASSERT_EQ(notifier.watchdog_interval(), 200ms);

  // Small black pairs every 5 ms.
  StereoCalibration calibration;
  calibration.image_size = {64, 48};
  StereoFrame black;
  black.left = cv::Mat::zeros(48, 64, CV_8UC1);
  black.right = black.left.clone();
  CyclingSource source(calibration, {black}, 5ms);
  HangableStages stages;
  LatestMeasurementSink latest;
  PipelineConfig config;
  config.prime_slots = false;
  config.status_period = 20ms;
  config.max_frame_age = 0ms;
  RealtimePipeline pipeline(source, stages, latest, config);
  Supervisor supervisor(notifier, 200ms, 10s);
  const auto run_for = [&](std::chrono::milliseconds d) {
    const auto end = std::chrono::steady_clock::now() + d;
    bool alive = true;
    while (std::chrono::steady_clock::now() < end) {
      alive = supervisor.tick(pipeline.stats(), latest, monotonic_now_ns());
      sock.poll();
      std::this_thread::sleep_for(20ms);
    }
    return alive;
  };
  pipeline.start();

  EXPECT_TRUE(run_for(400ms));
  EXPECT_EQ(sock.take_ready(), 1) << "ready after the first good measurement";
  EXPECT_TRUE(supervisor.ready_sent());
  EXPECT_GT(sock.take_watchdog(), 5);

  stages.hang = true;
  run_for(400ms);  // the stall is detected after 200 ms
  sock.take_watchdog();
  EXPECT_FALSE(run_for(400ms));
  EXPECT_EQ(sock.take_watchdog(), 0) << "pings must stop while a stage hangs";

  stages.hang = false;
  EXPECT_TRUE(run_for(400ms));
  EXPECT_GT(sock.take_watchdog(), 5) << "pings resume once frames move again";
  pipeline.stop();
  unsetenv("NOTIFY_SOCKET");
  unsetenv("WATCHDOG_USEC");
  unsetenv("WATCHDOG_PID");
}

// Points NOTIFY_SOCKET and WATCHDOG_USEC (200 ms) at a socket of its own for one test, as systemd does.
class NotifyEnvironment {
 public:
  NotifyEnvironment() : sock_((tmp_.path() / "notify").string()) {
    setenv("NOTIFY_SOCKET", (tmp_.path() / "notify").c_str(), 1);
    setenv("WATCHDOG_USEC", "200000", 1);
    setenv("WATCHDOG_PID", std::to_string(getpid()).c_str(), 1);
  }
  ~NotifyEnvironment() {
    unsetenv("NOTIFY_SOCKET");
    unsetenv("WATCHDOG_USEC");
    unsetenv("WATCHDOG_PID");
  }
  NotifySocket& sock() { return sock_; }

 private:
  test::TempDir tmp_;
  NotifySocket sock_;
};

// systemd arms the watchdog at the first WATCHDOG=1, even while the unit is still activating: a ping
// before READY=1 would let a slow start be killed as a hang. Here the first pairs never come out of the
// stages (a slow first measurement looks the same), so the pipeline counts as stalled after 200 ms.
TEST(Supervisor, NoWatchdogPingBeforeReady) {
  NotifyEnvironment env;
  ServiceNotifier notifier;
  Supervisor supervisor(notifier, 200ms, 1000ms);
  LatestMeasurementSink latest;  // nothing good published: READY=1 only at the 1 s start-up limit
  PipelineStats s;
  std::int64_t t = 0;
  for (; t < 1000 * kMs; t += 20 * kMs) {
    ++s.acquired, ++s.status_sent;
    supervisor.tick(s, latest, t);
    env.sock().poll();
  }
  EXPECT_EQ(env.sock().take_ready(), 0);
  EXPECT_EQ(env.sock().take_watchdog(), 0) << "no ping may arm the watchdog before READY=1";
  ++s.acquired, ++s.status_sent;
  EXPECT_FALSE(supervisor.tick(s, latest, t)) << "still stalled at the start-up limit";
  env.sock().poll();
  EXPECT_EQ(env.sock().take_ready(), 1) << "ready when the start-up time is up";
  EXPECT_EQ(env.sock().take_watchdog(), 0) << "stalled: READY=1, then no ping, and systemd's watchdog fires";
  for (int i = 0; i < 10; ++i) {
    t += 20 * kMs;
    ++s.acquired, ++s.published, ++s.status_sent;
    EXPECT_TRUE(supervisor.tick(s, latest, t));
    env.sock().poll();
  }
  EXPECT_EQ(env.sock().take_watchdog(), 10) << "after READY=1, a ping every tick while pairs are handled";
}

// Every pair refused as stale: the pipeline moves, so the watchdog stays fed (a restart would not make
// it faster), but the supervisor reports that nothing comes out, and when output resumes.
TEST(Supervisor, StaleOnlyKeepsThePingsAndReportsNoOutput) {
  NotifyEnvironment env;
  ServiceNotifier notifier;
  Supervisor supervisor(notifier, 200ms, 1000ms, 500ms);
  LatestMeasurementSink latest;
  PipelineStats s;
  std::int64_t t = 0;
  s.acquired = s.published = s.status_sent = 1;
  for (; t < 1500 * kMs; t += 20 * kMs) {
    ++s.acquired, ++s.stale[static_cast<std::size_t>(Stage::Match)], ++s.status_sent;
    EXPECT_TRUE(supervisor.tick(s, latest, t)) << t;
    EXPECT_EQ(supervisor.without_output(), t >= 500 * kMs) << t;
    env.sock().poll();
  }
  EXPECT_EQ(env.sock().take_ready(), 1);
  EXPECT_GE(env.sock().take_watchdog(), 20) << "pings go on while every pair is stale";
  ++s.acquired, ++s.published, ++s.status_sent;
  EXPECT_TRUE(supervisor.tick(s, latest, t));
  EXPECT_FALSE(supervisor.without_output());
}

// Records the health of every status message.
class StatusRecorder final : public MeasurementSink {
 public:
  void publish(const PublishedFrame&) override { ++published; }
  void publish_status(const SensorHealth& h, std::int64_t) override { last = h; }
  int published = 0;
  SensorHealth last;
};

TEST(NoOutputStatusSink, StatusFrameSaysNoMeasurementOnceOutputStops) {
  StatusRecorder next;
  NoOutputStatusSink sink(next, 300ms);
  SensorHealth ok;
  ok.last_status = RutStatus::Ok;
  ok.stale_frames = true;
  const std::int64_t t0 = monotonic_now_ns();
  sink.publish_status(ok, t0);
  EXPECT_EQ(next.last.last_status, RutStatus::Ok);
  sink.publish_status(ok, t0 + 299 * kMs);
  EXPECT_EQ(next.last.last_status, RutStatus::Ok);
  sink.publish_status(ok, t0 + 300 * kMs);
  EXPECT_EQ(next.last.last_status, RutStatus::NoMeasurement) << "nothing published for 300 ms";
  EXPECT_TRUE(next.last.stale_frames) << "the pipeline's flags pass through";
  PublishedFrame frame;
  frame.health = ok;
  sink.publish(frame);
  EXPECT_EQ(next.published, 1);
  sink.publish_status(ok, monotonic_now_ns());
  EXPECT_EQ(next.last.last_status, RutStatus::Ok) << "published again";
}

}  // namespace
}  // namespace rutd
