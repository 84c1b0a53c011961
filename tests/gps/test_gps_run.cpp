// Positions end to end through the `rutd` program: `rutd run` with gps enabled, a real gpsd on loopback
// fed by gpsfake from a generated drive, writes the measurement CSV with each pair's position (every one
// equal to a position of the NMEA log within its resolution, in the log's order) and records gpsd's
// reports as gps.jsonl beside the pairs; `rutd replay --positions` of that recording joins exactly the
// same positions to the same pairs. Without gpsd, rutd measures every pair all the same, with no position,
// and says so in every periodic summary. On CAN, every measurement's RutMotion frame carries the same fix
// mode as its CSV row (decoded by canmatrix with config/rutd.dbc).
#include <algorithm>
#include <map>
#include <set>

#include <gtest/gtest.h>

#include "decoded_candump.hpp"
#include "gps_test_support.hpp"
#include "recording/measurement_csv.hpp"

namespace rutd {
namespace {

using namespace std::chrono_literals;
using test::fs::path;

bool same(double a, double b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

// The RutMotion frames of a candump log must say, in order, what the CSV rows' fix modes say, with no
// speed source. Returns how many were compared.
std::size_t expect_motion_fixes_match(const path& candump, const MeasurementCsv& csv) {
  bool ok = false;
  const auto motion = test::frames_of(test::decode_candump(candump, ok), "RutMotion");
  EXPECT_TRUE(ok) << "the decoder reported a CRC, counter or unknown frame";
  EXPECT_EQ(motion.size(), csv.rows.size());
  std::size_t compared = 0;
  for (std::size_t i = 0; i < std::min(motion.size(), csv.rows.size()); ++i, ++compared) {
    const GeoFix::Mode mode = csv.rows[i].position.mode;
    const char* want = mode == GeoFix::Mode::Fix3d ? "FIX_3D" : mode == GeoFix::Mode::Fix2d ? "FIX_2D" : "NO_FIX";
    EXPECT_EQ(motion[i].named.at("PositionFix"), want) << "seq " << csv.rows[i].seq;
    EXPECT_EQ(motion[i].named.at("SpeedState"), "NO_SOURCE") << "seq " << csv.rows[i].seq;
  }
  return compared;
}

class GpsRunTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::fs::temp_directory_path() / ("rutd_gps_run_" + std::to_string(::getpid()) + "_" +
                                              ::testing::UnitTest::GetInstance()->current_test_info()->name());
    test::fs::remove_all(dir_);
    test::fs::create_directories(dir_);
  }
  void TearDown() override { test::fs::remove_all(dir_); }

  path write_config(int port) {
    const path config = dir_ / "rutd.yaml";
    std::ofstream(config) << "source:\n  synthetic:\n    size: 320x240\n    fps: 15\n    cycle_frames: 8\n"
                          << "sinks:\n  candump: \"\"\n  csv_positions: true\n"
                          << "gps:\n  enabled: true\n  port: \"" << port << "\"\n  reconnect_min_ms: 50\n"
                          << "logging:\n  stats_period_s: 0.2\n";
    return config;
  }
  path dir_;
};

TEST_F(GpsRunTest, RunJoinsGpsdPositionsAndReplayReproducesThem) {
  if (!test::gpsfake_installed()) RUTD_SKIP_NEEDS_INSTALLED("gpsd and gpsfake (Debian gpsd, gpsd-clients)");
  test::write_drive(dir_, "--epochs 60 --no-fix-epochs 2 --period 0.2");
  const auto truth = test::read_truth(dir_ / "drive_truth.csv");
  const int port = test::free_loopback_port();
  test::ProcessGroup gpsfake(
      {"gpsfake", "-q", "-n", "-1", "-c", "0.1", "-P", std::to_string(port), (dir_ / "drive.nmea").string()},
      dir_ / "gpsfake.log");
  ASSERT_TRUE(test::wait_for_port(port, 10s)) << test::read_text(dir_ / "gpsfake.log");
  const path config = write_config(port);
  ASSERT_EQ(
      test::run_rutd("run --config " + test::quoted(config) + " --frames 45 --csv " + test::quoted(dir_ / "run.csv") +
                         " --record " + test::quoted(dir_ / "rec") + " --candump " + test::quoted(dir_ / "can.log"),
                     (dir_ / "run.log").string()),
      0)
      << test::read_text(dir_ / "run.log");
  gpsfake.stop();
  const MeasurementCsv run = read_measurement_csv((dir_ / "run.csv").string());
  ASSERT_TRUE(run.has_positions);
  ASSERT_GE(run.rows.size(), 45u);
  int with_position = 0, last_epoch = -1;
  for (const MeasurementRow& r : run.rows) {
    EXPECT_NE(r.position.mode, GeoFix::Mode::None) << "seq " << r.seq << ": gps is configured";
    if (!r.position.valid()) continue;
    ++with_position;
    const int e = test::matching_epoch(truth, r.position.latitude_deg, r.position.longitude_deg);
    ASSERT_GE(e, 0) << "seq " << r.seq << ": a position not in the log";
    EXPECT_GE(e, last_epoch) << "seq " << r.seq << ": positions out of the log's order";
    last_epoch = e;
    EXPECT_NEAR(r.position.altitude_m, 1340.0, 1e-3);
  }
  // gpsfake starts its log as rutd starts; the pairs before the first fix have none.
  EXPECT_GE(with_position, 20) << test::read_text(dir_ / "run.log");
  EXPECT_GE(expect_motion_fixes_match(dir_ / "can.log", run), 45u);

  // The recording holds gpsd's reports, and replaying it joins the same positions to the same pairs.
  const std::string jsonl = test::read_text(dir_ / "rec" / "gps.jsonl");
  EXPECT_NE(jsonl.find(R"(,"report":{"class":"TPV")"), std::string::npos);
  ASSERT_EQ(
      test::run_rutd("replay " + test::quoted(dir_ / "rec") + " --positions --out " + test::quoted(dir_ / "replay.csv"),
                     (dir_ / "replay.log").string()),
      0)
      << test::read_text(dir_ / "replay.log");
  const MeasurementCsv replay = read_measurement_csv((dir_ / "replay.csv").string());
  ASSERT_TRUE(replay.has_positions);
  std::map<std::uint64_t, GeoFix> live;
  for (const MeasurementRow& r : run.rows) live[r.seq] = r.position;
  std::size_t compared = 0, valid = 0;
  for (const MeasurementRow& r : replay.rows) {
    const auto it = live.find(r.seq);
    if (it == live.end()) continue;  // recorded but not published live (dropped in the pipeline)
    ++compared;
    EXPECT_EQ(r.position.mode, it->second.mode) << "seq " << r.seq;
    if (!r.position.valid() || !it->second.valid()) continue;
    ++valid;
    EXPECT_EQ(r.position.latitude_deg, it->second.latitude_deg) << "seq " << r.seq;
    EXPECT_EQ(r.position.longitude_deg, it->second.longitude_deg) << "seq " << r.seq;
    EXPECT_TRUE(same(r.position.heading_deg, it->second.heading_deg)) << "seq " << r.seq;
  }
  EXPECT_GE(compared, 40u);
  EXPECT_GE(valid, 15u);
}

// A gpsd that misbehaves mid-run (fake_gpsd.py): a malformed report, a line that is not JSON, a fix an
// hour after the previous one 100 ms later (a time jump), then the connection dropped and served again.
// Every pair is measured as without gpsd (all OK), the faults are counted in the run's
// summary, and positions come back after the reconnection.
TEST_F(GpsRunTest, AMisbehavingGpsdLeavesEveryMeasurementAlone) {
  const int port = test::free_loopback_port();
  test::write_lines(dir_ / "s1",
                    {test::tpv("2026-11-25T12:00:00.000Z", -25.1, 28.1), R"({"class":"TPV","mode":3,"lat":-25.)",
                     "GPS receiver says hello", test::tpv("2026-11-25T12:00:00.200Z", -25.2, 28.2),
                     test::tpv("2026-11-25T13:00:00.400Z", -25.3, 28.3)});
  std::vector<std::string> second;
  for (int i = 0; i < 40; ++i) {
    char time[40];
    std::snprintf(time, sizeof time, "2026-11-25T13:00:%02d.%03dZ", 1 + i / 5, (i % 5) * 200);
    second.push_back(test::tpv(time, -25.4 - 1e-5 * i, 28.4));
  }
  test::write_lines(dir_ / "s2", second);
  test::ProcessGroup fake({"/usr/bin/python3", test::kGpsTestDir + "/fake_gpsd.py", "--port", std::to_string(port),
                           "--gap", "0.1", (dir_ / "s1").string(), (dir_ / "s2").string()},
                          dir_ / "fake.log");
  ASSERT_TRUE(fake.started());
  ASSERT_TRUE(test::wait_for_port(port, 10s)) << test::read_text(dir_ / "fake.log");
  const path config = write_config(port);
  ASSERT_EQ(
      test::run_rutd("run --config " + test::quoted(config) + " --frames 45 --csv " + test::quoted(dir_ / "run.csv"),
                     (dir_ / "run.log").string()),
      0)
      << test::read_text(dir_ / "run.log");
  fake.stop();
  const MeasurementCsv run = read_measurement_csv((dir_ / "run.csv").string());
  ASSERT_GE(run.rows.size(), 40u);  // the freshest pair wins: a loaded machine may drop a few
  std::size_t with_position = 0;
  for (const MeasurementRow& r : run.rows) {
    EXPECT_EQ(r.measurement.status, RutStatus::Ok) << "seq " << r.seq;
    with_position += r.position.valid();
  }
  EXPECT_GE(with_position, 5u) << "positions did not come back after the reconnection";
  const std::string log = test::read_text(dir_ / "run.log");
  EXPECT_NE(log.find("without a fix, 2 malformed"), std::string::npos) << log;
  EXPECT_NE(log.find("connections, 1 lost"), std::string::npos) << log;
  EXPECT_NE(log.find("failed attempts, 1 time jumps"), std::string::npos) << log;
}

TEST_F(GpsRunTest, WithoutGpsdEveryPairIsMeasuredWithoutPosition) {
  const path config = write_config(test::free_loopback_port());  // nobody listens there
  ASSERT_EQ(test::run_rutd("run --config " + test::quoted(config) + " --frames 10 --csv " +
                               test::quoted(dir_ / "run.csv") + " --candump " + test::quoted(dir_ / "can.log"),
                           (dir_ / "run.log").string()),
            0)
      << test::read_text(dir_ / "run.log");
  const MeasurementCsv run = read_measurement_csv((dir_ / "run.csv").string());
  ASSERT_GE(run.rows.size(), 10u);
  for (const MeasurementRow& r : run.rows) {
    EXPECT_EQ(r.position.mode, GeoFix::Mode::NoFix) << "seq " << r.seq;
    EXPECT_EQ(r.measurement.status, RutStatus::Ok) << "seq " << r.seq;
  }
  EXPECT_GE(expect_motion_fixes_match(dir_ / "can.log", run), 10u);
  const std::string log = test::read_text(dir_ / "run.log");
  EXPECT_NE(log.find("no gpsd at 127.0.0.1"), std::string::npos) << log;
  EXPECT_NE(log.find("0 pairs with a position"), std::string::npos) << log;
  // The condition, with every periodic summary while it lasts.
  EXPECT_NE(log.find("gps: gpsd not connected, 0 pairs with a position"), std::string::npos) << log;
}

}  // namespace
}  // namespace rutd
