// The CAN output of a real measurement run, decoded by an independent decoder: `rutd replay` of a
// synthetic recording writes the measurement CSV and the candump log; canmatrix decodes the log with
// config/rutd.dbc (tests/can/decode_candump.py, which also checks every CRC and counter). Every decoded
// value must equal the CSV within the signal's resolution, and the depth the renderer's truth within the
// measurement tolerance.
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace rutd
