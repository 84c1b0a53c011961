// reduce_to_cross_section on synthetic strips, and strip -> cross-section -> extract_rut end to end.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>

#include <gtest/gtest.h>

#include "rut/extract.hpp"
#include "test_rut_profile.hpp"

namespace rutd {
namespace {

using test::RutShape;
using test::View;

constexpr float kNaNf = std::numeric_limits<float>::quiet_NaN();

// Rows x cols points on the plane Z = z0 + slope X, X = x_start + j * spacing (not bin-aligned).
cv::Mat plane_strip(int rows, int cols, double x_start, double spacing, double z0, double slope) {
  cv::Mat xyz(rows, cols, CV_32FC3);
  for (int r = 0; r < rows; ++r) {
    for (int j = 0; j < cols; ++j) {
      const double x = x_start + j * spacing;
      xyz.at<cv::Vec3f>(r, j) = cv::Vec3f(float(x), float(r), float(z0 + slope * x));
    }
  }
  return xyz;
}

TEST(ReduceToCrossSection, PlaneGivesPlaneOnABinAlignedGrid) {
  const double slope = -0.1;
  const cv::Mat xyz = plane_strip(8, 500, -101.3, 0.37, 1500.0, slope);
  RutConfig params;
  params.bin_mm = 2.0;
  CrossSection c;
  reduce_to_cross_section(xyz, params, c);
  EXPECT_DOUBLE_EQ(c.dx_mm, 2.0);
  EXPECT_DOUBLE_EQ(c.x0_mm, -102.0);  // bin nearest to the smallest X (-101.3)
  const double x_last = -101.3 + 499 * 0.37;
  EXPECT_EQ(int(c.z_mm.size()), int(std::lround(x_last / 2.0)) + 51 + 1);
  long total = 0;
  for (std::size_t b = 0; b < c.z_mm.size(); ++b) {
    total += c.count[b];
    if (c.count[b] == 0) {
      EXPECT_TRUE(std::isnan(c.z_mm[b]));
      continue;
    }
    // Points lie within half a bin of its centre, so the mean Z is within |slope| * dx / 2.
    const double x = c.x0_mm + double(b) * c.dx_mm;
    EXPECT_NEAR(c.z_mm[b], 1500.0 + slope * x, std::abs(slope) * 1.0 + 1e-3) << "bin " << b;
  }
  EXPECT_EQ(total, 8 * 500);
}

TEST(ReduceToCrossSection, TrimmedMeanRejectsOutliers) {
  cv::Mat xyz = plane_strip(8, 200, 0.0, 1.0, 1500.0, 0.0);
  std::mt19937 rng(4);
  std::uniform_int_distribution<int> row(0, 7);
  for (int j = 0; j < xyz.cols; ++j) {
    xyz.at<cv::Vec3f>(row(rng), j)[2] += 80.0f;  // one gross mismatch per column
    xyz.at<cv::Vec3f>(row(rng), j)[2] -= 60.0f;  // and one the other way (may hit the same row)
  }
  CrossSection c;
  reduce_to_cross_section(xyz, RutConfig{}, c);
  ASSERT_EQ(c.z_mm.size(), 200u);
  for (std::size_t b = 0; b < c.z_mm.size(); ++b) {
    EXPECT_EQ(c.count[b], 8);
    EXPECT_NEAR(c.z_mm[b], 1500.0, 1e-3) << "bin " << b;
  }
}

TEST(ReduceToCrossSection, InvalidPointsAreSkipped) {
  cv::Mat xyz = plane_strip(4, 100, 0.0, 1.0, 1000.0, 0.0);
  for (int j = 0; j < 50; ++j) xyz.at<cv::Vec3f>(0, j)[2] = kNaNf;
  for (int j = 0; j < 50; ++j) xyz.at<cv::Vec3f>(1, j)[0] = kNaNf;
  for (int j = 0; j < 50; ++j) xyz.at<cv::Vec3f>(2, j)[2] = -5.0f;  // behind the camera
  for (int r = 0; r < 4; ++r) xyz.at<cv::Vec3f>(r, 99) = cv::Vec3f(kNaNf, kNaNf, kNaNf);
  CrossSection c;
  reduce_to_cross_section(xyz, RutConfig{}, c);
  ASSERT_EQ(c.z_mm.size(), 99u);  // the column at X = 99 is entirely invalid
  EXPECT_EQ(c.count[0], 1);
  EXPECT_EQ(c.count[60], 4);
  EXPECT_NEAR(c.z_mm[0], 1000.0, 1e-9);
}

TEST(ReduceToCrossSection, DegenerateInputsGiveNoBins) {
  CrossSection c;
  reduce_to_cross_section(cv::Mat(), RutConfig{}, c);
  EXPECT_TRUE(c.z_mm.empty());
  reduce_to_cross_section(cv::Mat(4, 4, CV_32FC1, cv::Scalar(1.0)), RutConfig{}, c);
  EXPECT_TRUE(c.z_mm.empty());
  reduce_to_cross_section(cv::Mat(4, 4, CV_32FC3, cv::Scalar(kNaNf, kNaNf, kNaNf)), RutConfig{}, c);
  EXPECT_TRUE(c.z_mm.empty());
  RutWorkspace ws;
  EXPECT_EQ(extract_rut(c, RutConfig{}, ws).status, RutStatus::TooFewPoints);
}

TEST(ReduceToCrossSection, FarOutlierCannotBlowUpTheGrid) {
  cv::Mat xyz = plane_strip(4, 600, -300.0, 1.0, 1500.0, 0.0);
  xyz.at<cv::Vec3f>(0, 0) = cv::Vec3f(1e7f, 0.0f, 1500.0f);  // absurd reprojection
  CrossSection c;
  reduce_to_cross_section(xyz, RutConfig{}, c);
  EXPECT_LE(c.z_mm.size(), 4001u);
  EXPECT_LE(c.x0_mm, -299.0);  // the real data are kept
}

TEST(ReduceToCrossSection, SteadyStateDoesNotReallocate) {
  const cv::Mat xyz = plane_strip(16, 640, -320.0, 1.0, 1500.0, 0.05);
  CrossSection c;
  reduce_to_cross_section(xyz, RutConfig{}, c);
  const void* ptrs[] = {c.z_mm.data(),      c.count.data(),         c.scratch_z.data(),
                        c.scratch_y.data(), c.scratch_slope.data(), c.scratch_offset.data()};
  reduce_to_cross_section(xyz, RutConfig{}, c);
  EXPECT_EQ(ptrs[0], c.z_mm.data());
  EXPECT_EQ(ptrs[1], c.count.data());
  EXPECT_EQ(ptrs[2], c.scratch_z.data());
  EXPECT_EQ(ptrs[3], c.scratch_y.data());
  EXPECT_EQ(ptrs[4], c.scratch_slope.data());
  EXPECT_EQ(ptrs[5], c.scratch_offset.data());
}

// A pinhole strip of a rig pitched against the ground: row r looks along Y = t Z (t = (r - cy) / f) at
// terrain Z = Z_ground(X) + slope Y, so it meets the surface at Z_ground(X) / (1 - slope t), and the
// rut's bottom further along Y than the ground beside it. Strips of 48 rows (t spans 0.087, f = 550 px)
// centred a quarter of the image above, on and below the principal row, the ground sloping 6 degrees
// along travel either way, 0.3 mm of noise: the depth is the terrain's within 0.15 mm; unlevelled it
// is 0.9-1.2 mm off (2.6 % of 40 mm) a quarter off the principal row.
TEST(ReduceToCrossSection, APitchedRigReadsTheSameDepthOnEveryRow) {
  RutShape s;
  const View v;
  constexpr int kRows = 48, kCols = 640;
  std::mt19937 rng(12);
  std::normal_distribution<double> noise(0.0, 0.3);
  int checked = 0, off_row_bias = 0;
  for (double pitch_deg : {6.0, -6.0}) {
    const double slope = std::tan(pitch_deg * test::kPi / 180.0);
    for (double t0 : {-0.22, 0.0, 0.22}) {
      cv::Mat xyz(kRows, kCols, CV_32FC3);
      for (int r = 0; r < kRows; ++r) {
        const double t = t0 + (r - (kRows - 1) / 2.0) / 550.0;
        for (int j = 0; j < kCols; ++j) {
          const double x = -320.0 + j;
          const double z = test::z_at_x(s, v, x) / (1.0 - slope * t) + noise(rng);
          xyz.at<cv::Vec3f>(r, j) = cv::Vec3f(float(x), float(t * z), float(z));
        }
      }
      CrossSection c;
      reduce_to_cross_section(xyz, RutConfig{}, c);
      EXPECT_NEAR(c.along_slope, slope, 0.01) << "pitch " << pitch_deg << " t " << t0;
      EXPECT_NEAR(c.ray_elevation, t0, 1e-3);
      RutWorkspace ws;
      const RutMeasurement m = extract_rut(c, RutConfig{}, ws);
      ASSERT_EQ(m.status, RutStatus::Ok) << to_string(m.status);
      EXPECT_NEAR(m.depth_mm, s.depth, 0.15) << "pitch " << pitch_deg << " t " << t0;
      EXPECT_NEAR(m.left_pile_mm, s.left_pile, 0.15) << "pitch " << pitch_deg << " t " << t0;
      // The same section unlevelled: the bias this takes out.
      c.along_slope = 0.0;
      const RutMeasurement raw = extract_rut(c, RutConfig{}, ws);
      if (t0 != 0.0) off_row_bias += std::abs(raw.depth_mm - s.depth) > 0.8;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 6);
  EXPECT_EQ(off_row_bias, 4);
}

// Strip of noisy points with outliers (rolled terrain, so X spacing is uneven) -> reduce -> extract.
class StripEndToEnd : public ::testing::TestWithParam<double> {};

TEST_P(StripEndToEnd, MeasuresTheRut) {
  RutShape s;
  s.depth = 50.0;
  s.right_pile = 22.0;
  View v;
  v.roll_deg = GetParam();
  constexpr int kRows = 16, kCols = 900;
  cv::Mat xyz = test::make_strip(s, v, -330.0, 0.75, kCols, kRows, 1.5, 21);
  std::mt19937 rng(8);
  std::uniform_int_distribution<int> row(0, kRows - 1), col(0, kCols - 1);
  for (int i = 0; i < kRows * kCols / 30; ++i) {
    xyz.at<cv::Vec3f>(row(rng), col(rng))[2] += (i % 2 ? 40.0f : -40.0f);  // ~3 % mismatches
  }
  CrossSection c;
  reduce_to_cross_section(xyz, RutConfig{}, c);
  RutWorkspace ws;
  const RutMeasurement m = extract_rut(c, RutConfig{}, ws);
  ASSERT_EQ(m.status, RutStatus::Ok) << to_string(m.status);
  EXPECT_NEAR(m.depth_mm, s.depth, 0.2);
  EXPECT_NEAR(m.width_mm, s.width(), 2.0);
  EXPECT_NEAR(m.area_mm2, s.area(), 0.01 * s.area());
  EXPECT_NEAR(m.left_pile_mm, s.left_pile, 0.5);
  EXPECT_NEAR(m.right_pile_mm, s.right_pile, 0.5);
  EXPECT_NEAR(m.ground_slope_deg, v.slope_deg(), 0.05);
  EXPECT_NEAR(m.center_x_mm, v.center_x(s), 1.0);
  EXPECT_GT(m.quality, 0.5);
}

INSTANTIATE_TEST_SUITE_P(Roll, StripEndToEnd, ::testing::Values(0.0, 8.0, -3.0));

TEST(ReduceToCrossSection, PrintsTimePerStrip) {
  const cv::Mat xyz = test::make_strip(RutShape{}, View{}, -320.0, 1.0, 640, 32, 1.0, 3);
  CrossSection c;
  reduce_to_cross_section(xyz, RutConfig{}, c);
  const CrossSection first = c;
  constexpr int kRuns = 100;
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < kRuns; ++i) reduce_to_cross_section(xyz, RutConfig{}, c);
  const auto t1 = std::chrono::steady_clock::now();
  std::printf("reduce_to_cross_section, 640 x 32 points: %.1f us per strip\n",
              std::chrono::duration<double, std::micro>(t1 - t0).count() / kRuns);
  // The timed calls reused `c`: they must give the first call's section, bin for bin.
  ASSERT_EQ(c.z_mm.size(), 640u);
  EXPECT_EQ(c.count, first.count);
  EXPECT_EQ(c.x0_mm, first.x0_mm);
  int differing = 0, valid = 0;
  for (std::size_t i = 0; i < c.z_mm.size(); ++i) {
    valid += !std::isnan(first.z_mm[i]);
    differing += !(c.z_mm[i] == first.z_mm[i] || (std::isnan(c.z_mm[i]) && std::isnan(first.z_mm[i])));
  }
  EXPECT_EQ(differing, 0);
  EXPECT_GT(valid, 320) << "a dense strip fills most bins";
}

}  // namespace
}  // namespace rutd
