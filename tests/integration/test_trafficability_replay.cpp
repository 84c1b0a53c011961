// Trafficability end to end through the rutd program: `rutd synth --speed-profile` writes a recording with
// the vehicle's CAN speed frames (vehicle.log: stop, reversing, acceleration), hostile frames are mixed in
// and the speed is cut for a while, `rutd replay --segments` measures it, and the segment CSV must equal
// an independent computation (tests/integration/segments_from_recording.py: canmatrix decodes vehicle.log
// with its own J1939 database, tests/unit/trafficability_reference.py does the rest from the per-frame
// CSV). The candump log of the replay carries RutMotion with every measurement: canmatrix decodes it with
// config/rutd.dbc, and its speed state and track distance must equal the reference's motion per frame
// (speed unknown exactly where the reference has none). A second replay gives the same file byte for byte.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "decoded_candump.hpp"
#include "test_support.hpp"

namespace rutd {
namespace {

namespace fs = std::filesystem;
using test::quoted;
using test::read_text;
using test::run_rutd;
using test::run_shell;
constexpr const char* kPython = "/usr/bin/python3";

std::vector<std::map<std::string, std::string>> read_rows(const fs::path& p) {
  std::ifstream in(p);
  std::string line;
  std::getline(in, line);
  std::vector<std::string> header;
  {
    std::stringstream ss(line);
    for (std::string h; std::getline(ss, h, ',');) header.push_back(h);
  }
  std::vector<std::map<std::string, std::string>> rows;
  while (std::getline(in, line)) {
    std::map<std::string, std::string> row;
    std::stringstream ss(line);
    std::string cell;
    for (std::size_t i = 0; i < header.size(); ++i) {
      if (!std::getline(ss, cell, ',')) cell.clear();
      row[header[i]] = cell;
    }
    rows.push_back(row);
  }
  return rows;
}

double num(const std::string& s) { return s.empty() || s == "nan" ? std::nan("") : std::stod(s); }

void expect_close(const std::string& got, const std::string& want, double tolerance, const std::string& what) {
  const double g = num(got), w = num(want);
  if (std::isnan(w)) {
    EXPECT_TRUE(std::isnan(g)) << what << ": want none, got " << got;
  } else {
    EXPECT_NEAR(g, w, tolerance) << what;
  }
}

TEST(TrafficabilityReplay, SegmentsEqualAnIndependentComputationAndReplayIsExact) {
  if (run_shell(std::string(kPython) + " -c 'import canmatrix.formats' >/dev/null 2>&1") != 0)
    RUTD_SKIP_NEEDS_INSTALLED("canmatrix for /usr/bin/python3 (Debian package python3-canmatrix)");
  test::TempDir tmp;
  const fs::path rec = tmp.path() / "rec";
  // 5 s at 30 fps: 3 m/s, a stop, 1 m/s backwards, forwards again; the rut deepens from 40 to 80 mm.
  ASSERT_EQ(run_rutd("synth " + quoted(rec) +
                     " --frames 150 --size 320x240 --depth-profile 0:40,40:40,70:80,149:80"
                     " --speed-profile 0:10.8,1.2:10.8,1.6:0,2:0,2.3:-3.6,2.8:-3.6,3.1:0,3.4:10.8,5:10.8"),
            0);
  // Hostile traffic: a spoofed sender (address 0x17) claiming 200 km/h, frames too short, "not available"
  // values; and no speed at all from 3.9 s to 4.5 s (longer than max_age_ms: speed stale).
  {
    std::ifstream in(rec / "vehicle.log");
    std::stringstream kept;
    int i = 0;
    for (std::string line; std::getline(in, line); ++i) {
      const double t = std::stod(line.substr(1, 17));
      if (t >= 3.9 && t < 4.5) continue;
      const std::string stamp = line.substr(0, line.find(')') + 1);
      const bool speed = line.find("18FEF100#") != std::string::npos;
      // A "not available" value in place of one speed frame, and a copy of a frame 1 ms later (a burst).
      kept << (speed && i == 40 ? stamp + " can0 18FEF100#FFFFFFFFFFFFFFFF" : line) << '\n';
      if (i % 7 == 3) kept << stamp << " can0 18FEF117#FF00C8FFFFFFFFFF\n";
      if (i % 11 == 5) kept << stamp << " can0 18FEF100#FF00\n";
      if (speed && i % 17 == 8) {
        char later[32];
        std::snprintf(later, sizeof later, "(%017.6f)", t + 0.001);
        kept << later << line.substr(line.find(')') + 1) << '\n';
      }
    }
    std::ofstream(rec / "vehicle.log") << kept.str();
  }
  const fs::path config = tmp.path() / "rutd.yaml";
  std::ofstream(config) << read_text(fs::path(RUTD_SOURCE_DIR) / "config/rutd.yaml");
  {
    std::string text = read_text(config);
    auto set = [&](const std::string& from, const std::string& to) {
      const auto at = text.find(from);
      ASSERT_NE(at, std::string::npos) << from;
      text.replace(at, from.size(), to);
    };
    set("direction_from_gear: false", "direction_from_gear: true");
    set("source_address: any", "source_address: 0x00");
    set("caution_depth_mm: 80 ", "caution_depth_mm: 50 ");
    set("no_go_depth_mm: 150", "no_go_depth_mm: 70");
    set("hysteresis_m: 3 ", "hysteresis_m: 2 ");
    // The first damage rule within reach of the drive's 80 mm, so that its share is not 0.
    set("depth_mm: 100, min_length_m: 1}", "depth_mm: 60, min_length_m: 0.3}");
    std::ofstream(config) << text;
  }
  const fs::path log = tmp.path() / "replay.log";
  ASSERT_EQ(run_rutd("replay " + quoted(rec) + " --out " + quoted(tmp.path() / "m.csv") + " --segments " +
                         quoted(tmp.path() / "seg.csv") + " --config " + quoted(config) + " --candump " +
                         quoted(tmp.path() / "can.log"),
                     log.string()),
            0)
      << read_text(log);
  const std::string replay_log = read_text(log);
  ASSERT_EQ(run_shell(std::string(kPython) + " " RUTD_SOURCE_DIR "/tests/integration/segments_from_recording.py " +
                      quoted(rec) + " " + quoted(tmp.path() / "m.csv") + " " + quoted(tmp.path()) + " gear"),
            0);
  // The reference's configuration: the file's values above.
  std::ofstream(tmp.path() / "config.csv") << "length_m,1\nmax_age_ns,500000000\ncaution_depth_mm,50\n"
                                              "no_go_depth_mm,70\nhysteresis_m,2\nmax_untrusted_fraction,0.5\n"
                                              "min_trusted_frames,3\ncoverage_factor,2\nsoil_table,0:1 1:0\n"
                                              "limit_one_pass,0\nlimit_fifty_passes,0\ndamage,60:0.3 200:1 200:4\n";
  ASSERT_EQ(run_shell(std::string(kPython) + " " RUTD_SOURCE_DIR "/tests/unit/trafficability_reference.py " +
                      quoted(tmp.path())),
            0);
  const auto got = read_rows(tmp.path() / "seg.csv");
  const auto want = read_rows(tmp.path() / "segments_ref.csv");
  ASSERT_EQ(got.size(), want.size());
  ASSERT_GE(got.size(), 6u);
  const char* advisories[] = {"UNKNOWN", "GO", "CAUTION", "NO_GO"};
  std::map<std::string, int> seen;
  for (std::size_t i = 0; i < got.size(); ++i) {
    const auto& g = got[i];
    const auto& w = want[i];
    const std::string at = "segment " + std::to_string(i);
    EXPECT_EQ(g.at("index"), w.at("index")) << at;
    EXPECT_EQ(g.at("frames"), w.at("frames")) << at;
    EXPECT_EQ(g.at("refused"), w.at("refused")) << at;
    expect_close(g.at("start_m"), w.at("start_m"), 1e-3, at + " start_m");
    // The CSV keeps 2 decimals; the per-frame CSV the reference reads keeps 3.
    expect_close(g.at("mean_depth_mm"), w.at("mean"), 0.006, at + " mean");
    expect_close(g.at("max_depth_mm"), w.at("max"), 0.006, at + " max");
    expect_close(g.at("p95_depth_mm"), w.at("p95"), 0.006, at + " p95");
    expect_close(g.at("mean_width_mm"), w.at("width"), 0.006, at + " width");
    EXPECT_EQ(g.at("advisory"), advisories[std::stoi(w.at("advisory"))]) << at;
    ++seen[g.at("advisory")];
  }
  // The drive shows every advisory: GO on the shallow rut, CAUTION and NO_GO as it deepens, UNKNOWN where
  // the speed stopped.
  EXPECT_GT(seen["GO"], 0);
  EXPECT_GT(seen["CAUTION"], 0);
  EXPECT_GT(seen["NO_GO"], 0);
  EXPECT_GT(seen["UNKNOWN"], 0);
  // The damage shares beside the segments, as the reference counts them from the per-frame CSV.
  const auto damage = read_rows(tmp.path() / "seg.damage.csv");
  const auto damage_want = read_rows(tmp.path() / "damage_ref.csv");
  ASSERT_EQ(damage.size(), 3u);
  ASSERT_EQ(damage_want.size(), 3u);
  for (std::size_t i = 0; i < damage.size(); ++i) {
    const std::string at = "damage rule " + std::to_string(i);
    expect_close(damage[i].at("measured_m"), damage_want[i].at("measured_m"), 2e-3, at + " measured");
    expect_close(damage[i].at("unmeasured_m"), damage_want[i].at("unmeasured_m"), 2e-3, at + " unmeasured");
    expect_close(damage[i].at("rutted_m"), damage_want[i].at("rutted_m"), 2e-3, at + " rutted");
    EXPECT_EQ(damage[i].at("stretches"), damage_want[i].at("stretches")) << at;
  }
  EXPECT_EQ(damage[0].at("rule"), "\"mineral soil (Finland)\"");
  EXPECT_GT(num(damage[0].at("rutted_m")), 0.3) << "the drive's 80 mm stretch";
  EXPECT_GT(num(damage[0].at("share")), 0.0);
  // Per measurement on CAN: RutMotion, after its RutConditions, says whether the speed was known and where
  // on the track the measurement lies, as the reference computes it.
  bool decoded_ok = false;
  const auto can = test::decode_candump(tmp.path() / "can.log", decoded_ok);
  EXPECT_TRUE(decoded_ok) << "the decoder reported a problem (CRC, counter, unknown frame)";
  const auto motion = test::frames_of(can, "RutMotion");
  const auto motion_want = read_rows(tmp.path() / "motion_ref.csv");
  ASSERT_EQ(motion.size(), motion_want.size()) << "one RutMotion frame per measurement";
  ASSERT_EQ(test::frames_of(can, "RutMeasurement1").size(), motion.size());
  std::size_t unknown = 0, known = 0;
  for (std::size_t i = 0; i < motion.size(); ++i) {
    const auto& f = motion[i];
    const std::string at = "measurement " + std::to_string(i);
    EXPECT_EQ(f.t_ns, std::stoll(motion_want[i].at("t_ns")) / 1000 * 1000) << at;
    EXPECT_EQ(f.named.at("PositionFix"), "NO_SOURCE") << at;
    if (motion_want[i].at("distance_m").empty()) {
      ++unknown;
      EXPECT_NE(f.named.at("SpeedState"), "OK") << at;
      EXPECT_TRUE(f.na.at("VehicleSpeed")) << at;
      EXPECT_TRUE(f.na.at("TrackDistance")) << at;
    } else {
      ++known;
      EXPECT_EQ(f.named.at("SpeedState"), "OK") << at;
      EXPECT_FALSE(f.na.at("VehicleSpeed")) << at;
      EXPECT_NEAR(f.phys.at("TrackDistance"), num(motion_want[i].at("distance_m")), 0.006) << at;
    }
  }
  EXPECT_GT(known, 100u);
  EXPECT_GE(unknown, 3u) << "the silence from 3.9 s to 4.5 s: stale from 4.4 s (max_age_ms 500)";
  // The hostile frames were counted, not used.
  EXPECT_NE(replay_log.find("trafficability:"), std::string::npos) << replay_log;

  // Replay is exact: the same recording gives the same segment file.
  ASSERT_EQ(run_rutd("replay " + quoted(rec) + " --out /dev/null --segments " + quoted(tmp.path() / "seg2.csv") +
                         " --config " + quoted(config),
                     (tmp.path() / "replay2.log").string()),
            0);
  EXPECT_EQ(read_text(tmp.path() / "seg.csv"), read_text(tmp.path() / "seg2.csv"));
}

}  // namespace
}  // namespace rutd
