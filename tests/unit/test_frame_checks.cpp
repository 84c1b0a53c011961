// The calibration check's correlation (measurement/frame_checks.hpp, normalized_correlation) against
// OpenCV's own cv::matchTemplate(TM_CCOEFF_NORMED), which it replaces on the per-frame path, on random
// textures of the sizes the check uses and of awkward ones, including flat patches.
#include <cstdio>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "measurement/frame_checks.hpp"

namespace rutd {
namespace {

TEST(FrameChecks, NormalizedCorrelationIsOpenCvsCcoeffNormed) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> size(4, 40), value(0, 255);
  int compared = 0;
  double worst = 0.0;
  for (int trial = 0; trial < 60; ++trial) {
    const int tw = size(rng), th = size(rng);
    const int aw = tw + std::uniform_int_distribution<int>(0, 20)(rng);
    const int ah = th + std::uniform_int_distribution<int>(0, 20)(rng);
    cv::Mat area(ah, aw, CV_8UC1), templ(th, tw, CV_8UC1);
    for (int y = 0; y < ah; ++y)
      for (int x = 0; x < aw; ++x) area.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(value(rng));
    // Half the templates are cut from the area (a true match exists), half are noise.
    if (trial % 2 == 0) {
      area(cv::Rect(aw - tw, ah - th, tw, th)).copyTo(templ);
    } else {
      for (int y = 0; y < th; ++y)
        for (int x = 0; x < tw; ++x) templ.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(value(rng));
    }
    cv::Mat ours, theirs;
    normalized_correlation(area, templ, ours);
    cv::matchTemplate(area, templ, theirs, cv::TM_CCOEFF_NORMED);
    ASSERT_EQ(ours.size(), theirs.size());
    ASSERT_EQ(ours.type(), CV_32F);
    for (int y = 0; y < ours.rows; ++y) {
      for (int x = 0; x < ours.cols; ++x) {
        const double d = std::abs(ours.at<float>(y, x) - theirs.at<float>(y, x));
        worst = std::max(worst, d);
        EXPECT_LT(d, 1e-3) << "trial " << trial << " at " << x << "," << y;
        ++compared;
      }
    }
    if (trial % 2 == 0) {
      EXPECT_NEAR(ours.at<float>(ah - th, aw - tw), 1.0f, 1e-5);
    }
  }
  EXPECT_GT(compared, 1000);
  std::printf("%d correlations compared with cv::matchTemplate, largest difference %.2e\n", compared, worst);
}

TEST(FrameChecks, NormalizedCorrelationOfAFlatPatchIsZero) {
  cv::Mat area(20, 20, CV_8UC1, cv::Scalar(90)), templ(8, 8, CV_8UC1);
  cv::randu(templ, 0, 255);
  cv::Mat ours;
  normalized_correlation(area, templ, ours);
  EXPECT_EQ(cv::countNonZero(ours), 0);
}

}  // namespace
}  // namespace rutd
