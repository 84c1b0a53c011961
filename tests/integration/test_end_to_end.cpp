// End to end through the rutd program, as a user runs it: `rutd synth` renders a recording of a rut of
// known shape (the renderer's analytic truth is the independent reference), `rutd replay` measures it,
// and every measured depth must be within 1.0 mm of the truth (the seed's own algorithm was 3-5 mm off).
// These scenes are clean: the CAN frames, decoded with the DBC by canmatrix, must carry no condition
// flag (README, "Conditions rutd flags").
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "decoded_candump.hpp"
#include "gpu_test_support.hpp"
#include "recording/measurement_csv.hpp"
#include "synthetic/truth_csv.hpp"
#include "test_support.hpp"

namespace rutd {
namespace {

struct Case {
  const char* name;
  double depth_mm;
  const char* size;
  const char* texture;
  double roll_deg;
  double baseline_mm;
  double height_mm;
  int frames;
  int seed;
};

std::ostream& operator<<(std::ostream& os, const Case& c) { return os << c.name; }

// `rutd synth` of the case into tmp/rec; returns that folder.
std::string synthesize(const Case& c, const test::TempDir& tmp) {
  const std::string rec = (tmp.path() / "rec").string();
  std::ostringstream synth;
  synth << "synth " << rec << " --frames " << c.frames << " --depth " << c.depth_mm << " --size " << c.size
        << " --texture " << c.texture << " --roll " << c.roll_deg << " --baseline " << c.baseline_mm << " --height "
        << c.height_mm << " --seed " << c.seed;
  EXPECT_EQ(test::run_rutd(synth.str()), 0);
  return rec;
}

// `rutd replay` of rec, its CAN frames logged to tmp/can<engine>.log; engine: "" for the configured
// default, else a --engine name. With the GPU engine, the replay must have run on a Vulkan device
// throughout (gpu_test_support.hpp).
std::vector<MeasurementRow> replay(const std::string& rec, const std::string& engine, const test::TempDir& tmp) {
  const std::string csv = (tmp.path() / ("m" + engine + ".csv")).string();
  const std::string log = (tmp.path() / ("can" + engine + ".log")).string();
  const std::string err = (tmp.path() / ("err" + engine + ".txt")).string();
  EXPECT_EQ(
      test::run_rutd(
          "replay " + rec + " --out " + csv + " --candump " + log + (engine.empty() ? "" : " --engine " + engine), err),
      0)
      << test::read_text(err);
  if (engine == "gpu") test::expect_ran_on_gpu(test::read_text(err));
  return read_measurement_csv(csv).rows;
}

void expect_depth_within_one_millimetre(const Case& c, const std::string& engine) {
  const test::TempDir tmp;
  const std::string rec = synthesize(c, tmp);
  const auto truth = read_truth_csv(rec + "/truth.csv");
  const auto rows = replay(rec, engine, tmp);
  const auto log = tmp.path() / ("can" + engine + ".log");
  ASSERT_EQ(rows.size(), truth.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    ASSERT_EQ(rows[i].measurement.status, RutStatus::Ok) << "frame " << i;
    const double err = rows[i].measurement.depth_mm - truth[i].depth_mm;
    std::printf("%-28s frame %zu  truth %.2f  measured %.3f  error %+.3f mm  width %.1f/%.1f\n", c.name, i,
                truth[i].depth_mm, rows[i].measurement.depth_mm, err, rows[i].measurement.width_mm, truth[i].width_mm);
    EXPECT_LE(std::abs(err), 1.0) << c.name << " frame " << i;
  }
  if (!test::have_canmatrix())
    RUTD_SKIP_NEEDS_INSTALLED("condition flags not checked: needs /usr/bin/python3 with canmatrix (python3-canmatrix)");
  bool decoded = false;
  const auto conditions = test::frames_of(test::decode_candump(log, decoded), "RutConditions");
  EXPECT_TRUE(decoded) << "decoder reported CRC, counter or format errors";
  ASSERT_EQ(conditions.size(), rows.size());
  const char* flags[] = {"Water",       "LeftLensObstructed", "RightLensObstructed", "LowLight",
                         "Overexposed", "Vegetation",         "CalibrationDrift",    "DepthUncertain"};
  for (std::size_t i = 0; i < conditions.size(); ++i) {
    for (const char* flag : flags)
      EXPECT_EQ(conditions[i].phys.at(flag), 0) << c.name << " frame " << i << ": " << flag;
    std::printf("%-28s frame %zu  uncertainty %.2f mm  vertical disparity %+.2f px\n", c.name, i,
                conditions[i].phys.at("DepthUncertainty"), conditions[i].phys.at("VerticalDisparity"));
  }
}

class EndToEnd : public ::testing::TestWithParam<Case> {};
TEST_P(EndToEnd, DepthWithinOneMillimetreOfTruth) { expect_depth_within_one_millimetre(GetParam(), ""); }

// The Vulkan engine (lavapipe in CI) with the DIC; skipped only where no Vulkan driver exists.
class EndToEndGpu : public ::testing::TestWithParam<Case> {};
TEST_P(EndToEndGpu, DepthWithinOneMillimetreOfTruth) {
  RUTD_SKIP_WITHOUT_VULKAN_DRIVER();
  expect_depth_within_one_millimetre(GetParam(), "gpu");
}

// The GPU engine measures as sgmref does, the same matcher on the CPU with the CPU DIC (double
// precision, warm-started windows, the strip matched binned): the same depth to 0.1 mm, and nearly as
// many cross-section bins (the GPU's cold-started windows converge slightly less often on rut walls).
TEST_P(EndToEndGpu, DepthAgreesWithTheCpuEngineOfTheSameMatcher) {
  RUTD_SKIP_WITHOUT_VULKAN_DRIVER();
  const Case& c = GetParam();
  const test::TempDir tmp;
  const std::string rec = synthesize(c, tmp);
  const auto gpu = replay(rec, "gpu", tmp);
  const auto cpu = replay(rec, "sgmref", tmp);
  ASSERT_EQ(gpu.size(), cpu.size());
  for (std::size_t i = 0; i < gpu.size(); ++i) {
    const RutMeasurement& g = gpu[i].measurement;
    const RutMeasurement& r = cpu[i].measurement;
    std::printf("%-28s frame %zu  depth gpu %.3f sgmref %.3f (%+.3f mm)  valid %.3f / %.3f\n", c.name, i, g.depth_mm,
                r.depth_mm, g.depth_mm - r.depth_mm, g.valid_fraction, r.valid_fraction);
    ASSERT_EQ(g.status, RutStatus::Ok) << c.name << " frame " << i;
    ASSERT_EQ(r.status, RutStatus::Ok) << c.name << " frame " << i;
    EXPECT_LE(std::abs(g.depth_mm - r.depth_mm), 0.1) << c.name << " frame " << i;
    EXPECT_GE(g.valid_fraction, r.valid_fraction - 0.1) << c.name << " frame " << i;
  }
}

// Each depth of the seed's Table 3 at both resolutions, both textures, both rolls and the rig extremes,
// plus mud and grass; a different random texture and noise per case.
const Case kCases[] = {
    {"d30_640_sand_r0_b40h400", 30, "640x480", "sand", 0, 40, 400, 3, 7},
    {"d40_640_snow_r3_b80h300", 40, "640x480", "snow", 3, 80, 300, 3, 8},
    {"d50_640_sand_r3_b60h350", 50, "640x480", "sand", 3, 60, 350, 3, 9},
    {"d60_640_snow_r0_b60h350", 60, "640x480", "snow", 0, 60, 350, 3, 10},
    {"d60_640_sand_r3_b80h300", 60, "640x480", "sand", 3, 80, 300, 3, 11},
    {"d30_640_snow_r3_b40h400", 30, "640x480", "snow", 3, 40, 400, 3, 12},
    {"d50_640_snow_r0_b80h300", 50, "640x480", "snow", 0, 80, 300, 3, 13},
    {"d40_640_mud_r3_b60h350", 40, "640x480", "mud", 3, 60, 350, 3, 14},
    {"d50_640_grass_r0_b40h400", 50, "640x480", "grass", 0, 40, 400, 3, 15},
    {"d30_1280_snow_r3_b80h300", 30, "1280x1024", "snow", 3, 80, 300, 2, 16},
    {"d40_1280_sand_r0_b40h400", 40, "1280x1024", "sand", 0, 40, 400, 2, 17},
    {"d50_1280_snow_r0_b80h300", 50, "1280x1024", "snow", 0, 80, 300, 2, 18},
    {"d60_1280_sand_r3_b40h400", 60, "1280x1024", "sand", 3, 40, 400, 2, 19},
    {"d60_1280_snow_r3_b60h350", 60, "1280x1024", "snow", 3, 60, 350, 2, 20},
};

INSTANTIATE_TEST_SUITE_P(Matrix, EndToEnd, ::testing::ValuesIn(kCases),
                         [](const auto& info) { return std::string(info.param.name); });

// The published uncertainty means what the README says: a standard uncertainty. Over every frame of the
// matrix, the depth errors against the renderer's truth, divided by the DepthUncertainty the CAN frame
// carries (decoded by canmatrix), must spread like a standard normal variable's: their RMS between 0.65
// and 1.5, at least 75 % of them within 2 u (95 % for a normal variable), and none beyond 5 u; and the
// same errors against u doubled and against u halved must fail these criteria. A floor of 0.02 mm stands for the CAN
// signal's 0.01 mm step.
TEST(EndToEndUncertainty, DepthErrorsSpreadAsTheirEstimatedUncertainty) {
  if (!test::have_canmatrix()) RUTD_SKIP_NEEDS_INSTALLED("needs /usr/bin/python3 with canmatrix (python3-canmatrix)");
  std::vector<double> z;
  for (const Case& c : kCases) {
    const test::TempDir tmp;
    const auto truth = read_truth_csv(synthesize(c, tmp) + "/truth.csv");
    const auto rows = replay(tmp.path().string() + "/rec", "", tmp);
    bool decoded = false;
    const auto conditions = test::frames_of(test::decode_candump(tmp.path() / "can.log", decoded), "RutConditions");
    ASSERT_TRUE(decoded) << c.name;
    ASSERT_EQ(rows.size(), truth.size()) << c.name;
    ASSERT_EQ(conditions.size(), rows.size()) << c.name;
    for (std::size_t i = 0; i < rows.size(); ++i) {
      ASSERT_EQ(rows[i].measurement.status, RutStatus::Ok) << c.name << " frame " << i;
      const double u = std::max(conditions[i].phys.at("DepthUncertainty"), 0.02);
      z.push_back((rows[i].measurement.depth_mm - truth[i].depth_mm) / u);
    }
  }
  ASSERT_GE(z.size(), 30u);
  // The criteria for the uncertainty scaled by `scale`: the RMS of error / u within [0.65, 1.5] (a
  // standard normal's is 1, within about 0.25 of it over 30-40 frames at 95 %), at least 75 % within 2 u, none
  // beyond 5 u.
  struct Spread {
    double rms = 0.0, share2 = 0.0, worst = 0.0;
    bool standard() const { return rms >= 0.65 && rms <= 1.5 && share2 >= 0.75 && worst <= 5.0; }
  };
  const auto spread = [&](double scale) {
    Spread s;
    double sum2 = 0.0;
    std::size_t within2 = 0;
    for (const double e : z) {
      const double v = e / scale;
      sum2 += v * v;
      s.worst = std::max(s.worst, std::abs(v));
      within2 += std::abs(v) <= 2.0;
    }
    s.rms = std::sqrt(sum2 / static_cast<double>(z.size()));
    s.share2 = static_cast<double>(within2) / static_cast<double>(z.size());
    return s;
  };
  const Spread s = spread(1.0);
  std::printf("%zu frames: RMS of error / uncertainty %.2f, %.0f %% within 2 u, worst %.2f u\n", z.size(), s.rms,
              100.0 * s.share2, s.worst);
  EXPECT_GE(s.rms, 0.65) << "the uncertainty overstates the errors";
  EXPECT_LE(s.rms, 1.5) << "the uncertainty understates the errors";
  EXPECT_GE(s.share2, 0.75);
  EXPECT_LE(s.worst, 5.0);
  // The same criteria fail an uncertainty twice as large and one half as large as published.
  EXPECT_FALSE(spread(2.0).standard()) << "u doubled passes: RMS " << spread(2.0).rms;
  EXPECT_FALSE(spread(0.5).standard()) << "u halved passes: RMS " << spread(0.5).rms;
}

// The 30-60 mm ruts of the seed's Table 3 at 640x480, both textures and rolls.
const Case kGpuCases[] = {
    {"d30_640_sand_r0_b40h400", 30, "640x480", "sand", 0, 40, 400, 2, 21},
    {"d40_640_snow_r3_b80h300", 40, "640x480", "snow", 3, 80, 300, 2, 22},
    {"d50_640_sand_r3_b60h350", 50, "640x480", "sand", 3, 60, 350, 2, 23},
    {"d60_640_snow_r0_b60h350", 60, "640x480", "snow", 0, 60, 350, 2, 24},
};
INSTANTIATE_TEST_SUITE_P(Matrix, EndToEndGpu, ::testing::ValuesIn(kGpuCases),
                         [](const auto& info) { return std::string(info.param.name); });

}  // namespace
}  // namespace rutd
