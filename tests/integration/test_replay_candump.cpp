// The CAN output of a real measurement run, decoded by an independent decoder: `rutd replay` of a
// synthetic recording writes the measurement CSV and the candump log; canmatrix decodes the log with
// config/rutd.dbc (tests/can/decode_candump.py, which also checks every CRC and counter). Every decoded
// value must equal the CSV within the signal's resolution, and the depth the renderer's truth within the
// measurement tolerance. The status frames are those the vehicle would have sent during the recording:
// every 100 ms of the recording's clock, saying NoCamera and NO_MEASUREMENT through a gap in it.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "decoded_candump.hpp"
#include "recording/measurement_csv.hpp"
#include "synthetic/truth_csv.hpp"
#include "test_support.hpp"

namespace rutd {
namespace {

// message -> signal -> physical values in log order.
using Decoded = std::map<std::string, std::map<std::string, std::vector<double>>>;

Decoded read_decoded(const std::string& path) {
  Decoded d;
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);  // header: index,t_ns,message,signal,raw,phys,named,na
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::stringstream ss(line);
    for (std::string x; std::getline(ss, x, ',');) f.push_back(x);
    if (f.size() < 8 || f[7] == "1") continue;  // not available
    d[f[2]][f[3]].push_back(std::stod(f[5]));
  }
  return d;
}

TEST(ReplayCandump, DecodedFramesEqualTheCsvAndTheTruth) {
  if (std::system("/usr/bin/python3 -c 'import canmatrix' >/dev/null 2>&1") != 0)
    RUTD_SKIP_NEEDS_INSTALLED("needs /usr/bin/python3 with canmatrix (Debian package python3-canmatrix)");
  const test::TempDir tmp;
  const std::string rec = (tmp.path() / "rec").string(), csv = (tmp.path() / "m.csv").string(),
                    log = (tmp.path() / "can.log").string(), decoded = (tmp.path() / "decoded.csv").string();
  ASSERT_EQ(test::run_rutd("synth " + rec + " --frames 4 --depth 45 --roll 2 --seed 5"), 0);
  ASSERT_EQ(test::run_rutd("replay " + rec + " --out " + csv + " --candump " + log), 0);
  const std::string cmd = std::string("/usr/bin/python3 ") + RUTD_SOURCE_DIR + "/tests/can/decode_candump.py " +
                          RUTD_SOURCE_DIR + "/config/rutd.dbc " + log + " > " + decoded;
  ASSERT_EQ(std::system(cmd.c_str()), 0) << "decoder reported CRC, counter or format errors";

  const auto rows = read_measurement_csv(csv).rows;
  const auto truth = read_truth_csv(rec + "/truth.csv");
  const Decoded d = read_decoded(decoded);
  const auto& m1 = d.at("RutMeasurement1");
  const auto& m2 = d.at("RutMeasurement2");
  ASSERT_EQ(rows.size(), 4u);
  ASSERT_EQ(m1.at("RutDepth").size(), rows.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const RutMeasurement& m = rows[i].measurement;
    ASSERT_EQ(m.status, RutStatus::Ok);
    // Half a step of each signal's resolution, plus the CSV's own rounding (0.001).
    EXPECT_NEAR(m1.at("RutDepth")[i], m.depth_mm, 0.05 + 0.001) << i;
    EXPECT_NEAR(m1.at("RutWidth")[i], m.width_mm, 0.125 + 0.001) << i;
    EXPECT_NEAR(m1.at("RutArea")[i], m.area_mm2, 5.0 + 0.001) << i;
    EXPECT_NEAR(m1.at("RutQuality")[i], 100.0 * m.quality, 0.2 + 0.01) << i;
    EXPECT_NEAR(m2.at("RutLeftPile")[i], m.left_pile_mm, 0.05 + 0.001) << i;
    EXPECT_NEAR(m2.at("RutRightPile")[i], m.right_pile_mm, 0.05 + 0.001) << i;
    EXPECT_NEAR(m2.at("GroundSlope")[i], m.ground_slope_deg, 0.01 + 0.001) << i;
    EXPECT_NEAR(m2.at("RutCenterX")[i], m.center_x_mm, 0.25 + 0.001) << i;
    EXPECT_NEAR(m1.at("RutDepth")[i], truth[i].depth_mm, 1.0 + 0.05) << i;
    std::printf("frame %zu: CAN depth %.1f mm, CSV %.3f mm, truth %.3f mm\n", i, m1.at("RutDepth")[i], m.depth_mm,
                truth[i].depth_mm);
  }
}

// The pairs' times in frames.csv (t_ns, the second field), in order.
std::vector<std::int64_t> pair_times(const std::string& rec) {
  std::vector<std::int64_t> t;
  std::ifstream in(rec + "/frames.csv");
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) t.push_back(std::stoll(line.substr(line.find(',') + 1)));
  return t;
}

constexpr std::int64_t kPeriodNs = 100'000'000;  // the status period of `rutd run`'s default

// 40 pairs at 30 fps (1.3 s): a status frame every 100 ms of the recording from its first pair, and one
// after the last pair; healthy, the last measurement's status, the recording's frame rate once a second
// of it has passed; every frame on the recording's clock.
TEST(ReplayCandump, StatusFramesEveryPeriodOfTheRecordingClock) {
  if (!test::have_canmatrix()) RUTD_SKIP_NEEDS_INSTALLED("needs /usr/bin/python3 with canmatrix (python3-canmatrix)");
  const test::TempDir tmp;
  const std::string rec = (tmp.path() / "rec").string(), log = (tmp.path() / "can.log").string();
  ASSERT_EQ(test::run_rutd("synth " + rec + " --frames 40 --size 320x240 --seed 8"), 0);
  ASSERT_EQ(test::run_rutd("replay " + rec + " --out " + (tmp.path() / "m.csv").string() + " --candump " + log), 0);
  bool ok = false;
  const auto all = test::decode_candump(log, ok);
  ASSERT_TRUE(ok) << "decoder reported CRC, counter or format errors";
  const std::vector<std::int64_t> t = pair_times(rec);
  ASSERT_EQ(t.size(), 40u);
  const auto m1 = test::frames_of(all, "RutMeasurement1");
  ASSERT_EQ(m1.size(), t.size());
  for (std::size_t i = 0; i < t.size(); ++i) EXPECT_EQ(m1[i].t_ns, t[i] / 1000 * 1000) << "pair " << i;
  const auto status = test::frames_of(all, "RutSensorStatus");
  // Periodic statuses at t0 + k * 100 ms before the last pair, then the last one at its time.
  const std::int64_t periodic = (t.back() - t.front() - 1) / kPeriodNs;
  ASSERT_EQ(static_cast<std::int64_t>(status.size()), periodic + 1);
  for (std::size_t k = 0; k < status.size(); ++k) {
    const std::int64_t want = k + 1 < status.size() ? t.front() + (k + 1) * kPeriodNs : t.back();
    EXPECT_EQ(status[k].t_ns, want / 1000 * 1000) << "status " << k;
    EXPECT_EQ(status[k].named.at("RutS_LastStatus"), "OK") << "status " << k;
    EXPECT_EQ(status[k].phys.at("NoCamera"), 0) << "status " << k;
    EXPECT_EQ(status[k].phys.at("CalibrationInvalid"), 0) << "status " << k;
    EXPECT_EQ(status[k].phys.at("FrameDrops"), 0) << "status " << k;
    const double seconds = (status[k].t_ns - t.front()) * 1e-9;
    if (seconds >= 1.0) EXPECT_NEAR(status[k].phys.at("FrameRate"), 30.0, 0.5) << "status " << k;
    else EXPECT_EQ(status[k].phys.at("FrameRate"), 0) << "status " << k << ": no full second yet";
  }
  std::printf("%zu pairs over %.2f s, %zu status frames\n", t.size(), (t.back() - t.front()) * 1e-9, status.size());
}

// A recording with a 2.5 s gap (the cameras lost on the drive): the status frames in the gap raise
// NoCamera once no pair came for 1 s, and say NO_MEASUREMENT as the latest status, as `rutd run` does;
// both clear with the first pair after the gap.
TEST(ReplayCandump, GapInTheRecordingIsReportedAsTheVehicleWouldHaveSeenIt) {
  if (!test::have_canmatrix()) RUTD_SKIP_NEEDS_INSTALLED("needs /usr/bin/python3 with canmatrix (python3-canmatrix)");
  const test::TempDir tmp;
  const std::string rec = (tmp.path() / "rec").string(), log = (tmp.path() / "can.log").string();
  ASSERT_EQ(test::run_rutd("synth " + rec + " --frames 24 --size 320x240 --seed 9"), 0);
  // Pairs 12.. moved 2.5 s later.
  constexpr std::int64_t kGapNs = 2'500'000'000;
  {
    std::ifstream in(rec + "/frames.csv");
    std::string text, line;
    std::getline(in, line);
    text = line + "\n";
    for (int i = 0; std::getline(in, line); ++i) {
      const auto a = line.find(','), b = line.find(',', a + 1);
      const std::int64_t t = std::stoll(line.substr(a + 1, b - a - 1)) + (i >= 12 ? kGapNs : 0);
      text += line.substr(0, a + 1) + std::to_string(t) + line.substr(b) + "\n";
    }
    std::ofstream(rec + "/frames.csv") << text;
  }
  ASSERT_EQ(test::run_rutd("replay " + rec + " --out " + (tmp.path() / "m.csv").string() + " --candump " + log), 0);
  bool ok = false;
  const auto all = test::decode_candump(log, ok);
  ASSERT_TRUE(ok) << "decoder reported CRC, counter or format errors";
  const std::vector<std::int64_t> t = pair_times(rec);
  ASSERT_EQ(t.size(), 24u);
  const std::int64_t before = t[11], after = t[12];  // the last pair before the gap, the first after it
  int in_gap = 0, lost = 0;
  for (const auto& s : test::frames_of(all, "RutSensorStatus")) {
    const bool no_camera = s.phys.at("NoCamera") == 1;
    const std::string& last = s.named.at("RutS_LastStatus");
    if (s.t_ns <= before + 1'000'000'000 || s.t_ns >= after) {
      EXPECT_FALSE(no_camera) << "status at " << s.t_ns;
      EXPECT_EQ(last, "OK") << "status at " << s.t_ns;
      continue;
    }
    ++in_gap;
    lost += no_camera;
    EXPECT_TRUE(no_camera) << "status at " << s.t_ns << ", " << (s.t_ns - before) / 1'000'000 << " ms after a pair";
    EXPECT_EQ(last, "NO_MEASUREMENT") << "status at " << s.t_ns;
  }
  // From 1 s after the last pair to the next pair: (2.5 + 0.033 - 1) s of statuses every 100 ms.
  EXPECT_GE(in_gap, 14);
  EXPECT_LE(in_gap, 16);
  std::printf("%d status frames in the gap beyond 1 s, %d of them NoCamera and NO_MEASUREMENT\n", in_gap, lost);
}

}  // namespace
}  // namespace rutd
