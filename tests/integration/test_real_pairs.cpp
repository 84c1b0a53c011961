// The frame checks (measurement/frame_checks.hpp) on real image pairs: the Middlebury pairs (rectified,
// measured with an ideal calibration) and OpenCV's chessboard pairs (raw, measured with the calibration
// rutd computes from them), tests/data. Neither shows a rut, so statuses such as NO_RUT are right; but
// none shows water, an obstructed lens, vegetation or a calibration that does not fit, so no condition
// may be raised but on the strips listed below with their measured cause. A check that fires on real
// texture fires on real soil. Every pair is measured in three strips (a third, a half and two thirds
// down the image).
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "geometry/stereo_calibrate.hpp"
#include "measurement/measurer.hpp"

namespace rutd {
namespace {

struct Pair {
  std::string name;
  cv::Mat left, right;
  StereoCalibration calibration;
};

std::string condition_names(std::uint8_t bits) {
  static const char* const kNames[] = {"Water",       "LeftLensObstructed", "RightLensObstructed", "LowLight",
                                       "Overexposed", "Vegetation",         "CalibrationDrift",    "DepthUncertain"};
  std::string out;
  for (int b = 0; b < 8; ++b)
    if (bits & (1U << b)) out += std::string(out.empty() ? "" : " ") + kNames[b];
  return out.empty() ? "-" : out;
}

// A rectified pair as a rig with no distortion and no rotation: focal f px, baseline chosen so the
// pair's middle disparity lies at 400 mm, the rig height rutd is configured for.
StereoCalibration ideal_calibration(cv::Size size, double f, double mid_disparity) {
  StereoCalibration c;
  c.image_size = size;
  c.M1 = cv::Matx33d(f, 0, 0.5 * (size.width - 1), 0, f, 0.5 * (size.height - 1), 0, 0, 1);
  c.M2 = c.M1;
  c.D1 = cv::Mat::zeros(1, 5, CV_64F);
  c.D2 = cv::Mat::zeros(1, 5, CV_64F);
  c.R = cv::Matx33d::eye();
  c.T = cv::Vec3d(-400.0 * mid_disparity / f, 0, 0);
  return c;
}

std::vector<Pair> middlebury_pairs() {
  struct Entry {
    const char* name;
    const char* left;
    const char* right;
  };
  const Entry entries[] = {{"cone", "im2.png", "im6.png"},
                           {"Cloth3", "view1.png", "view5.png"},
                           {"Reindeer", "view1.png", "view5.png"},
                           {"Wood2", "view1.png", "view5.png"}};
  std::vector<Pair> out;
  for (const Entry& e : entries) {
    const std::string dir = std::string(RUTD_TEST_DATA_DIR) + "/middlebury/" + e.name + "/";
    Pair p{std::string("middlebury/") + e.name,
           cv::imread(dir + e.left, cv::IMREAD_GRAYSCALE),
           cv::imread(dir + e.right, cv::IMREAD_GRAYSCALE),
           {}};
    std::ifstream range(dir + "drange.txt");
    std::string line;
    int dmin = 0, dmax = 0;
    while (std::getline(range, line)) {
      if (line.rfind("dmin=", 0) == 0) dmin = std::stoi(line.substr(5));
      if (line.rfind("dmax=", 0) == 0) dmax = std::stoi(line.substr(5));
    }
    EXPECT_FALSE(p.left.empty()) << dir;
    EXPECT_GT(dmax, dmin) << dir;
    p.calibration = ideal_calibration(p.left.size(), 700.0, 0.5 * (dmin + dmax));
    out.push_back(std::move(p));
  }
  return out;
}

std::vector<Pair> chessboard_pairs() {
  std::vector<std::string> left, right;
  read_image_list(std::string(RUTD_TEST_DATA_DIR) + "/chessboard-stereo/stereo_calib.xml", left, right);
  const StereoCalibration calibration = calibrate_stereo(left, right, {{9, 6}, 25.0}).calibration;
  std::vector<Pair> out;
  for (std::size_t i = 0; i < left.size(); ++i) {
    Pair p{"chessboard/" + left[i].substr(left[i].find_last_of('/') + 1), cv::imread(left[i], cv::IMREAD_GRAYSCALE),
           cv::imread(right[i], cv::IMREAD_GRAYSCALE), calibration};
    out.push_back(std::move(p));
  }
  return out;
}

struct Tally {
  int measured = 0;
  int strips_with[8] = {};  // strips raising each condition bit
};

void measure_pairs(const std::vector<Pair>& pairs, Tally& t) {
  for (const Pair& p : pairs) {
    ASSERT_FALSE(p.left.empty() || p.right.empty()) << p.name;
    for (const double at : {1.0 / 3.0, 0.5, 2.0 / 3.0}) {
      MeasurerConfig config;
      const int rows = default_strip(p.left.size()).rows;
      config.strip.first_row = static_cast<int>(at * p.left.rows) - rows / 2;
      StereoMeasurer measurer(p.calibration, config);
      const RutMeasurement m = measurer.measure(p.left, p.right);
      ++t.measured;
      std::printf("%-26s row %3d  status %-18s  conditions %s  vd %.2f px  obstructed %.2f/%.2f\n", p.name.c_str(),
                  *config.strip.first_row, std::string(to_string(m.status)).c_str(),
                  condition_names(m.conditions).c_str(), m.vertical_disparity_px, m.obstructed_left,
                  m.obstructed_right);
      for (int b = 0; b < 8; ++b) t.strips_with[b] += (m.conditions >> b) & 1U;
    }
  }
}

// Each condition at most on the strips listed (DepthUncertain is about the depth of what was taken for
// a rut, none being there: not counted). The budgets are the false alarms measured now, so that none
// grows; they are to fall to 0 (issue: no condition on real pairs). Measured causes:
// - Vegetation (textured in both views, unmatched): on the Middlebury scenes the unmatched blocks are
//   occlusions and depth edges (cones, reindeer, cloth folds); on the chessboard pairs most of the
//   strip goes unmatched (the board's repeated squares).
// - Lens obstruction: a block unmatched whose right view, at the strip's disparity, is another part of
//   a scene in depth (before the check looked at each block's own disparity and left matched blocks
//   alone: Middlebury 5 of 12 strips, chessboard 36 of 39).
// - CalibrationDrift: the vertical search locked onto a repeated pattern (offsets at the search's end,
//   8 px, on calibrated or ideal pairs).
// - Overexposed: chessboard pair 05's white squares are clipped on over 15 % of the strip (true).
struct Budget {
  RutCondition bit;
  int middlebury, chessboard;
};
constexpr Budget kBudgets[] = {
    {kConditionWater, 0, 0},           {kConditionLeftObstructed, 3, 9}, {kConditionRightObstructed, 0, 16},
    {kConditionLowLight, 0, 0},        {kConditionOverexposed, 0, 1},    {kConditionVegetation, 7, 35},
    {kConditionCalibrationDrift, 1, 8}};

int bit_index(RutCondition bit) {
  int i = 0;
  while (!((1U << i) & bit)) ++i;
  return i;
}

TEST(RealPairs, MiddleburyConditionsWithinTheirListedCauses) {
  Tally t;
  measure_pairs(middlebury_pairs(), t);
  ASSERT_EQ(t.measured, 12);
  for (const Budget& b : kBudgets)
    EXPECT_LE(t.strips_with[bit_index(b.bit)], b.middlebury) << condition_names(b.bit) << " of 12 strips";
}

TEST(RealPairs, ChessboardConditionsWithinTheirListedCauses) {
  Tally t;
  measure_pairs(chessboard_pairs(), t);
  ASSERT_EQ(t.measured, 39);
  for (const Budget& b : kBudgets)
    EXPECT_LE(t.strips_with[bit_index(b.bit)], b.chessboard) << condition_names(b.bit) << " of 39 strips";
}

}  // namespace
}  // namespace rutd
