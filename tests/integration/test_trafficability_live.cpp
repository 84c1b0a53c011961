// The live path of trafficability: `rutd run` receives the vehicle's speed (J1939 CCVS frames encoded by
// canmatrix from its own J1939 database, tests/integration/encode_speed_profile.py, sent at the log's
// pace into the receiver's socket by rutd_faults --speed-from: the daemon's code, without CAN kernel
// support; tests/can runs it on a real kernel's vcan), records the pairs and vehicle.log, and writes the
// segment CSV. `rutd replay` of that recording must give the same segments (the last, closed when the run
// stopped, may differ by the pairs recorded after the last one published); a stop adds no frames; a
// silent sender makes the segment UNKNOWN.
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "test_support.hpp"

namespace rutd {
namespace {

namespace fs = std::filesystem;
using test::quoted;
using test::read_text;
using test::run_shell;
constexpr const char* kPython = "/usr/bin/python3";

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

TEST(TrafficabilityLive, RunMeasuresOnDistanceAndReplayGivesTheSameSegments) {
  if (run_shell(std::string(kPython) + " -c 'import canmatrix.formats' >/dev/null 2>&1") != 0)
    RUTD_SKIP_NEEDS_INSTALLED("canmatrix for /usr/bin/python3 (Debian package python3-canmatrix)");
  test::TempDir tmp;
  // 50 Hz: 7.2 km/h (2 m/s) for 1 s, a stop of 0.6 s, 10.8 km/h (3 m/s); silent from 2.6 s to 3.4 s.
  ASSERT_EQ(run_shell(std::string(kPython) + " " RUTD_SOURCE_DIR "/tests/integration/encode_speed_profile.py " +
                      quoted(tmp.path() / "vehicle_in.log") +
                      " 50 6 0:7.2,0.9:7.2,1.0:0,1.6:0,1.7:10.8,6:10.8 2.6:3.4 2>/dev/null"),
            0);
  const fs::path rec = tmp.path() / "rec", log = tmp.path() / "run.log";
  const std::string run = "exec " + quoted(RUTD_FAULTS_BINARY) + " --speed-from " +
                          quoted(tmp.path() / "vehicle_in.log") +
                          " run --frames 120 --size 320x240 --candump '' --speed-socketcan vcan0 --record " +
                          quoted(rec) + " --segments " + quoted(tmp.path() / "live.csv") + " 2>" + quoted(log);
  ASSERT_EQ(run_shell(run), 0) << read_text(log);
  const std::string run_log = read_text(log);
  EXPECT_NE(run_log.find("recording " + rec.string() + ": "), std::string::npos);
  ASSERT_NE(run_log.find(", 0 dropped (writer behind)"), std::string::npos)
      << "the recording dropped pairs: replay cannot match\n"
      << run_log;
  ASSERT_TRUE(fs::exists(rec / "vehicle.log"));
  ASSERT_EQ(test::run_rutd("replay " + quoted(rec) + " --out /dev/null --segments " + quoted(tmp.path() / "replay.csv"),
                           (tmp.path() / "replay.log").string()),
            0)
      << read_text(tmp.path() / "replay.log");
  const auto live = lines(read_text(tmp.path() / "live.csv"));
  const auto replay = lines(read_text(tmp.path() / "replay.csv"));
  ASSERT_GE(live.size(), 5u) << run_log;  // header and at least 4 segments
  ASSERT_EQ(live.size(), replay.size());
  for (std::size_t i = 0; i + 1 < live.size(); ++i) EXPECT_EQ(live[i], replay[i]) << "row " << i;
  // The stop: frames at rest were not placed; the silence: speed stale, its segment UNKNOWN.
  const auto at_rest = run_log.find(" at rest or reversing");
  ASSERT_NE(at_rest, std::string::npos) << run_log;
  const std::string counts = run_log.substr(0, at_rest);
  EXPECT_NE(counts.substr(counts.rfind(' ') + 1), "0") << "no frame at rest during the stop";
  EXPECT_NE(read_text(tmp.path() / "live.csv").find(",UNKNOWN"), std::string::npos);
  EXPECT_EQ(run_log.find(" 0 without speed"), std::string::npos) << "the silence left every frame a speed";
}

}  // namespace
}  // namespace rutd
