// The gpsd position source against a real gpsd on loopback, fed by gpsfake from a drive log we generate
// (nmea_drive.py): the fixes read through libgps equal the log's positions within its resolution, in
// order; gpsfake ending (gpsd going away) is counted and the last fix ages out. Against a fake gpsd that
// misbehaves on purpose (fake_gpsd.py): a malformed report, a time jump and a dropped connection are
// counted, the connection comes back, and positions come back with it. Against no gpsd at all: bounded
// retries, no position, and the source stops at once.
#include <chrono>
#include <set>
#include <thread>

#include <gtest/gtest.h>

#include "core/monotonic_clock.hpp"
#include "gps/gpsd_source.hpp"
#include "gps_test_support.hpp"

namespace rutd {
namespace {

using namespace std::chrono_literals;
using test::fs::path;

class GpsdSourceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::fs::temp_directory_path() / ("rutd_gps_" + std::to_string(::getpid()) + "_" +
                                              ::testing::UnitTest::GetInstance()->current_test_info()->name());
    test::fs::remove_all(dir_);
    test::fs::create_directories(dir_);
  }
  void TearDown() override { test::fs::remove_all(dir_); }
  path dir_;
};

GpsConfig config_for(int port) {
  GpsConfig c;
  c.enabled = true;
  c.port = std::to_string(port);
  c.reconnect_min_ms = 50;
  c.reconnect_max_ms = 200;
  c.max_fix_age_ms = 1000;
  return c;
}

TEST_F(GpsdSourceTest, FixesFromGpsfakeEqualTheLogInOrder) {
  if (!test::gpsfake_installed()) RUTD_SKIP_NEEDS_INSTALLED("gpsd and gpsfake (Debian gpsd, gpsd-clients)");
  test::write_drive(dir_, "--epochs 30 --no-fix-epochs 3 --period 0.2 --heading-deg 60 --alt 1340");
  const auto truth = test::read_truth(dir_ / "drive_truth.csv");
  const int port = test::free_loopback_port();
  // -n: gpsd reads the log at once; -c: 0.05 s a sentence. gpsfake plays the log whether or not a client
  // watches, and plays it again from the start at its end: a client that connects late (a loaded machine,
  // a sanitizer build) reads the rest of one pass and then a whole one, which is the one checked.
  test::ProcessGroup gpsfake(
      {"gpsfake", "-q", "-n", "-c", "0.05", "-P", std::to_string(port), (dir_ / "drive.nmea").string()},
      dir_ / "gpsfake.log");
  ASSERT_TRUE(gpsfake.started());
  ASSERT_TRUE(test::wait_for_port(port, 10s)) << test::read_text(dir_ / "gpsfake.log");
  GpsdSource source(config_for(port));
  std::vector<GeoFix> seen;
  // Until the log's last epoch ends a pass read from its first fix (a pass joined late is dropped there).
  // The log's first fix is epoch 3 (--no-fix-epochs 3); gpsd may report its first position a sentence or
  // two later.
  const int first_fix_epoch = truth.front().epoch + 3;
  bool whole_pass = false;
  const auto end = std::chrono::steady_clock::now() + 40s;
  while (std::chrono::steady_clock::now() < end) {
    const GeoFix f = source.position_at(monotonic_now_ns());
    if (f.valid() && (seen.empty() || f.t_ns != seen.back().t_ns)) {
      const int e = test::matching_epoch(truth, f.latitude_deg, f.longitude_deg);
      if (!seen.empty() || e <= first_fix_epoch + 2) seen.push_back(f);  // else joined mid-pass: wait
      if (!seen.empty() && e == truth.back().epoch) {
        whole_pass = true;
        break;
      }
    }
    std::this_thread::sleep_for(5ms);
  }
  ASSERT_TRUE(whole_pass) << "no whole pass of the log was read: " << seen.size() << " fixes\n"
                          << test::read_text(dir_ / "gpsfake.log");
  gpsfake.stop();  // gpsd goes away mid-run
  std::this_thread::sleep_for(300ms);
  const GpsStats stats = source.stats();
  EXPECT_GE(stats.fixes, 20u) << test::read_text(dir_ / "gpsfake.log");
  EXPECT_EQ(stats.malformed, 0u);
  // Every position read equals one the log holds, and they come in the log's order.
  int last_epoch = -1, matched = 0, with_heading = 0, with_time = 0;
  std::set<int> epochs;
  for (const GeoFix& f : seen) {
    const int e = test::matching_epoch(truth, f.latitude_deg, f.longitude_deg);
    ASSERT_GE(e, 0) << "a position not in the log: " << f.latitude_deg << ", " << f.longitude_deg;
    EXPECT_GE(e, last_epoch);
    last_epoch = e;
    epochs.insert(e);
    ++matched;
    EXPECT_EQ(f.mode, GeoFix::Mode::Fix3d);
    EXPECT_NEAR(f.altitude_m, truth[static_cast<std::size_t>(e)].alt, 1e-3);
    EXPECT_GT(f.horizontal_error_m, 0.0);
    with_time += f.utc_ns != 0;
    if (std::isfinite(f.heading_deg)) {
      EXPECT_NEAR(f.heading_deg, truth[static_cast<std::size_t>(e)].track, 0.01);
      ++with_heading;
    }
  }
  EXPECT_GE(epochs.size(), 15u) << "positions of only " << epochs.size() << " of 27 epochs were read";
  // Only gpsd's first reports, before it saw an RMC, lack the time and the heading.
  EXPECT_GE(with_heading, matched - 2) << "the heading (RMC's track) is not carried through the epoch";
  EXPECT_GE(with_time, matched - 2);
  // gpsd went away, which is counted, and the last fix ages out.
  EXPECT_EQ(stats.disconnects, 1u);
  EXPECT_FALSE(stats.connected);
  const GeoFix later = source.position_at(monotonic_now_ns() + 2'000'000'000);
  EXPECT_EQ(later.mode, GeoFix::Mode::NoFix);
}

using test::tpv;
using test::write_lines;

TEST_F(GpsdSourceTest, MalformedReportsTimeJumpsAndDisconnectsAreCountedAndSurvived) {
  const int port = test::free_loopback_port();
  write_lines(dir_ / "s1", {tpv("2026-11-25T12:00:00.000Z", -25.1, 28.1), R"({"class":"TPV","mode":3,"lat":-25.)",
                            "GPS receiver says hello", tpv("2026-11-25T12:00:00.200Z", -25.2, 28.2),
                            tpv("2026-11-25T13:00:00.400Z", -25.3, 28.3)});
  write_lines(dir_ / "s2",
              {tpv("2026-11-25T13:00:01.000Z", -25.4, 28.4), tpv("2026-11-25T13:00:01.200Z", -25.5, 28.5)});
  test::ProcessGroup fake({"/usr/bin/python3", test::kGpsTestDir + "/fake_gpsd.py", "--port", std::to_string(port),
                           "--gap", "0.05", (dir_ / "s1").string(), (dir_ / "s2").string()},
                          dir_ / "fake.log");
  ASSERT_TRUE(fake.started());
  ASSERT_TRUE(test::wait_for_port(port, 10s)) << test::read_text(dir_ / "fake.log");
  GpsdSource source(config_for(port));
  GeoFix last;
  const auto end = std::chrono::steady_clock::now() + 10s;
  while (std::chrono::steady_clock::now() < end) {
    last = source.position_at(monotonic_now_ns());
    if (last.valid() && std::abs(last.latitude_deg - -25.5) < 1e-9) break;
    std::this_thread::sleep_for(10ms);
  }
  const GpsStats s = source.stats();
  EXPECT_NEAR(last.latitude_deg, -25.5, 1e-9) << "positions did not come back after the reconnection";
  EXPECT_NEAR(last.longitude_deg, 28.5, 1e-9);
  EXPECT_EQ(s.malformed, 2u);
  EXPECT_EQ(s.time_jumps, 1u);  // 12:00:00.2 to 13:00:00.4 in 50 ms; the reconnection's next fix is no jump
  EXPECT_EQ(s.disconnects, 1u);
  EXPECT_GE(s.connects, 2u);
  EXPECT_EQ(s.fixes, 5u);
  EXPECT_TRUE(s.connected);
}

TEST_F(GpsdSourceTest, NoGpsdMeansNoPositionAndBoundedRetries) {
  const int port = test::free_loopback_port();  // nobody listens
  GpsConfig c = config_for(port);
  GpsdSource source(c);
  std::this_thread::sleep_for(600ms);
  EXPECT_EQ(source.position_at(monotonic_now_ns()).mode, GeoFix::Mode::NoFix);
  const GpsStats s = source.stats();
  // 50, 100, 200, 200 ... ms: at least 3 attempts in 600 ms, and never more than one per 50 ms.
  EXPECT_GE(s.connect_failures, 3u);
  EXPECT_LE(s.connect_failures, 12u);
  EXPECT_EQ(s.connects, 0u);
  EXPECT_FALSE(s.connected);
  const auto t0 = std::chrono::steady_clock::now();
  source.stop();
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 2s) << "stop waits for the whole reconnect delay";
}

}  // namespace
}  // namespace rutd
