// StereoGeometry against a rig made of known matrices (distortion, slightly misaligned cameras): points
// are projected into the raw images with cv::projectPoints, independently of the rectification code,
// and must come back on equal rows and at their 3D position. Also the band estimate for the supported
// camera heights and baselines.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "engines/disparity_engine.hpp"
#include "geometry/stereo_geometry.hpp"
#include "measurement/band_estimate.hpp"

namespace rutd {
namespace {

StereoCalibration distorted_rig() {
  StereoCalibration c;
  c.image_size = cv::Size(1280, 960);
  c.M1 = cv::Matx33d(1100.0, 0.0, 642.3, 0.0, 1098.0, 478.1, 0.0, 0.0, 1.0);
  c.D1 = (cv::Mat_<double>(1, 5) << -0.21, 0.08, 0.0007, -0.0005, -0.01);
  c.M2 = cv::Matx33d(1105.0, 0.0, 636.8, 0.0, 1103.0, 483.6, 0.0, 0.0, 1.0);
  c.D2 = (cv::Mat_<double>(1, 5) << -0.19, 0.06, -0.0004, 0.0006, -0.008);
  cv::Mat r;
  cv::Rodrigues(cv::Vec3d(0.004, -0.008, 0.003), r);
  c.R = cv::Matx33d(r);
  c.T = cv::Vec3d(-60.0, 0.4, 0.9);
  return c;
}

StereoCalibration ideal_rig(double focal, double baseline) {
  StereoCalibration c;
  c.image_size = cv::Size(1280, 960);
  c.M1 = cv::Matx33d(focal, 0.0, 639.5, 0.0, focal, 479.5, 0.0, 0.0, 1.0);
  c.M2 = c.M1;
  c.D1 = cv::Mat::zeros(1, 5, CV_64F);
  c.D2 = cv::Mat::zeros(1, 5, CV_64F);
  c.R = cv::Matx33d::eye();
  c.T = cv::Vec3d(-baseline, 0.0, 0.0);
  return c;
}

const StripRoi kStrip{400, 64};

// A scene point chosen at a rectified left pixel (x, y) and distance z: its position in the rectified
// frame, in the left camera frame, and its raw pixel in both cameras.
struct ScenePoint {
  cv::Point2d rect_px;
  cv::Vec3d rectified;
  cv::Point2d raw_left, raw_right;
};

std::vector<ScenePoint> scene(const StereoCalibration& c, const StereoGeometry& g) {
  std::vector<ScenePoint> points;
  const double f = g.focal_px(), cx = g.P1()(0, 2), cy = g.P1()(1, 2);
  for (int row = 0; row < 2; ++row) {
    for (int i = 0; i < 16; ++i) {
      const double x = 250.0 + 60.0 * i;
      const double y = kStrip.row0 + (row == 0 ? 16.0 : 44.0);
      const double z = row == 0 ? 350.0 + 100.0 * i / 15.0 : 450.0 - 100.0 * i / 15.0;
      points.push_back({{x, y}, {(x - cx) * z / f, (y - cy) * z / f, z}, {}, {}});
    }
  }
  std::vector<cv::Point3d> in_left;
  for (const auto& p : points) in_left.emplace_back(cv::Point3d(g.R1().t() * p.rectified));
  std::vector<cv::Point2d> left, right;
  cv::Mat right_rvec;
  cv::Rodrigues(cv::Mat(c.R), right_rvec);
  cv::projectPoints(in_left, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), cv::Mat(c.M1), c.D1, left);
  cv::projectPoints(in_left, right_rvec, cv::Mat(c.T), cv::Mat(c.M2), c.D2, right);
  for (std::size_t i = 0; i < points.size(); ++i) {
    points[i].raw_left = left[i];
    points[i].raw_right = right[i];
  }
  return points;
}

TEST(StereoGeometry, PointsLandOnOneRowAndReprojectTo3d) {
  const StereoCalibration c = distorted_rig();
  const StereoGeometry g(c, kStrip);
  std::printf("alpha %.4f focal %.2f px baseline %.4f mm\n", g.alpha(), g.focal_px(), g.baseline_mm());
  EXPECT_NEAR(g.baseline_mm(), cv::norm(c.T), 1e-9);
  const auto points = scene(c, g);
  std::vector<cv::Point2d> raw_left, raw_right, left, right;
  for (const auto& p : points) {
    raw_left.push_back(p.raw_left);
    raw_right.push_back(p.raw_right);
  }
  const cv::TermCriteria exact(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-12);
  cv::undistortPoints(raw_left, left, cv::Mat(c.M1), c.D1, cv::Mat(g.R1()), cv::Mat(g.P1()), exact);
  cv::undistortPoints(raw_right, right, cv::Mat(c.M2), c.D2, cv::Mat(g.R2()), cv::Mat(g.P2()), exact);
  cv::Mat disparity(1, 1, CV_32FC1), xyz;
  double worst = 0.0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    EXPECT_NEAR(left[i].y, right[i].y, 1e-3);
    EXPECT_NEAR(left[i].x, points[i].rect_px.x, 1e-3);
    EXPECT_NEAR(left[i].y, points[i].rect_px.y, 1e-3);
    // Reproject through Q at the point's pixel (a 1-row "strip" at its row).
    const cv::Vec4d h = g.Q() * cv::Vec4d(left[i].x, left[i].y, left[i].x - right[i].x, 1.0);
    const cv::Vec3d p(h[0] / h[3], h[1] / h[3], h[2] / h[3]);
    worst = std::max(worst, cv::norm(p - points[i].rectified));
  }
  std::printf("worst 3D error through Q: %.2e mm\n", worst);
  EXPECT_LT(worst, 1e-3);
}

// Gaussian spots (sigma 2.5 px, wide enough that sampling and interpolation keep their centroid) on a dark background
// at the given raw positions, 12-bit in 16 bits.
cv::Mat spots(cv::Size size, const std::vector<cv::Point2d>& at) {
  cv::Mat image(size, CV_16UC1, cv::Scalar(320));
  for (const auto& p : at) {
    for (int y = static_cast<int>(p.y) - 14; y <= static_cast<int>(p.y) + 14; ++y) {
      for (int x = static_cast<int>(p.x) - 14; x <= static_cast<int>(p.x) + 14; ++x) {
        const double r2 = (x - p.x) * (x - p.x) + (y - p.y) * (y - p.y);
        image.at<std::uint16_t>(y, x) = cv::saturate_cast<std::uint16_t>(320 + 3700 * std::exp(-r2 / 12.5));
      }
    }
  }
  return image;
}

// Intensity centroid above the background within +-11 px (4.4 sigma) of `near`. No threshold: a
// thresholded centroid is itself biased toward whole pixels.
cv::Point2d centroid(const cv::Mat& strip, cv::Point2d near, double background) {
  double sw = 0, sx = 0, sy = 0;
  for (int y = std::max(0, static_cast<int>(near.y) - 11); y <= std::min(strip.rows - 1, static_cast<int>(near.y) + 11);
       ++y) {
    for (int x = static_cast<int>(near.x) - 11; x <= static_cast<int>(near.x) + 11; ++x) {
      const double w = strip.at<std::uint8_t>(y, x) - background;
      sw += w;
      sx += w * x;
      sy += w * y;
    }
  }
  return {sx / sw, sy / sw};
}

TEST(StereoGeometry, RectifiedImagesPutSpotsOnOneRowAndAtTheir3dPoint) {
  const StereoCalibration c = distorted_rig();
  const StereoGeometry g(c, kStrip);
  const auto points = scene(c, g);
  std::vector<cv::Point2d> raw_left, raw_right;
  for (const auto& p : points) {
    raw_left.push_back(p.raw_left);
    raw_right.push_back(p.raw_right);
  }
  cv::Mat left, right;
  g.rectify(spots(c.image_size, raw_left), spots(c.image_size, raw_right), left, right);
  ASSERT_EQ(left.type(), CV_8UC1);
  ASSERT_EQ(left.size(), cv::Size(c.image_size.width, kStrip.rows));
  // The background after the 16-bit scaling: the median, as spots cover a few percent of the strip.
  std::vector<std::uint8_t> values(left.begin<std::uint8_t>(), left.end<std::uint8_t>());
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  const double background = values[values.size() / 2];
  cv::Mat disparity(left.size(), CV_32FC1, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  for (const auto& p : points) {
    const double d = g.disparity_at(p.rectified[2]);
    const cv::Point2d at(p.rect_px.x, p.rect_px.y - kStrip.row0);
    const cv::Point2d l = centroid(left, at, background);
    const cv::Point2d r = centroid(right, at - cv::Point2d(d, 0.0), background);
    EXPECT_NEAR(l.y, r.y, 0.05);
    EXPECT_NEAR(l.x, at.x, 0.05);
    EXPECT_NEAR(l.y, at.y, 0.05);
    disparity.at<float>(static_cast<int>(at.y), static_cast<int>(at.x)) = static_cast<float>(l.x - r.x);
  }
  cv::Mat xyz;
  g.reproject(disparity, xyz);
  double worst = 0.0;
  int valid = 0;
  for (const auto& p : points) {
    const cv::Vec3f q = xyz.at<cv::Vec3f>(static_cast<int>(p.rect_px.y) - kStrip.row0, static_cast<int>(p.rect_px.x));
    worst = std::max(worst, cv::norm(cv::Vec3d(q) - p.rectified));
  }
  for (auto it = xyz.begin<cv::Vec3f>(); it != xyz.end<cv::Vec3f>(); ++it) valid += std::isfinite((*it)[2]);
  std::printf("worst 3D error from the rectified images: %.4f mm\n", worst);
  EXPECT_LT(worst, 0.1);  // measured 0.076 mm, the spot centroids' ~0.02 px at Z up to 450 mm
  EXPECT_EQ(valid, static_cast<int>(points.size()));  // NaN disparity -> NaN point
}

TEST(StereoGeometry, StripShowsNoBorder) {
  const StereoCalibration c = distorted_rig();
  for (StripRoi roi : {StripRoi{0, 48}, StripRoi{456, 48}, StripRoi{912, 48}}) {
    const StereoGeometry g(c, roi);
    const cv::Mat white(c.image_size, CV_8UC1, cv::Scalar(255));
    cv::Mat left, right;
    g.rectify(white, white, left, right);
    double min_left = 0, min_right = 0;
    cv::minMaxLoc(left, &min_left);
    cv::minMaxLoc(right, &min_right);
    std::printf("strip at row %d: alpha %.4f\n", roi.row0, g.alpha());
    EXPECT_EQ(min_left, 255.0);
    EXPECT_EQ(min_right, 255.0);
  }
}

TEST(StereoGeometry, DisparityAndDistanceAreInverse) {
  const StereoGeometry g(distorted_rig(), kStrip);
  for (double z : {150.0, 350.0, 600.0, 1500.0}) {
    const double d = g.disparity_at(z);
    EXPECT_NEAR(d, g.focal_px() * g.baseline_mm() / z, 1e-9 * d);
    EXPECT_NEAR(g.distance_at(d), z, 1e-9 * z);
  }
}

TEST(StereoGeometry, WholeImageAndBadStrips) {
  const StereoCalibration c = distorted_rig();
  const StereoGeometry whole(c, StripRoi{});
  EXPECT_EQ(whole.roi().row0, 0);
  EXPECT_EQ(whole.roi().rows, c.image_size.height);
  EXPECT_THROW(StereoGeometry(c, StripRoi{950, 20}), std::invalid_argument);
  EXPECT_THROW(StereoGeometry(c, StripRoi{-1, 20}), std::invalid_argument);
  EXPECT_THROW(StereoGeometry(c, StripRoi{5, 0}), std::invalid_argument);
  EXPECT_THROW(StereoGeometry(c, StripRoi{0, -4}), std::invalid_argument);
  StereoCalibration swapped = c;
  swapped.T = -c.T;  // the "right" camera on the left
  EXPECT_THROW(StereoGeometry(swapped, kStrip), std::invalid_argument);
}

TEST(StereoGeometry, SixteenBitMatchesEightBit) {
  const StereoCalibration c = distorted_rig();
  const StereoGeometry g(c, kStrip);
  cv::Mat raw8(c.image_size, CV_8UC1);
  cv::randu(raw8, 0, 256);
  raw8(cv::Rect(600, 400, 100, 60)).setTo(255);  // brightest strip pixel 255: 16-bit scale 255/4080
  cv::Mat raw16;
  raw8.convertTo(raw16, CV_16U, 16.0);  // 12-bit sensor: brightest 4080 -> 255
  cv::Mat l8, r8, l16, r16;
  g.rectify(raw8, raw8, l8, r8);
  g.rectify(raw16, raw16, l16, r16);
  cv::Mat diff;
  cv::absdiff(l8, l16, diff);
  double worst = 0;
  cv::minMaxLoc(diff, nullptr, &worst);
  EXPECT_LE(worst, 1.0);
  EXPECT_THROW(g.rectify(raw8, raw16, l8, r8), std::invalid_argument);
}

// A textured plane at distance z seen by an ideal rig: right(x) = left(x + d), d integer.
void plane_strips(double d, cv::Size size, cv::Mat& left, cv::Mat& right) {
  cv::Mat canvas(size.height, size.width + static_cast<int>(d) + 1, CV_32FC1);
  cv::RNG rng(42);
  rng.fill(canvas, cv::RNG::NORMAL, 0.0, 1.0);
  cv::GaussianBlur(canvas, canvas, cv::Size(0, 0), 1.2);
  cv::normalize(canvas, canvas, 20, 235, cv::NORM_MINMAX);
  canvas.colRange(0, size.width).convertTo(left, CV_8U);
  canvas.colRange(static_cast<int>(d), static_cast<int>(d) + size.width).convertTo(right, CV_8U);
}

TEST(EstimateBand, FindsTheGroundForAllSupportedRigs) {
  const WorkingRange range;  // 150..1500 mm
  std::printf(" height baseline   d_true   full band     estimate\n");
  for (double height : {250.0, 400.0, 600.0}) {
    for (double baseline : {40.0, 80.0, 120.0}) {
      const StereoGeometry g(ideal_rig(1000.0, baseline), StripRoi{456, 48});
      const double d = std::round(g.disparity_at(height));
      cv::Mat left, right;
      plane_strips(d, cv::Size(1280, 48), left, right);
      const DisparityBand full = band_for_range(g, range);
      const DisparityBand band = estimate_band(left, right, g, range);
      std::printf(" %6.0f %8.0f %8.0f   %4d+%-4d   %4d+%-4d\n", height, baseline, d, full.min_disparity,
                  full.num_disparities, band.min_disparity, band.num_disparities);
      EXPECT_EQ(band.num_disparities % 16, 0);
      EXPECT_LE(band.min_disparity, d - 2);
      EXPECT_GE(band.min_disparity + band.num_disparities - 1, d + 2);
      EXPECT_LE(band.num_disparities, 48);
      EXPECT_GE(band.min_disparity, full.min_disparity);
    }
  }
}

// A wide baseline with the default near end (150 mm) leaves StereoSGBM only the right 35% of the coarse
// strip, and there the ground is plain (snow): the texture, and the rut, lie further left. The band must
// still be found, from the whole overlap.
TEST(EstimateBand, FindsTheGroundWhereTheWorkingRangeLeavesOnlyPlainColumns) {
  const WorkingRange range;  // 150..1500 mm
  const StereoGeometry g(ideal_rig(1000.0, 120.0), StripRoi{456, 48});
  const DisparityBand full = band_for_range(g, range);
  ASSERT_GT(full.min_disparity + full.num_disparities, 800);  // columns left of this match nothing
  int checked = 0;
  for (double height : {450.0, 600.0, 750.0}) {
    const double d = std::round(g.disparity_at(height));
    cv::Mat left, right;
    plane_strips(d, cv::Size(1280, 48), left, right);
    // Plain ground from left column 700 on (and where it lies in the right view).
    left.colRange(700, left.cols).setTo(128);
    right.colRange(700 - static_cast<int>(d), right.cols).setTo(128);
    const DisparityBand band = estimate_band(left, right, g, range);
    EXPECT_LE(band.min_disparity, d - 2) << height;
    EXPECT_GE(band.min_disparity + band.num_disparities - 1, d + 2) << height;
    EXPECT_LE(band.num_disparities, 48) << height;
    cv::Mat gl, gr;
    const int scale = 8;  // what the coarse pass averages for this band (736 px / 128)
    cv::Mat cl, cr;
    cv::resize(left, cl, cv::Size(1280 / scale, 24), 0, 0, cv::INTER_AREA);
    cv::resize(right, cr, cv::Size(1280 / scale, 24), 0, 0, cv::INTER_AREA);
    const int dominant = dominant_disparity(cl, cr, DisparityBand{full.min_disparity / scale, 96}, gl, gr);
    EXPECT_NEAR(dominant * scale, d, scale) << height;
    ++checked;
  }
  EXPECT_EQ(checked, 3);
  // Unrelated strips have no dominant disparity.
  cv::Mat a, b, unused;
  plane_strips(0, cv::Size(160, 24), a, unused);
  cv::RNG rng(7);
  b.create(24, 160, CV_8U);
  rng.fill(b, cv::RNG::UNIFORM, 0, 255);
  cv::GaussianBlur(b, b, cv::Size(0, 0), 1.2);
  cv::Mat gl, gr;
  EXPECT_EQ(dominant_disparity(a, b, DisparityBand{0, 96}, gl, gr), -1);
}

TEST(EstimateBand, FallsBackToTheFullBandWithoutTexture) {
  const StereoGeometry g(ideal_rig(1000.0, 60.0), StripRoi{456, 48});
  const cv::Mat flat(48, 1280, CV_8UC1, cv::Scalar(128));
  const DisparityBand full = band_for_range(g, WorkingRange{});
  const DisparityBand band = estimate_band(flat, flat, g, WorkingRange{});
  EXPECT_EQ(band.min_disparity, full.min_disparity);
  EXPECT_EQ(band.num_disparities, full.num_disparities);
  const double fb = g.focal_px() * g.baseline_mm();  // disparity = f B / Z
  EXPECT_EQ(full.min_disparity, static_cast<int>(std::floor(fb / 1500.0)));
  const int hi = static_cast<int>(std::ceil(fb / 150.0));
  EXPECT_GE(full.min_disparity + full.num_disparities - 1, hi);
  EXPECT_LT(full.min_disparity + full.num_disparities - 1, hi + 16);
}

}  // namespace
}  // namespace rutd
