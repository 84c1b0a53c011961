// DIC refinement against images with KNOWN fractional disparities (known_disparity.hpp).
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "engines/disparity_engine.hpp"
#include "engines/engine_factory.hpp"
#include "known_disparity.hpp"
#include "refinement/dic_refine.hpp"
#include "test_support.hpp"

namespace rutd {
namespace {

using namespace known_disparity;

const cv::Size kStrip(320, 48);

TEST(DicRefine, RemovesSgbmPixelLockingBias) {
  auto sgbm = make_cpu_engine(EngineKind::Sgbm);
  DicWorkspace ws;
  DicConfig params;
  double worst_sgbm = 0.0, worst_dic = 0.0;
  std::printf("   d_true   sgbm_bias  sgbm_rms   dic_bias   dic_rms  refined  rejected  iters\n");
  for (int tenth = 1; tenth <= 9; ++tenth) {
    const double d_true = 24.0 + tenth / 10.0;
    const Pair pair = render_pair(d_true, 0.0, kStrip, 100 + tenth);
    cv::Mat disparity;
    sgbm->compute(pair.left, pair.right, {16, 16}, disparity);
    const Error before = error_of(disparity, d_true, 0.0, 32);
    const DicStats stats = refine_disparity_dic(pair.left, pair.right, disparity, params, ws);
    const Error after = error_of(disparity, d_true, 0.0, 32);
    std::printf("  %7.2f  %+9.4f  %8.4f  %+9.4f  %8.4f  %7d  %8d  %5.2f\n", d_true, before.mean, before.rms, after.mean,
                after.rms, stats.refined, stats.rejected, stats.mean_iterations);
    worst_sgbm = std::max(worst_sgbm, std::abs(before.mean));
    worst_dic = std::max(worst_dic, std::abs(after.mean));
    EXPECT_LT(std::abs(after.mean), 0.02) << "d = " << d_true;
    EXPECT_LT(after.rms, 0.05) << "d = " << d_true;
    EXPECT_GT(after.count, 0.9 * before.count) << "d = " << d_true;
  }
  std::printf("worst |bias|: sgbm %.4f px, dic %.4f px\n", worst_sgbm, worst_dic);
  EXPECT_GT(worst_sgbm, 0.15);  // the locking is there to be removed (measured 0.22 px at d = 24.6)
}

TEST(DicRefine, FollowsSlopedDisparity) {
  const double d0 = 20.3, slope = 0.12;  // a steep rut wall: 0.12 px of disparity per px
  const Pair pair = render_pair(d0, slope, kStrip, 7);
  auto sgbm = make_cpu_engine(EngineKind::Sgbm);
  cv::Mat engine;
  sgbm->compute(pair.left, pair.right, {16, 48}, engine);
  const Error before = error_of(engine, d0, slope, 64);
  DicWorkspace ws;
  for (bool first_order : {false, true}) {
    cv::Mat disparity = engine.clone();
    DicConfig params;
    params.first_order = first_order;
    const DicStats stats = refine_disparity_dic(pair.left, pair.right, disparity, params, ws);
    const Error after = error_of(disparity, d0, slope, 64);
    std::printf("slope %.2f first_order=%d: sgbm bias %+.4f rms %.4f -> dic bias %+.4f rms %.4f (%d px, %d rejected)\n",
                slope, first_order, before.mean, before.rms, after.mean, after.rms, stats.refined, stats.rejected);
    if (first_order) {
      EXPECT_LT(std::abs(after.mean), 0.02);
      EXPECT_LT(after.rms, 0.06);
      EXPECT_GT(after.count, 0.9 * before.count);
    }
  }
}

TEST(DicRefine, RejectsLowTexture) {
  // Left half textured, right half flat grey with sensor noise only.
  const double d_true = 22.5;
  Pair pair = render_pair(d_true, 0.0, kStrip, 3);
  std::mt19937 rng(5);
  std::normal_distribution<double> gauss(100.0, 0.7);
  const int half = kStrip.width / 2;
  for (int y = 0; y < kStrip.height; ++y) {
    for (int x = half - 30; x < kStrip.width; ++x) {
      if (x >= half) pair.left.at<std::uint8_t>(y, x) = cv::saturate_cast<std::uint8_t>(gauss(rng));
      pair.right.at<std::uint8_t>(y, x) = cv::saturate_cast<std::uint8_t>(gauss(rng));
    }
  }
  cv::Mat disparity(kStrip, CV_32FC1, cv::Scalar(d_true + 0.3));
  DicWorkspace ws;
  const DicConfig params;
  const DicStats stats = refine_disparity_dic(pair.left, pair.right, disparity, params, ws);
  int textured = 0, textured_ok = 0, flat = 0, flat_ok = 0;
  for (int y = 0; y < kStrip.height; ++y) {
    for (int x = 0; x < kStrip.width; ++x) {
      const bool valid = std::isfinite(disparity.at<float>(y, x));
      if (x >= 40 && x < half - 60) {  // fully textured windows whose match lies in the textured right part
        ++textured;
        textured_ok += valid && std::abs(disparity.at<float>(y, x) - d_true) < 0.1;
      } else if (x > half + params.half_window) {
        ++flat;
        flat_ok += valid;
      }
    }
  }
  std::printf("textured: %d of %d refined; flat: %d of %d refined; stats %d refined %d rejected\n", textured_ok,
              textured, flat_ok, flat, stats.refined, stats.rejected);
  EXPECT_GT(textured_ok, 0.95 * textured);
  EXPECT_EQ(flat_ok, 0);
  EXPECT_EQ(stats.refined + stats.rejected, kStrip.area());
}

TEST(DicRefine, RejectsStartFarFromTheMatch) {
  const double d_true = 25.0;
  const Pair pair = render_pair(d_true, 0.0, kStrip, 11);
  cv::Mat disparity(kStrip, CV_32FC1, cv::Scalar(d_true + 5.0));
  DicWorkspace ws;
  const DicStats stats = refine_disparity_dic(pair.left, pair.right, disparity, DicConfig{}, ws);
  std::printf("start 5 px off: %d refined, %d rejected\n", stats.refined, stats.rejected);
  EXPECT_LT(stats.refined, 0.02 * kStrip.area());
}

TEST(DicRefine, StepKeepsOnlyTheGrid) {
  const double d_true = 21.25;
  const Pair pair = render_pair(d_true, 0.0, kStrip, 13);
  cv::Mat disparity(kStrip, CV_32FC1, cv::Scalar(d_true - 0.4));
  DicConfig params;
  params.step = 4;
  DicWorkspace ws;
  const DicStats stats = refine_disparity_dic(pair.left, pair.right, disparity, params, ws);
  int off_grid_valid = 0;
  for (int y = 0; y < kStrip.height; ++y) {
    for (int x = 0; x < kStrip.width; ++x) {
      if ((x % 4 != 0 || y % 4 != 0) && std::isfinite(disparity.at<float>(y, x))) ++off_grid_valid;
    }
  }
  EXPECT_EQ(off_grid_valid, 0);
  EXPECT_EQ(stats.refined + stats.rejected, (kStrip.width / 4) * (kStrip.height / 4));
  EXPECT_GT(stats.refined, 0.7 * (kStrip.width / 4) * (kStrip.height / 4));
  EXPECT_LT(std::abs(error_of(disparity, d_true, 0.0, 0).mean), 0.02);
}

// The refinement processes window columns in groups of four and shares samples between neighbouring
// windows, so window widths that fill the groups differently, steps that leave fewer or more shared
// columns, restricted rows and windows clipped by the strip's right end each take their own branch:
// all against the known sloped disparity.
TEST(DicRefine, WindowShapesStepsRowsAndBordersMeetTheTruth) {
  const double d0 = 20.3, slope = 0.05;
  const Pair pair = render_pair(d0, slope, kStrip, 17);
  auto sgbm = make_cpu_engine(EngineKind::Sgbm);
  cv::Mat engine;
  sgbm->compute(pair.left, pair.right, {16, 48}, engine);
  struct Shape {
    int half_window, half_height;
  };
  DicWorkspace ws;  // shared: the tables must follow the shape from call to call
  for (const Shape shape : {Shape{2, 0}, Shape{3, 6}, Shape{4, 4}, Shape{7, 3}, Shape{9, 2}, Shape{15, 1}}) {
    for (const int step : {1, 3}) {
      DicConfig params;
      params.half_window = shape.half_window;
      params.half_height = shape.half_height;
      params.step = step;
      params.row_step = 2;
      params.row_begin = 9;
      params.row_end = 41;
      cv::Mat disparity = engine.clone();
      const DicStats stats = refine_disparity_dic(pair.left, pair.right, disparity, params, ws);
      const Error all = error_of(disparity, d0, slope, 64);
      // Windows clipped by the right end of the strip.
      const Error border = error_of(disparity.colRange(kStrip.width - shape.half_window, kStrip.width),
                                    d0 + slope * (kStrip.width - shape.half_window), slope, 0);
      int outside = 0;  // valid pixels off the grid or outside the rows
      for (int y = 0; y < kStrip.height; ++y) {
        for (int x = 0; x < kStrip.width; ++x) {
          const bool grid = y >= 9 && y < 41 && y % 2 == 0 && x % step == 0;
          outside += !grid && std::isfinite(disparity.at<float>(y, x));
        }
      }
      std::printf(
          "h %2d hh %d step %d: bias %+.4f rms %.4f (%d px), right border bias %+.4f rms %.4f (%d px), %d "
          "refined %d rejected, %.2f iterations\n",
          shape.half_window, shape.half_height, step, all.mean, all.rms, all.count, border.mean, border.rms,
          border.count, stats.refined, stats.rejected, stats.mean_iterations);
      const std::string what = "h " + std::to_string(shape.half_window) + " step " + std::to_string(step);
      EXPECT_EQ(outside, 0) << what;
      EXPECT_LT(std::abs(all.mean), 0.02) << what;
      EXPECT_LT(all.rms, 0.06) << what;
      const int grid_pixels = 16 * ((kStrip.width - 64 + step - 1) / step);
      EXPECT_GT(all.count, 0.9 * grid_pixels) << what;
      EXPECT_GT(border.count, 0) << what;
      // h = 2 clips to windows of 3 columns there, which the noise alone moves by ~0.2 px rms.
      if (shape.half_window >= 3) {
        EXPECT_LT(std::abs(border.mean), 0.05) << what;
        EXPECT_LT(border.rms, 0.1) << what;
      }
    }
  }
}

// Strip mode: one window per column over the measured rows [7, 55) of a 62-row strip, on disparity
// sloping across and down the strip. Every measured row gets the column's fitted d(y); the margin rows
// stay NaN.
TEST(DicRefine, ColumnWindowsFitTheDisparityDownEachColumn) {
  const cv::Size strip(320, 62);
  const int row_begin = 7, row_end = 55;
  auto sgbm = make_cpu_engine(EngineKind::Sgbm);
  DicWorkspace ws;
  int cases = 0;
  for (const double slope : {0.0, 0.08}) {
    for (const double slope_y : {0.0, -0.04, 0.06}) {
      const double d0 = 20.35 + 0.3 * cases;
      const Pair pair = render_pair(d0, slope, strip, 23 + cases, 0.7, slope_y);
      cv::Mat disparity;
      sgbm->compute(pair.left, pair.right, {16, 48}, disparity);
      DicConfig params;
      params.column_windows = true;
      params.row_begin = row_begin;
      params.row_end = row_end;
      const DicStats stats = refine_disparity_dic(pair.left, pair.right, disparity, params, ws);
      Error e;
      int margin_valid = 0, columns = 0;
      for (int x = 64; x < strip.width; ++x) {
        bool column_valid = true;
        for (int y = 0; y < strip.height; ++y) {
          const float d = disparity.at<float>(y, x);
          if (y < row_begin || y >= row_end) {
            margin_valid += std::isfinite(d);
            continue;
          }
          column_valid = column_valid && std::isfinite(d);
          if (!std::isfinite(d)) continue;
          const double err = d - (d0 + slope * x + slope_y * y);
          e.mean += err;
          e.rms += err * err;
          ++e.count;
        }
        columns += column_valid;
      }
      e.mean /= std::max(1, e.count);
      e.rms = std::sqrt(e.rms / std::max(1, e.count));
      std::printf("slope %.2f slope_y %+.2f: bias %+.4f rms %.4f, %d of %d columns, %d refined %d rejected, %.2f it\n",
                  slope, slope_y, e.mean, e.rms, columns, strip.width - 64, stats.refined, stats.rejected,
                  stats.mean_iterations);
      const std::string what = "slope " + std::to_string(slope) + " slope_y " + std::to_string(slope_y);
      EXPECT_EQ(margin_valid, 0) << what;
      EXPECT_GT(columns, 0.95 * (strip.width - 64)) << what;
      EXPECT_EQ(e.count, columns * (row_end - row_begin)) << what;  // whole columns or nothing
      EXPECT_LT(std::abs(e.mean), 0.01) << what;
      EXPECT_LT(e.rms, 0.03) << what;
      ++cases;
    }
  }
  EXPECT_EQ(cases, 6);
}

// A column whose engine disparities are mostly missing has no start: it is rejected whole, and the
// columns beside it are still refined.
TEST(DicRefine, ColumnWindowsNeedAQuarterOfTheColumnValid) {
  const cv::Size strip(320, 48);
  const double d_true = 22.4;
  const Pair pair = render_pair(d_true, 0.0, strip, 29);
  cv::Mat disparity(strip, CV_32FC1, cv::Scalar(d_true - 0.45));
  for (int y = 0; y < strip.height; ++y) {
    if (y % 5 != 0) disparity.at<float>(y, 100) = std::numeric_limits<float>::quiet_NaN();  // 10 of 48 valid
    if (y % 3 != 0) disparity.at<float>(y, 150) = std::numeric_limits<float>::quiet_NaN();  // 16 of 48 valid
  }
  DicConfig params;
  params.column_windows = true;
  DicWorkspace ws;
  refine_disparity_dic(pair.left, pair.right, disparity, params, ws);
  int valid_100 = 0, valid_150 = 0;
  for (int y = 0; y < strip.height; ++y) {
    valid_100 += std::isfinite(disparity.at<float>(y, 100));
    valid_150 += std::isfinite(disparity.at<float>(y, 150));
  }
  EXPECT_EQ(valid_100, 0);
  EXPECT_EQ(valid_150, strip.height);
  EXPECT_NEAR(disparity.at<float>(20, 150), d_true, 0.05);
  EXPECT_NEAR(disparity.at<float>(20, 101), d_true, 0.05);
}

// Low texture under noise (snow under gain): the texture's RMS is 3 grey levels against a noise of 2,
// so a correct column window correlates at about 0.7 and min_zncc (0.8) alone rejects nearly all. With the
// noise known (DicConfig::noise_grey), the residual a correct match leaves is what that noise explains:
// the windows are kept, at the truth. A right strip of another texture (no match anywhere) stays
// rejected, and so do the windows when the noise given is far under the real one.
struct LowTextureCase {
  int columns = 0, refined = 0, within = 0;
};

LowTextureCase refine_low_texture(double noise_grey, bool same_texture, double d_true) {
  const cv::Size strip(320, 48);
  const double noise = 2.0;
  auto waves = random_texture(41);
  for (Wave& w : waves) w.amplitude *= 3.0 / 40.0;
  const cv::Mat left = render(waves, strip, 1.0, 0.0, noise, 42);
  auto other = random_texture(77);
  for (Wave& w : other) w.amplitude *= 3.0 / 40.0;
  const cv::Mat right = render(same_texture ? waves : other, strip, 1.0, d_true, noise, 43);
  cv::Mat disparity(strip, CV_32FC1, cv::Scalar(d_true + 0.3));
  DicConfig params;
  params.column_windows = true;
  params.noise_grey = noise_grey;
  DicWorkspace ws;
  refine_disparity_dic(left, right, disparity, params, ws);
  LowTextureCase c;
  for (int x = 40; x < strip.width - 10; ++x) {
    ++c.columns;
    const float d = disparity.at<float>(strip.height / 2, x);
    c.refined += std::isfinite(d);
    c.within += std::isfinite(d) && std::abs(d - d_true) < 0.25;
  }
  return c;
}

TEST(DicRefine, NoiseJudgesTheCorrelationOfLowTextureWindows) {
  const double d_true = 22.4;
  const LowTextureCase alone = refine_low_texture(0.0, true, d_true);
  const LowTextureCase judged = refine_low_texture(2.0, true, d_true);
  const LowTextureCase no_match = refine_low_texture(2.0, false, d_true);
  const LowTextureCase too_little = refine_low_texture(0.5, true, d_true);
  std::printf(
      "of %d columns: min_zncc alone %d refined; noise judged %d (%d within 0.25 px); another texture %d; "
      "noise given as 0.5 %d\n",
      judged.columns, alone.refined, judged.refined, judged.within, no_match.refined, too_little.refined);
  // Measured: 5, 175 (174 within), 0 and 5 of 270.
  EXPECT_LT(alone.refined, 0.05 * alone.columns);
  EXPECT_GT(judged.within, 0.55 * judged.columns);
  EXPECT_GE(judged.within, judged.refined - judged.columns / 100);  // what it keeps is at the truth
  EXPECT_LT(no_match.refined, 0.02 * no_match.columns);
  EXPECT_LE(too_little.refined, alone.refined + too_little.columns / 100);
}

TEST(DicRefine, WideVectorsGiveTheSameResultsBitForBit) {
  // On x86 CPUs with AVX2 the samples are taken 8 lanes at a time; the 4-lane path must give the same
  // disparities to the bit (elsewhere both runs take the 4-lane path).
  const Pair pair = render_pair(20.3, 0.05, kStrip, 19);
  auto sgbm = make_cpu_engine(EngineKind::Sgbm);
  cv::Mat engine;
  sgbm->compute(pair.left, pair.right, {16, 48}, engine);
  for (const int half_window : {2, 5, 9}) {
    DicConfig params;
    params.half_window = half_window;
    cv::Mat wide = engine.clone(), narrow = engine.clone();
    DicWorkspace ws;
    const DicStats a = refine_disparity_dic(pair.left, pair.right, wide, params, ws);
    params.allow_avx2 = false;
    const DicStats b = refine_disparity_dic(pair.left, pair.right, narrow, params, ws);
    EXPECT_EQ(a.refined, b.refined) << half_window;
    EXPECT_EQ(a.mean_iterations, b.mean_iterations) << half_window;
    EXPECT_EQ(std::memcmp(wide.data, narrow.data, wide.total() * wide.elemSize()), 0) << half_window;
  }
}

}  // namespace
}  // namespace rutd
