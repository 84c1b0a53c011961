// Ground truth of the synthetic renderer: analytic values, the truth against the cross-section that
// ray casting actually sees, the depth profile, and the truth.csv format.
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include "core/input_error.hpp"
#include "synthetic/synthetic_renderer.hpp"
#include "synthetic/truth_csv.hpp"

namespace rutd {
namespace {

constexpr double kDeg = std::numbers::pi / 180;

SyntheticRendererConfig aligned_params() {
  SyntheticRendererConfig p;
  p.rig.image_size = {320, 240};
  p.rig.misalign_yaw_deg = p.rig.misalign_pitch_deg = p.rig.misalign_roll_deg = 0;
  return p;
}

TEST(SyntheticTruth, AnalyticValuesForALevelAlignedRig) {
  SyntheticRendererConfig p = aligned_params();
  p.rut.pile_left_mm = 10;
  p.rut.pile_right_mm = 15;
  p.rut.lateral_offset_mm = 20;
  const SyntheticRenderer renderer(p);
  const RutTruth t = renderer.truth(9);
  const RutShape& r = p.rut;
  EXPECT_EQ(t.index, 9u);
  EXPECT_NEAR(t.depth_mm, r.depth_mm, 1e-9);
  EXPECT_NEAR(t.width_mm, r.width_mm, 1e-9);
  EXPECT_NEAR(t.left_pile_mm, 10, 1e-9);
  EXPECT_NEAR(t.right_pile_mm, 15, 1e-9);
  EXPECT_NEAR(t.area_mm2, r.depth_mm * (r.bottom_width_mm + (r.width_mm - r.bottom_width_mm) / 2), 1e-6);
  EXPECT_NEAR(t.ground_slope_deg, 0, 1e-12);
  EXPECT_NEAR(t.center_x_mm, r.lateral_offset_mm + p.rig.baseline_mm / 2, 1e-9);  // left camera at x = -B/2
  EXPECT_EQ(t.tread_depth_mm, 0);
  EXPECT_NEAR(t.y_mm, 9 * p.speed_mm_s / p.fps, 1e-9);
  p.rut.tread = true;
  EXPECT_NEAR(SyntheticRenderer(p).truth(0).tread_depth_mm, r.tread_depth_mm, 1e-9);
}

TEST(SyntheticTruth, SlopeSignUnderRollMatchesTwoGroundPoints) {
  SyntheticRendererConfig p = aligned_params();
  p.rig.roll_deg = 5;  // right camera lower: ground at larger X is closer
  p.rut.width_mm = 120, p.rut.bottom_width_mm = 60, p.rut.pile_width_mm = 20;
  const SyntheticRenderer renderer(p);
  const RutTruth t = renderer.truth(0);
  EXPECT_LT(t.ground_slope_deg, 0);
  EXPECT_NEAR(t.ground_slope_deg, -p.rig.roll_deg, 1e-9);
  // Two undisturbed ground points on the principal row, projected through the calibration.
  const StereoCalibration& c = renderer.calibration();
  std::vector<cv::Point3d> points;
  for (double x : {-0.65, 0.65}) {
    const auto hit = renderer.intersect_left(0, cv::Vec3d(x, 0, 1));
    ASSERT_TRUE(hit.has_value());
    points.emplace_back((*hit)[0], (*hit)[1], (*hit)[2]);
  }
  std::vector<cv::Point2d> pixels;
  cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), c.M1, c.D1, pixels);
  EXPECT_LT(pixels[0].x, pixels[1].x);
  EXPECT_LT(points[1].z, points[0].z);  // the right-hand point is nearer the camera
  const double slope = std::atan((points[1].z - points[0].z) / (points[1].x - points[0].x)) / kDeg;
  EXPECT_NEAR(slope, t.ground_slope_deg, 1e-6);
}

struct Measured {
  double slope_deg, depth, width, left_pile, right_pile, area, center_x;
};

// Measures the cross-section that ray casting sees in the truth frame's plane Y = 0, with the
// definitions of core/rut_measurement.hpp: ground line through far undisturbed ground, heights
// perpendicular to it, crossings walking out from the deepest point.
Measured measure_cross_section(const SyntheticRenderer& renderer, std::uint64_t index, double ground_from) {
  const cv::Matx33d R1 = renderer.truth_rotation();
  std::vector<cv::Vec3d> pts;
  for (double x = -0.7; x <= 0.7; x += 0.0001) {
    const auto hit = renderer.intersect_left(index, R1.t() * cv::Vec3d(x, 0, 1));
    if (hit) pts.push_back(R1 * *hit);
  }
  // Least-squares line Z = m X + c through the far ground on both sides.
  double sx = 0, sz = 0, sxx = 0, sxz = 0, n = 0;
  const double centre = renderer.truth(index).center_x_mm;
  for (const auto& q : pts) {
    if (std::abs(q[0] - centre) < ground_from) continue;
    sx += q[0], sz += q[2], sxx += q[0] * q[0], sxz += q[0] * q[2], n += 1;
  }
  const double m = (n * sxz - sx * sz) / (n * sxx - sx * sx), c = (sz - m * sx) / n;
  const double norm = std::sqrt(1 + m * m);
  std::vector<double> height(pts.size());
  std::size_t deepest = 0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    height[i] = (m * pts[i][0] + c - pts[i][2]) / norm;  // + towards the camera
    if (height[i] < height[deepest]) deepest = i;
  }
  const auto crossing = [&](int dir) {
    std::size_t i = deepest;
    while (height[i + dir] < 0) i += dir;
    const double u = height[i] / (height[i] - height[i + dir]);
    return pts[i][0] + u * (pts[i + dir][0] - pts[i][0]);
  };
  Measured out{};
  out.slope_deg = std::atan(m) / kDeg;
  out.depth = -height[deepest];
  const double left = crossing(-1), right = crossing(1);
  out.width = (right - left) * norm;
  out.center_x = (left + right) / 2;
  for (std::size_t i = 1; i < pts.size(); ++i) {
    const double x = pts[i][0];
    if (x < left) out.left_pile = std::max(out.left_pile, height[i]);
    if (x > right) out.right_pile = std::max(out.right_pile, height[i]);
    if (x > left && pts[i - 1][0] < right) {
      out.area += -0.5 * (std::min(height[i], 0.0) + std::min(height[i - 1], 0.0)) * (x - pts[i - 1][0]) * norm;
    }
  }
  return out;
}

void expect_truth_matches_cross_section(const SyntheticRendererConfig& p, std::uint64_t index) {
  const SyntheticRenderer renderer(p);
  const RutTruth t = renderer.truth(index);
  const Measured m = measure_cross_section(renderer, index, p.rut.width_mm / 2 + p.rut.pile_width_mm + 25);
  std::printf("truth depth %.4f width %.4f piles %.4f/%.4f area %.2f slope %.4f centre %.4f\n", t.depth_mm, t.width_mm,
              t.left_pile_mm, t.right_pile_mm, t.area_mm2, t.ground_slope_deg, t.center_x_mm);
  std::printf("rays  depth %.4f width %.4f piles %.4f/%.4f area %.2f slope %.4f centre %.4f\n", m.depth, m.width,
              m.left_pile, m.right_pile, m.area, m.slope_deg, m.center_x);
  EXPECT_NEAR(m.slope_deg, t.ground_slope_deg, 1e-4);
  EXPECT_NEAR(m.depth, t.depth_mm, 0.01);
  EXPECT_NEAR(m.width, t.width_mm, 0.05);
  EXPECT_NEAR(m.left_pile, t.left_pile_mm, 0.02);
  EXPECT_NEAR(m.right_pile, t.right_pile_mm, 0.02);
  EXPECT_NEAR(m.area, t.area_mm2, 2e-3 * t.area_mm2);
  EXPECT_NEAR(m.center_x, t.center_x_mm, 0.05);
}

TEST(SyntheticTruth, MatchesRayCastCrossSectionUnderRollPitchAndMisalignment) {
  SyntheticRendererConfig p;
  p.rig.image_size = {320, 240};
  p.rig.roll_deg = 4;
  p.rig.pitch_deg = 8;
  p.rut.pile_left_mm = 8;
  p.rut.pile_right_mm = 14;
  p.rut.lateral_offset_mm = -15;
  p.rut.width_mm = 160, p.rut.bottom_width_mm = 60, p.rut.depth_mm = 35, p.rut.pile_width_mm = 30;
  expect_truth_matches_cross_section(p, 4);
}

TEST(SyntheticTruth, MatchesRayCastCrossSectionOfAWanderingRut) {
  SyntheticRendererConfig p;
  p.rig.image_size = {320, 240};
  p.rig.roll_deg = -3;
  p.rut.width_mm = 160, p.rut.bottom_width_mm = 60, p.rut.depth_mm = 35, p.rut.pile_width_mm = 30;
  p.rut.wander_amplitude_mm = 40;
  p.rut.wander_wavelength_mm = 900;
  p.speed_mm_s = 3000;
  expect_truth_matches_cross_section(p, 2);  // y = 200 mm: the centreline crosses at a slant
}

// The water's truth against the cross-section ray casting sees: where it crosses the water's world
// height, and how far below the ground line (fitted to far ground, as measure_cross_section does) that is.
void expect_waterline_matches_cross_section(const SyntheticRendererConfig& p, std::uint64_t index) {
  const SyntheticRenderer renderer(p);
  const RutTruth t = renderer.truth(index);
  const cv::Matx33d R1 = renderer.truth_rotation();
  const cv::Matx33d world_from_left = renderer.camera_rotation(Camera::Left);
  const cv::Vec3d centre = renderer.camera_centre(Camera::Left, index);
  const WaterConfig& w = p.conditions.water;
  const double z_water = w.surface_depth_mm > 0 ? -w.surface_depth_mm : w.level_mm - renderer.depth_mm(index);
  std::vector<cv::Vec3d> pts;  // truth frame
  std::vector<double> world_z;
  for (double x = -0.7; x <= 0.7; x += 0.0001) {
    const auto hit = renderer.intersect_left(index, R1.t() * cv::Vec3d(x, 0, 1));
    if (!hit) continue;
    pts.push_back(R1 * *hit);
    world_z.push_back((world_from_left * *hit + centre)[2]);
  }
  std::vector<double> crossings;
  for (std::size_t i = 1; i < pts.size(); ++i) {
    if ((world_z[i - 1] < z_water) != (world_z[i] < z_water)) {
      const double u = (z_water - world_z[i - 1]) / (world_z[i] - world_z[i - 1]);
      crossings.push_back(pts[i - 1][0] + u * (pts[i][0] - pts[i - 1][0]));
    }
  }
  ASSERT_EQ(crossings.size(), 2u);
  double sx = 0, sz = 0, sxx = 0, sxz = 0, n = 0;
  const double ground_from = p.rut.width_mm / 2 + p.rut.pile_width_mm + 25;
  for (const auto& q : pts) {
    if (std::abs(q[0] - t.center_x_mm) < ground_from) continue;
    sx += q[0], sz += q[2], sxx += q[0] * q[0], sxz += q[0] * q[2], n += 1;
  }
  const double m = (n * sxz - sx * sz) / (n * sxx - sx * sx), c = (sz - m * sx) / n;
  // The waterline's points on the cross-section, interpolated at the crossings' X.
  double below = 0;
  for (double X : crossings) {
    std::size_t i = 1;
    while (pts[i][0] < X) ++i;
    const double u = (X - pts[i - 1][0]) / (pts[i][0] - pts[i - 1][0]);
    const double Z = pts[i - 1][2] + u * (pts[i][2] - pts[i - 1][2]);
    below += 0.5 * (Z - m * X - c) / std::sqrt(1 + m * m);
  }
  std::printf("waterline truth X %.4f / %.4f depth below ground %.4f water %.4f; rays X %.4f / %.4f below %.4f\n",
              t.waterline_left_x_mm, t.waterline_right_x_mm, t.waterline_depth_mm, t.water_depth_mm, crossings[0],
              crossings[1], below);
  EXPECT_NEAR(crossings[0], t.waterline_left_x_mm, 0.02);
  EXPECT_NEAR(crossings[1], t.waterline_right_x_mm, 0.02);
  EXPECT_NEAR(below, t.waterline_depth_mm, 0.01);
  EXPECT_NEAR(t.water_depth_mm + t.waterline_depth_mm, t.depth_mm, 1e-9);
}

TEST(SyntheticTruth, WaterlineMatchesTheRayCastCrossSection) {
  SyntheticRendererConfig p;
  p.rig.image_size = {320, 240};
  p.rig.roll_deg = 4;
  p.rig.pitch_deg = 8;
  p.rut.pile_left_mm = 8;
  p.rut.pile_right_mm = 14;
  p.rut.lateral_offset_mm = -15;
  p.rut.width_mm = 160, p.rut.bottom_width_mm = 60, p.rut.depth_mm = 35, p.rut.pile_width_mm = 30;
  p.conditions.water.level_mm = 12;
  expect_waterline_matches_cross_section(p, 4);
  p.rut.wander_amplitude_mm = 40;  // the centreline crosses the section at a slant
  p.rut.wander_wavelength_mm = 900;
  p.speed_mm_s = 3000;
  p.conditions.water.level_mm = 25;
  expect_waterline_matches_cross_section(p, 2);
  p.conditions.water.level_mm = 0;
  EXPECT_EQ(SyntheticRenderer(p).truth(2).water_depth_mm, 0);
  EXPECT_TRUE(std::isnan(SyntheticRenderer(p).truth(2).waterline_left_x_mm));
}

// A pool the rut runs into (WaterConfig::surface_depth_mm): the surface stays where it is while the rut
// deepens, so the truth has no water while the rut is shallower and the rest of the depth after; the
// waterline lies where the ray-cast cross-section crosses the surface's level.
TEST(SyntheticTruth, APoolsSurfaceStaysAtItsDepthWhileTheRutDeepens) {
  SyntheticRendererConfig p;
  p.rig.image_size = {320, 240};
  p.rig.roll_deg = 3;
  p.rig.pitch_deg = 5;
  p.rut.width_mm = 160, p.rut.bottom_width_mm = 60, p.rut.depth_mm = 30, p.rut.pile_width_mm = 30;
  p.depth_profile = {{0, 30}, {10, 50}};  // 2 mm a frame
  p.conditions.water.surface_depth_mm = 37;
  const SyntheticRenderer renderer(p);
  int dry = 0, wet = 0;
  for (std::uint64_t i = 0; i <= 10; ++i) {
    const RutTruth t = renderer.truth(i);
    const double world_depth = 30 + 2.0 * static_cast<double>(i);
    if (world_depth <= 37) {
      EXPECT_EQ(t.water_depth_mm, 0) << "frame " << i;
      EXPECT_TRUE(std::isnan(t.waterline_left_x_mm)) << "frame " << i;
      ++dry;
    } else {
      // In the section's plane, as depth_mm: scaled alike.
      EXPECT_NEAR(t.water_depth_mm / t.depth_mm, (world_depth - 37) / world_depth, 1e-9) << "frame " << i;
      EXPECT_NEAR(t.water_depth_mm + t.waterline_depth_mm, t.depth_mm, 1e-9) << "frame " << i;
      ++wet;
    }
  }
  EXPECT_EQ(dry, 4);  // frames 0-3: 30-36 mm
  EXPECT_EQ(wet, 7);
  p.depth_profile = {{0, 45}, {10, 45}};
  expect_waterline_matches_cross_section(p, 3);  // 8 mm of water at 37 mm below the ground
}

TEST(SyntheticTruth, DepthFollowsThePiecewiseLinearProfile) {
  SyntheticRendererConfig p = aligned_params();
  p.depth_profile = {{10, 20}, {20, 40}, {30, 40}, {50, 10}};
  const SyntheticRenderer renderer(p);
  const std::vector<std::pair<std::uint64_t, double>> expected = {{0, 20},  {10, 20},   {15, 30}, {19, 38},  {25, 40},
                                                                  {40, 25}, {45, 17.5}, {50, 10}, {1000, 10}};
  for (const auto& [index, depth] : expected) {
    EXPECT_NEAR(renderer.depth_mm(index), depth, 1e-12) << "frame " << index;
    EXPECT_NEAR(renderer.truth(index).depth_mm, depth, 1e-9) << "frame " << index;
  }
  // The rendered terrain follows it too: the bottom seen straight down.
  const double x = (p.rut.lateral_offset_mm + p.rig.baseline_mm / 2) / p.rig.height_mm;
  EXPECT_NEAR((*renderer.intersect_left(15, cv::Vec3d(x, 0, 1)))[2], p.rig.height_mm + 30, 1e-6);
}

class TruthCsv : public ::testing::Test {
 protected:
  std::string path(const std::string& name) {
    const auto dir = std::filesystem::temp_directory_path() / ("rutd_truth_csv_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    return (dir / name).string();
  }
  void write(const std::string& file, const std::string& text) { std::ofstream(file) << text; }
  void expect_error(const std::string& file, const std::string& field, const std::string& words) {
    try {
      read_truth_csv(file);
      ADD_FAILURE() << "no error for " << file;
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), file);
      EXPECT_EQ(e.field(), field) << e.what();
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  }
};

TEST_F(TruthCsv, RoundTripsExactly) {
  RutTruth a{7,   50.000123456789,    200.1, 12.5,  0.0,   7500.033333333333, -4.999999999, 30.25,
             3.0, 233.33333333333334, 12.25, 37.75, -70.5, 130.125,           2500000,      0.8887166368888804,
             1};
  RutTruth b{18446744073709551615ull, 1e-300, 0.1, 1.0 / 3, 2.0 / 3, 1e12, 0.0, -1234.5678, 0.0, -5.0};  // dry
  b.right_delay_ns = -16666667, b.exposure = 2, b.gain = 8.396;
  const std::string file = path("truth.csv");
  {
    TruthCsvWriter writer(file);
    EXPECT_TRUE(writer.append(a, 233333333));
    EXPECT_TRUE(writer.append(b, -9));
  }
  std::ifstream in(file);
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header, kTruthCsvHeader);
  std::vector<std::int64_t> t_ns;
  const std::vector<RutTruth> rows = read_truth_csv(file, &t_ns);
  ASSERT_EQ(rows.size(), 2u);
  ASSERT_EQ(t_ns, (std::vector<std::int64_t>{233333333, -9}));
  for (int i = 0; i < 2; ++i) {
    const RutTruth& e = i == 0 ? a : b;
    const RutTruth& r = rows[i];
    EXPECT_EQ(r.index, e.index);
    EXPECT_EQ(r.depth_mm, e.depth_mm);
    EXPECT_EQ(r.width_mm, e.width_mm);
    EXPECT_EQ(r.left_pile_mm, e.left_pile_mm);
    EXPECT_EQ(r.right_pile_mm, e.right_pile_mm);
    EXPECT_EQ(r.area_mm2, e.area_mm2);
    EXPECT_EQ(r.ground_slope_deg, e.ground_slope_deg);
    EXPECT_EQ(r.center_x_mm, e.center_x_mm);
    EXPECT_EQ(r.tread_depth_mm, e.tread_depth_mm);
    EXPECT_EQ(r.y_mm, e.y_mm);
    EXPECT_EQ(r.water_depth_mm, e.water_depth_mm);
    for (const auto& [read, written] : {std::pair{r.waterline_depth_mm, e.waterline_depth_mm},
                                        {r.waterline_left_x_mm, e.waterline_left_x_mm},
                                        {r.waterline_right_x_mm, e.waterline_right_x_mm}}) {
      if (std::isnan(written)) {
        EXPECT_TRUE(std::isnan(read));  // a dry rut has no waterline
      } else {
        EXPECT_EQ(read, written);
      }
    }
    EXPECT_EQ(r.right_delay_ns, e.right_delay_ns);
    EXPECT_EQ(r.exposure, e.exposure);
    EXPECT_EQ(r.gain, e.gain);
  }
}

TEST_F(TruthCsv, ReadsFilesWrittenBeforeTheWaterAndCameraColumns) {
  write(path("dry.csv"), std::string(kTruthCsvHeaderDry) + "\n4,5,50,200,12,12,7500,0,30,0,7.5\n");
  const std::vector<RutTruth> rows = read_truth_csv(path("dry.csv"));
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].index, 4u);
  EXPECT_EQ(rows[0].y_mm, 7.5);
  EXPECT_EQ(rows[0].water_depth_mm, 0);
  EXPECT_TRUE(std::isnan(rows[0].waterline_left_x_mm));
  EXPECT_EQ(rows[0].right_delay_ns, 0);
  EXPECT_EQ(rows[0].exposure, 1);
  EXPECT_EQ(rows[0].gain, 1);
  // One form per file: a line of the new form under the old header is an error.
  write(path("mixed.csv"),
        std::string(kTruthCsvHeaderDry) + "\n4,5,50,200,12,12,7500,0,30,0,7.5,0,nan,nan,nan,0,1,1\n");
  expect_error(path("mixed.csv"), "line 2", "expected 11 fields, found 18");
}

TEST_F(TruthCsv, BadFilesNameFileAndLine) {
  const std::string header = std::string(kTruthCsvHeader) + "\n";
  const std::string tail = ",0,nan,nan,nan,0,1,1\n";  // dry, triggered cameras, exposure and gain 1
  const std::string good = "0,0,50,200,12,12,7500,0,30,0,0" + tail;
  write(path("header.csv"), "index,t_ns,depth\n" + good);
  expect_error(path("header.csv"), "line 1", "header");
  write(path("fields.csv"), header + good + "1,33,50,200,12,12,7500,0,30,0,0,0,nan,nan,nan,0,1\n");
  expect_error(path("fields.csv"), "line 3", "expected 18 fields, found 17");
  write(path("number.csv"), header + "0,0,abc,200,12,12,7500,0,30,0,0" + tail);
  expect_error(path("number.csv"), "line 2", "depth_mm");
  write(path("index.csv"), header + "-1,0,50,200,12,12,7500,0,30,0,0" + tail);
  expect_error(path("index.csv"), "line 2", "index");
  write(path("trailing.csv"), header + "0,0,50,200,12,12,7500,0,30,0,0x" + tail);
  expect_error(path("trailing.csv"), "line 2", "y_mm");
  write(path("delay.csv"), header + "0,0,50,200,12,12,7500,0,30,0,0,0,nan,nan,nan,1.5,1,1\n");
  expect_error(path("delay.csv"), "line 2", "right_delay_ns");
  write(path("gain.csv"), header + "0,0,50,200,12,12,7500,0,30,0,0,0,nan,nan,nan,0,1,1x\n");
  expect_error(path("gain.csv"), "line 2", "gain");
  write(path("empty.csv"), "");
  expect_error(path("empty.csv"), "file", "empty");
  expect_error(path("missing.csv"), "file", "cannot open");
  write(path("crlf.csv"),
        std::string(kTruthCsvHeader) + "\r\n" + "4,5,50,200,12,12,7500,0,30,0,0,0,nan,nan,nan,0,1,1\r\n");
  EXPECT_EQ(read_truth_csv(path("crlf.csv")).at(0).index, 4u);
  EXPECT_THROW(TruthCsvWriter("/nonexistent-dir/truth.csv"), InputError);
}

// Found by fuzzing: a CR (or any control byte) inside a field was quoted into the message as is, so the
// error spanned two lines on a terminal and in the journal. It is written escaped.
TEST_F(TruthCsv, ErrorQuotingABadFieldIsOneLine) {
  write(path("cr.csv"), std::string(kTruthCsvHeader) + "\n0,0,50,200,12,12,75\r00,0,30,0,0,0,nan,nan,nan,0,1,1\n");
  expect_error(path("cr.csv"), "line 2", "field 'area_mm2': not a number: '75\\r00'");
  write(path("bell.csv"),
        std::string(kTruthCsvHeader) + "\n0,0,50,200,12,12,7500,0,30,0,0,0,nan,nan,nan,0,1,\a\x1b[2J\n");
  expect_error(path("bell.csv"), "line 2", "field 'gain': not a number: '\\x07\\x1B[2J'");
}

}  // namespace
}  // namespace rutd
