// check_frame's rules (measurement/frame_checks.hpp) one by one, on constructed strips whose truth is
// known by construction: both views of one random texture at a known disparity, then one view covered,
// darkened, clipped or flattened.
#include <cmath>
#include <limits>
#include <random>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "measurement/frame_checks.hpp"

namespace rutd {
namespace {

constexpr int kWidth = 640, kRows = 40, kDisparity = 24;

StereoCalibration ideal_rig() {
  StereoCalibration c;
  c.image_size = {kWidth, 480};
  c.M1 = cv::Matx33d(700, 0, 319.5, 0, 700, 239.5, 0, 0, 1);
  c.M2 = c.M1;
  c.D1 = cv::Mat::zeros(1, 5, CV_64F);
  c.D2 = cv::Mat::zeros(1, 5, CV_64F);
  c.R = cv::Matx33d::eye();
  c.T = cv::Vec3d(-60, 0, 0);
  return c;
}

struct Strips {
  cv::Mat left, right, disparity;
  // A texture of grey `mean` and deviation `deviation` (smoothed noise, as soil seen by a lens), seen by
  // the right camera kDisparity px to the left; disparity valid everywhere the right view exists.
  Strips(double mean, double deviation, unsigned seed = 3) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, 1.0);
    cv::Mat world(kRows, kWidth + kDisparity, CV_64F);
    for (int y = 0; y < world.rows; ++y)
      for (int x = 0; x < world.cols; ++x) world.at<double>(y, x) = noise(rng);
    cv::GaussianBlur(world, world, cv::Size(0, 0), 1.0);
    cv::Scalar m, sd;
    cv::meanStdDev(world, m, sd);
    world = (world - m[0]) * (deviation / sd[0]) + mean;
    // The right camera sees the point at left column x at x - d: right(x) = world(x + d), left(x) = world(x).
    world(cv::Rect(0, 0, kWidth, kRows)).convertTo(left, CV_8U);
    world(cv::Rect(kDisparity, 0, kWidth, kRows)).convertTo(right, CV_8U);
    disparity = cv::Mat(kRows, kWidth, CV_32F, cv::Scalar(kDisparity));
    disparity.colRange(0, kDisparity).setTo(std::numeric_limits<float>::quiet_NaN());
  }
};

RutMeasurement check(const Strips& s, ConditionConfig config = {}, std::int64_t skew_ns = 0,
                     const RutGeometry& rut = {}, const PairSignal& signal = {}, RutStatus measured = RutStatus::Ok) {
  const StereoGeometry geometry(ideal_rig(), StripRoi{220, kRows});
  FrameCheckScratch scratch;
  RutMeasurement m;
  m.status = measured;
  check_frame(s.left, s.right, s.disparity, 0, kRows, geometry, rut, DisparityBand{0, 64}, skew_ns, signal, config,
              scratch, m);
  return m;
}

constexpr std::uint8_t kLens = kConditionLeftObstructed | kConditionRightObstructed;

TEST(FrameChecks, CleanTexturedPairRaisesNothing) {
  const RutMeasurement m = check(Strips(120, 25));
  EXPECT_EQ(m.conditions, 0) << int(m.conditions);
  EXPECT_EQ(m.status, RutStatus::Ok);
  EXPECT_NEAR(m.vertical_disparity_px, 0.0, 0.2);
}

TEST(FrameChecks, FaintTextureMatchedIsNoCoveredLens) {  // snow under read noise, the right view dimmer
  // Texture a little above min_texture in the left view, the right camera's a little below (a gain 40 %
  // lower about the same mean): every block flat in one view only, yet DIC matched all of them.
  Strips s(200, 5.0);
  cv::Mat right;
  s.right.convertTo(right, CV_8U, 0.6, 0.4 * 200);
  s.right = right;
  const auto flat_share = [](const cv::Mat& v) {
    int flat = 0, blocks = 0;
    for (int b = 0; b + 16 <= v.cols; b += 16, ++blocks) {
      double g2 = 0;
      for (int y = 0; y < v.rows; y += 2)
        for (int x = b; x < b + 16; ++x)
          g2 += std::pow(double(v.at<std::uint8_t>(y, x + 1)) - v.at<std::uint8_t>(y, x), 2);
      flat += std::sqrt(g2 / (16.0 * v.rows / 2)) < ConditionConfig{}.min_texture;
    }
    return double(flat) / blocks;
  };
  ASSERT_LT(flat_share(s.left), 0.9);
  ASSERT_GE(flat_share(s.right), 0.9);
  const RutMeasurement m = check(s);
  EXPECT_EQ(m.conditions & kLens, 0) << int(m.conditions);
  // The same views, nothing matched: one flat view beside a textured one is a covered lens.
  Strips covered(200, 8);
  covered.right.setTo(180);
  covered.disparity.setTo(std::numeric_limits<float>::quiet_NaN());
  const RutMeasurement c = check(covered);
  EXPECT_TRUE(c.conditions & kConditionRightObstructed);
  EXPECT_EQ(c.status, RutStatus::LensObstructed);
}

TEST(FrameChecks, DarkBlobOnOneLensUnmatchedIsObstruction) {
  Strips s(120, 25);
  // A mud blob over columns 300-400 of the right view; DIC matches nothing there (left 324-424).
  s.right.colRange(300, 400).setTo(8);
  s.disparity.colRange(300 + kDisparity, 400 + kDisparity).setTo(std::numeric_limits<float>::quiet_NaN());
  const RutMeasurement m = check(s);
  EXPECT_TRUE(m.conditions & kConditionRightObstructed);
  EXPECT_FALSE(m.conditions & kConditionLeftObstructed);
  EXPECT_GT(m.obstructed_right, 0.1);
  // Matched all the same (a shadow both cameras see is no blob): no obstruction.
  Strips shadow(120, 25);
  shadow.right.colRange(300, 400) *= 0.3;
  shadow.left.colRange(300 + kDisparity, 400 + kDisparity) *= 0.3;
  EXPECT_EQ(check(shadow).conditions & kLens, 0);
}

// Frost or snow on a window lets the ground through: DIC matches every block, yet the camera behind it
// sees the ground brighter and with a fraction of its contrast (a veil: (1 - a) ground + a light).
TEST(FrameChecks, MatchedBehindAVeilIsStillAnObstructedLens) {
  const auto veil = [](cv::Mat& view, int x0, int x1, double a, double light) {
    cv::Mat part = view.colRange(x0, x1);
    part.convertTo(part, CV_8U, 1.0 - a, a * light);
  };
  Strips left_veiled(110, 25);
  veil(left_veiled.left, 200, 400, 0.7, 230);  // disparity stays valid: DIC matched through it
  const RutMeasurement l = check(left_veiled);
  EXPECT_TRUE(l.conditions & kConditionLeftObstructed) << int(l.conditions);
  EXPECT_FALSE(l.conditions & kConditionRightObstructed);
  EXPECT_EQ(l.status, RutStatus::LensObstructed);
  EXPECT_GT(l.obstructed_left, 0.2);

  Strips right_veiled(110, 25);
  veil(right_veiled.right, 300, 420, 0.7, 230);
  const RutMeasurement r = check(right_veiled);
  EXPECT_TRUE(r.conditions & kConditionRightObstructed) << int(r.conditions);
  EXPECT_FALSE(r.conditions & kConditionLeftObstructed);

  // Two clean lenses: the right camera 5 % brighter with 10 % less contrast (gain and response differ).
  Strips unequal(110, 25);
  unequal.right.convertTo(unequal.right, CV_8U, 0.9, 0.15 * 110);
  EXPECT_EQ(check(unequal).conditions & kLens, 0);
  // A thin veil (contrast halved, above obstruction_ratio) is left to the depth's uncertainty.
  Strips thin(110, 25);
  veil(thin.left, 200, 400, 0.5, 230);
  EXPECT_EQ(check(thin).conditions & kLens, 0);
  // The same contrast loss without the added light (a shadow on the ground only this camera sees is
  // no optics of the window): not a veil.
  Strips darker(110, 25);
  veil(darker.left, 200, 400, 0.7, 110);
  EXPECT_FALSE(check(darker).conditions & kConditionLeftObstructed);
}

TEST(FrameChecks, ExposureRules) {
  const RutMeasurement dark = check(Strips(8, 2));
  EXPECT_TRUE(dark.conditions & kConditionLowLight);
  EXPECT_EQ(dark.status, RutStatus::BadExposure);
  Strips bright(200, 40);
  bright.left.colRange(0, 200).setTo(255);
  bright.right.colRange(0, 200).setTo(255);
  // Clipping alone took texture away, no more: a depth extract_rut measured OK stands, flagged.
  const RutMeasurement clipped = check(bright);
  EXPECT_EQ(clipped.conditions, kConditionOverexposed) << int(clipped.conditions);
  EXPECT_EQ(clipped.status, RutStatus::Ok);
  // A depth over its uncertainty limit, or another condition beside it: the exposure is the status.
  EXPECT_EQ(check(bright, {}, 0, {}, {}, RutStatus::Uncertain).status, RutStatus::BadExposure);
  Strips blob = bright;  // and a mud blob on the right lens, unmatched
  blob.right = bright.right.clone();
  blob.disparity = bright.disparity.clone();
  blob.right.colRange(300, 400).setTo(8);
  blob.disparity.colRange(300 + kDisparity, 400 + kDisparity).setTo(std::numeric_limits<float>::quiet_NaN());
  const RutMeasurement two = check(blob);
  EXPECT_TRUE(two.conditions & kConditionOverexposed);
  EXPECT_TRUE(two.conditions & kConditionRightObstructed) << int(two.conditions);
  EXPECT_EQ(two.status, RutStatus::BadExposure);
  EXPECT_FALSE(check(Strips(200, 20)).conditions & kConditionOverexposed);
}

// Auto exposure and gain hold the median grey level up at night: the light is judged from the raw
// images' texture against their noise (ImageSignal), and only where the noise is high gain's.
TEST(FrameChecks, LowLightUnderAutoGainIsJudgedFromTheNoiseNotTheMedian) {
  const Strips lit(120, 25);  // a median of 120 of 255: the median rule sees nothing
  const auto signal = [](double left_ratio, double right_ratio, double noise) {
    PairSignal p;
    p.left.texture_to_noise = left_ratio;
    p.right.texture_to_noise = right_ratio;
    p.left.noise = p.right.noise = noise;
    return p;
  };
  const RutMeasurement night = check(lit, {}, 0, {}, signal(0.3, 0.25, 0.06));
  EXPECT_TRUE(night.conditions & kConditionLowLight);
  EXPECT_EQ(night.status, RutStatus::BadExposure);
  // Bright snow poor in texture: the same low ratio at gain 1's noise is no low light.
  EXPECT_FALSE(check(lit, {}, 0, {}, signal(0.3, 0.25, 0.01)).conditions & kConditionLowLight);
  // Enough texture over the same high-gain noise: matching has what it needs.
  EXPECT_FALSE(check(lit, {}, 0, {}, signal(0.8, 0.7, 0.06)).conditions & kConditionLowLight);
  // The better camera decides (the other may be covered: the lens checks' business).
  EXPECT_FALSE(check(lit, {}, 0, {}, signal(0.8, 0.1, 0.06)).conditions & kConditionLowLight);
  // One camera unknown: the other decides; both unknown: no rule.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(check(lit, {}, 0, {}, signal(nan, 0.3, 0.06)).conditions & kConditionLowLight);
  EXPECT_FALSE(check(lit, {}, 0, {}, PairSignal{}).conditions & kConditionLowLight);
  // The thresholds are the configuration's.
  ConditionConfig c;
  c.low_light_texture_to_noise = 0.2;
  EXPECT_FALSE(check(lit, c, 0, {}, signal(0.3, 0.25, 0.06)).conditions & kConditionLowLight);
  c = ConditionConfig{};
  c.low_light_noise = 0.1;
  EXPECT_FALSE(check(lit, c, 0, {}, signal(0.3, 0.25, 0.06)).conditions & kConditionLowLight);
}

// A raw image built from its parts: a soil texture (random, smoothed over `blur` px, deviation
// `deviation` grey levels about 120) plus white noise of `noise` grey levels, rounded to 8 bits. The truth
// is the construction's: the noise's deviation (with the rounding's 1/12), and the noise-free texture's
// RMS horizontal difference over sqrt(2) times it.
struct RawImage {
  cv::Mat image;
  double noise = 0, texture_to_noise = 0;
  RawImage(double deviation, double blur, double noise_dn, unsigned seed = 11) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> normal(0.0, 1.0);
    cv::Mat texture(240, 640, CV_64F), noisy(240, 640, CV_64F);
    for (auto it = texture.begin<double>(); it != texture.end<double>(); ++it) *it = normal(rng);
    cv::GaussianBlur(texture, texture, cv::Size(0, 0), blur);
    cv::Scalar m, sd;
    cv::meanStdDev(texture, m, sd);
    texture = (texture - m[0]) * (deviation / sd[0]) + 120.0;
    for (int y = 0; y < noisy.rows; ++y)
      for (int x = 0; x < noisy.cols; ++x) noisy.at<double>(y, x) = texture.at<double>(y, x) + noise_dn * normal(rng);
    noisy.convertTo(image, CV_8U);
    const cv::Mat dx = texture.colRange(1, texture.cols) - texture.colRange(0, texture.cols - 1);
    const double sigma = std::sqrt(noise_dn * noise_dn + 1.0 / 12);
    noise = sigma / 255.0;
    texture_to_noise = std::sqrt(cv::mean(dx.mul(dx))[0]) / (std::sqrt(2.0) * sigma);
  }
};

TEST(ImageSignal, NoiseAndTextureAgainstTheImagesConstruction) {
  std::vector<std::uint32_t> histogram;
  int checked = 0;
  // Night (texture under the noise), dusk, and daylight on fine (sand) and coarse (mud) texture.
  for (const double deviation : {4.0, 12.0, 40.0}) {
    for (const double blur : {1.0, 2.5}) {
      for (const double noise : {3.0, 10.0, 20.0}) {
        const RawImage raw(deviation, blur, noise);
        const ImageSignal s = image_signal(raw.image, 0, raw.image.rows, 64, histogram);
        SCOPED_TRACE(::testing::Message()
                     << "deviation " << deviation << " blur " << blur << " noise " << noise << ": true ratio "
                     << raw.texture_to_noise << " estimated " << s.texture_to_noise << ", noise " << s.noise / raw.noise
                     << " of the truth");
        EXPECT_NEAR(s.noise / raw.noise, 1.0, raw.texture_to_noise < 1.5 ? 0.15 : 0.6);
        // The ratio to within a fifth (and 0.1: the root of a small difference) where it matters, about the
        // threshold, and on the right side of
        // 0.5 wherever the truth is clearly on one side.
        if (raw.texture_to_noise < 1.5) {
          EXPECT_NEAR(s.texture_to_noise, raw.texture_to_noise, 0.2 * raw.texture_to_noise + 0.1);
        }
        if (raw.texture_to_noise < 0.4) {
          EXPECT_LT(s.texture_to_noise, 0.5);
        }
        if (raw.texture_to_noise > 0.7) {
          EXPECT_GT(s.texture_to_noise, 0.5);
        }
        // The same image in 16-bit pixels (a 12-bit sensor's scale) gives the same figures.
        cv::Mat wide;
        raw.image.convertTo(wide, CV_16U, 16.0);
        const ImageSignal w = image_signal(wide, 0, wide.rows, 64, histogram);
        EXPECT_NEAR(w.noise, s.noise, 0.1 * s.noise + 0.1 / 4095);
        EXPECT_NEAR(w.texture_to_noise, s.texture_to_noise, 0.1 * s.texture_to_noise + 0.05);
        ++checked;
      }
    }
  }
  EXPECT_EQ(checked, 18);
}

TEST(ImageSignal, UnusableInputGivesUnknownFigures) {
  std::vector<std::uint32_t> histogram;
  EXPECT_TRUE(std::isnan(image_signal(cv::Mat(), 0, 10, 16, histogram).texture_to_noise));
  EXPECT_TRUE(std::isnan(image_signal(cv::Mat(20, 20, CV_8UC3), 0, 10, 16, histogram).noise));
  EXPECT_TRUE(std::isnan(image_signal(cv::Mat(20, 4, CV_8UC1), 0, 10, 16, histogram).noise));
  EXPECT_TRUE(std::isnan(image_signal(cv::Mat(20, 20, CV_32FC1), 0, 10, 16, histogram).noise));
  // A flat image: no noise, no texture (no division by zero).
  const ImageSignal flat = image_signal(cv::Mat(20, 20, CV_8UC1, cv::Scalar(90)), 0, 20, 16, histogram);
  EXPECT_FALSE(std::isnan(flat.noise));
  EXPECT_EQ(flat.texture_to_noise, 0.0);
}

TEST(FrameChecks, RowsShiftedAreCalibrationDrift) {
  Strips s(120, 25);
  cv::Mat shifted;
  cv::copyMakeBorder(s.right.rowRange(0, kRows - 2), shifted, 2, 0, 0, 0, cv::BORDER_REPLICATE);
  s.right = shifted;  // the right view's features two rows lower
  const RutMeasurement m = check(s);
  EXPECT_TRUE(m.conditions & kConditionCalibrationDrift);
  EXPECT_NEAR(m.vertical_disparity_px, 2.0, 0.3);
  EXPECT_EQ(m.status, RutStatus::CalibrationDrift);
}

// Texture that varies along the columns only (a steep rut's edges and shadows, running along travel):
// each view's rows all alike but for its own sensor noise. The rows slide along it, so no vertical offset
// can be read there, and none may be reported as drift: without the contrast test, the blocks' peaks fell
// anywhere in the +-8 rows searched and the pair was flagged.
TEST(FrameChecks, TextureAlongTheColumnsOnlySaysNothingOfAVerticalOffset) {
  int checked = 0;
  for (unsigned seed = 1; seed <= 6; ++seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, 1.0);
    std::vector<double> profile(kWidth + kDisparity);
    for (double& v : profile) v = noise(rng);
    cv::Mat row(1, kWidth + kDisparity, CV_64F, profile.data());
    cv::GaussianBlur(row, row, cv::Size(0, 0), 3.0);
    cv::normalize(row, row, 60, 200, cv::NORM_MINMAX);
    Strips s(120, 25, seed);
    for (int y = 0; y < kRows; ++y) {
      for (int x = 0; x < kWidth; ++x) {
        s.left.at<std::uint8_t>(y, x) = cv::saturate_cast<std::uint8_t>(row.at<double>(0, x) + 1.5 * noise(rng));
        s.right.at<std::uint8_t>(y, x) =
            cv::saturate_cast<std::uint8_t>(row.at<double>(0, x + kDisparity) + 1.5 * noise(rng));
      }
    }
    const RutMeasurement m = check(s);
    EXPECT_FALSE(m.conditions & kConditionCalibrationDrift) << "seed " << seed << ": " << m.vertical_disparity_px;
    EXPECT_NE(m.status, RutStatus::CalibrationDrift) << "seed " << seed;
    ++checked;
  }
  EXPECT_EQ(checked, 6);
}

// Where the blocks reach into the rut opening the right view's rows are two lower (as a wall's misfit in a
// rigid block reads), beside it they fit: the calibration is judged on the ground beside the rut, and is not flagged.
// The same offset across the whole view is drift with the opening known, as without it.
TEST(FrameChecks, OffsetsOverTheRutAreNoCalibrationDrift) {
  RutGeometry rut;  // ground 400 mm away, the opening X -40..40 mm: columns 249.5..389.5 of the 700 px lens
  rut.has_line = rut.has_rut = true;
  rut.line_c = 400;
  rut.left_x_mm = -40;
  rut.right_x_mm = 40;
  Strips s(120, 25);
  // The right view's columns of the blocks that reach into the opening (left columns 226..414).
  const cv::Rect over_rut(226 - kDisparity, 0, 188, kRows);
  cv::Mat shifted;
  cv::copyMakeBorder(s.right(over_rut).rowRange(0, kRows - 2), shifted, 2, 0, 0, 0, cv::BORDER_REPLICATE);
  shifted.copyTo(s.right(over_rut));
  const RutMeasurement beside = check(s, {}, 0, rut);
  EXPECT_FALSE(beside.conditions & kConditionCalibrationDrift) << beside.vertical_disparity_px;
  EXPECT_NEAR(beside.vertical_disparity_px, 0.0, 0.3);
  // Without the opening the three blocks over it are read, and flag it.
  EXPECT_TRUE(check(s).conditions & kConditionCalibrationDrift);

  Strips all(120, 25);
  cv::copyMakeBorder(all.right.rowRange(0, kRows - 2), shifted, 2, 0, 0, 0, cv::BORDER_REPLICATE);
  all.right = shifted;
  const RutMeasurement drift = check(all, {}, 0, rut);
  EXPECT_TRUE(drift.conditions & kConditionCalibrationDrift);
  EXPECT_NEAR(drift.vertical_disparity_px, 2.0, 0.3);
}

// Free-running cameras: the same two-row shift with the right camera exposed 3 ms after the left is the
// vehicle's motion, not the calibration's; so is a shift too large to correlate. Synchronised, or with the
// views aligned, nothing changes.
TEST(FrameChecks, RowsShiftedByAKnownSkewAreUnsynchronisedNotDrift) {
  Strips s(120, 25);
  cv::Mat shifted;
  cv::copyMakeBorder(s.right.rowRange(0, kRows - 2), shifted, 2, 0, 0, 0, cv::BORDER_REPLICATE);
  s.right = shifted;
  const RutMeasurement skewed = check(s, {}, 3'000'000);
  EXPECT_EQ(skewed.status, RutStatus::Unsynchronised) << to_string(skewed.status);
  EXPECT_FALSE(skewed.conditions & kConditionCalibrationDrift) << int(skewed.conditions);
  EXPECT_NEAR(skewed.vertical_disparity_px, 2.0, 0.3);  // still reported
  // Below the configured skew (hardware-triggered cameras), or with the rule off: drift.
  EXPECT_EQ(check(s, {}, 50'000).status, RutStatus::CalibrationDrift);
  ConditionConfig off;
  off.unsynchronised_skew_ms = 0;
  EXPECT_EQ(check(s, off, 3'000'000).status, RutStatus::CalibrationDrift);
  // A skew with the views aligned (the vehicle standing): measured as any pair.
  const RutMeasurement standing = check(Strips(120, 25), {}, 3'000'000);
  EXPECT_EQ(standing.status, RutStatus::Ok) << to_string(standing.status);
  EXPECT_EQ(standing.conditions, 0) << int(standing.conditions);
}

TEST(FrameChecks, ViewsTooFarApartToCorrelateWithAKnownSkewAreUnsynchronised) {
  Strips s(120, 25);
  s.right = Strips(120, 25, 11).right;  // the right camera sees other ground: moved beyond the search
  s.disparity.setTo(std::numeric_limits<float>::quiet_NaN());
  const RutMeasurement skewed = check(s, {}, -6'000'000);
  EXPECT_EQ(skewed.status, RutStatus::Unsynchronised) << to_string(skewed.status);
  EXPECT_EQ(skewed.conditions & (kLens | kConditionVegetation | kConditionCalibrationDrift), 0)
      << int(skewed.conditions);
  EXPECT_EQ(skewed.obstructed_left, 0.0);
  EXPECT_EQ(skewed.obstructed_right, 0.0);
  // Without the skew the same views are not called unsynchronised.
  EXPECT_NE(check(s).status, RutStatus::Unsynchronised);
}

// Standing water (or any flat patch) in the rut: inside the opening both views are flat and nothing
// matched over 60 mm; the bottom is hidden only where the profile's walls still descend into the patch.
// What no skew explains: a lens covered whole (one view with no texture, the other textured) stays a
// covered lens on a skewed pair, with its bit and share; a featureless scene (no texture in either view)
// is not called unsynchronised either, since there was nothing to correlate.
TEST(FrameChecks, ACoveredLensOnASkewedPairIsStillACoveredLens) {
  Strips covered(120, 25);
  covered.right.setTo(40);
  covered.disparity.setTo(std::numeric_limits<float>::quiet_NaN());
  const RutMeasurement m = check(covered, {}, 4'000'000);
  EXPECT_EQ(m.status, RutStatus::LensObstructed) << to_string(m.status);
  EXPECT_TRUE(m.conditions & kConditionRightObstructed) << int(m.conditions);
  EXPECT_FALSE(m.conditions & kConditionLeftObstructed) << int(m.conditions);
  EXPECT_EQ(m.obstructed_right, 1.0);
  Strips left_covered(120, 25);
  left_covered.left.setTo(40);
  left_covered.disparity.setTo(std::numeric_limits<float>::quiet_NaN());
  const RutMeasurement l = check(left_covered, {}, -4'000'000);
  EXPECT_EQ(l.status, RutStatus::LensObstructed) << to_string(l.status);
  EXPECT_TRUE(l.conditions & kConditionLeftObstructed) << int(l.conditions);

  Strips blank(120, 25);
  blank.left.setTo(120);
  blank.right.setTo(120);
  blank.disparity.setTo(std::numeric_limits<float>::quiet_NaN());
  EXPECT_NE(check(blank, {}, 4'000'000).status, RutStatus::Unsynchronised);
}

TEST(FrameChecks, FlatUnmatchedPatchInTheRutHidesTheBottomWhereTheWallsDescend) {
  Strips s(120, 25);
  const int u0 = 264, u1 = 376;  // left columns of the patch; the right view sees them kDisparity px left
  s.left.colRange(u0, u1).setTo(90);
  s.right.colRange(u0 - kDisparity, u1 - kDisparity).setTo(90);
  s.disparity.colRange(u0, u1).setTo(std::numeric_limits<float>::quiet_NaN());
  RutGeometry rut;  // ground 400 mm away, the opening X -40..40 mm: columns 249.5..389.5 of the 700 px lens
  rut.has_line = rut.has_rut = true;
  rut.line_c = 400;
  rut.left_x_mm = -40;
  rut.right_x_mm = 40;
  rut.unseen_depth_mm = 6;  // the walls descend into the patch
  const RutMeasurement hidden = check(s, {}, 0, rut);
  EXPECT_TRUE(hidden.conditions & kConditionWater) << int(hidden.conditions);
  EXPECT_EQ(hidden.status, RutStatus::BottomNotSeen) << to_string(hidden.status);
  EXPECT_EQ(hidden.conditions & (kLens | kConditionVegetation | kConditionCalibrationDrift), 0);
  rut.unseen_depth_mm = 0;  // bottom seen level on both sides of the patch: nothing hidden
  const RutMeasurement seen = check(s, {}, 0, rut);
  EXPECT_FALSE(seen.conditions & kConditionWater) << int(seen.conditions);
  EXPECT_EQ(seen.status, RutStatus::Ok) << to_string(seen.status);
  // Outside the opening the same patch is no water (the rut is elsewhere).
  rut.unseen_depth_mm = 6;
  rut.left_x_mm = 60;
  rut.right_x_mm = 120;
  EXPECT_FALSE(check(s, {}, 0, rut).conditions & kConditionWater);
}

// Water over left columns 264-376 in the rut opening (dark, unmatched: each view sees its own ripples
// over the bottom, as textured as the ground, so that no flat patch finds it), and glints of the sun on
// it: bright, striped patches (ripple facets) over left columns 280-312 and over right columns
// 280 + glint_shift .. 312 + glint_shift, each view its own stripes. The sun is at infinity, so its
// reflection lies at disparity 0: glint_shift 0 is what cameras see; the right view's water lies
// kDisparity px left of the left's.
Strips glinting_water(int glint_shift, double glint = 190, double stripe = 50, int glint_end = 312) {
  Strips s(120, 25);
  const int u0 = 264, u1 = 376;
  const Strips left_ripples(40, 25, 5), right_ripples(40, 25, 7);
  left_ripples.left.colRange(u0, u1).copyTo(s.left.colRange(u0, u1));
  right_ripples.left.colRange(u0, u1).copyTo(s.right.colRange(u0 - kDisparity, u1 - kDisparity));
  s.disparity.colRange(u0, u1).setTo(std::numeric_limits<float>::quiet_NaN());
  const auto stripes = [glint, stripe](cv::Mat& view, int x0, int x1, int phase) {
    for (int y = 0; y < view.rows; ++y)
      for (int x = x0; x < x1; ++x)
        view.at<std::uint8_t>(y, x) =
            cv::saturate_cast<std::uint8_t>(glint + ((x + y / 3 + phase) / 2 % 2 ? stripe : -stripe));
  };
  stripes(s.left, 280, glint_end, 0);
  stripes(s.right, 280 + glint_shift, glint_end + glint_shift, 1);
  return s;
}

RutGeometry opening_over_water() {  // ground 400 mm away; X -40..40 mm: columns 249.5..389.5
  RutGeometry rut;
  rut.has_line = rut.has_rut = true;
  rut.line_c = 400;
  rut.left_x_mm = -40;
  rut.right_x_mm = 40;
  rut.unseen_depth_mm = 6;  // the walls descend into the water
  return rut;
}

TEST(FrameChecks, GlintsBothViewsSeeAtTheSameColumnsAreWaterNotALens) {
  RutGeometry rut = opening_over_water();
  const RutMeasurement glints = check(glinting_water(0), {}, 0, rut);
  EXPECT_TRUE(glints.conditions & kConditionWater) << int(glints.conditions);
  EXPECT_EQ(glints.conditions & kLens, 0) << int(glints.conditions);
  EXPECT_EQ(glints.status, RutStatus::BottomNotSeen) << to_string(glints.status);
  // Without the reflection rule the same views are an obstructed lens: the test sees the rule work.
  ConditionConfig off;
  off.specular_min_blocks = 1000;
  const RutMeasurement lens = check(glinting_water(0), off, 0, rut);
  EXPECT_TRUE(lens.conditions & kLens) << int(lens.conditions);
  EXPECT_EQ(lens.status, RutStatus::LensObstructed) << to_string(lens.status);
  // Bright patches at neither the ground's disparity nor 0 reflect nothing at infinity (the right view's
  // 40 px right of the left's, 64 px wide: they overlap by 24 px at disparity 0).
  const RutMeasurement elsewhere = check(glinting_water(40, 190, 50, 344), {}, 0, rut);
  EXPECT_FALSE(elsewhere.conditions & kConditionWater) << int(elsewhere.conditions);
  EXPECT_TRUE(elsewhere.conditions & kLens) << int(elsewhere.conditions);
  // Glints and a blob on a lens outside the rut: the lens is obstructed.
  Strips blob = glinting_water(0);
  blob.right.colRange(480, 560).setTo(8);
  blob.disparity.colRange(480 + kDisparity, 560 + kDisparity).setTo(std::numeric_limits<float>::quiet_NaN());
  const RutMeasurement both = check(blob, {}, 0, rut);
  EXPECT_TRUE(both.conditions & kConditionRightObstructed) << int(both.conditions);
  EXPECT_EQ(both.status, RutStatus::LensObstructed) << to_string(both.status);
  // The same dirt on both lenses at the same columns agrees at disparity 0 too, but is no glint: mud is
  // dark, frost or snow out of focus is smooth, and a patch no brighter than the ground is no sun.
  for (const auto& [name, glint, stripe] :
       {std::tuple{"mud", 10.0, 0.0}, {"frost", 200.0, 0.0}, {"dim", 120.0, 50.0}}) {
    const RutMeasurement dirt = check(glinting_water(0, glint, stripe), {}, 0, rut);
    EXPECT_FALSE(dirt.conditions & kConditionWater) << name << " " << int(dirt.conditions);
    EXPECT_TRUE(dirt.conditions & kLens) << name << " " << int(dirt.conditions);
  }
  // Nor is it water where the rut is elsewhere: a lens puts its blobs anywhere.
  rut.left_x_mm = 60;
  rut.right_x_mm = 120;
  const RutMeasurement away = check(glinting_water(0), {}, 0, rut);
  EXPECT_FALSE(away.conditions & kConditionWater) << int(away.conditions);
  EXPECT_TRUE(away.conditions & kLens) << int(away.conditions);
}

// Every third block unmatched in strips whose texture is `deviation` grey levels; the cameras' read noise
// (ImageSignal::noise) `noise_dn` grey levels and their texture to noise `ratio`, NaN for unknown.
RutMeasurement unmatched_blocks(double deviation, double noise_dn, double ratio = 0.6) {
  Strips s(120, deviation);
  for (int b = 4; b < 30; b += 3)
    s.disparity.colRange(b * 16, b * 16 + 16).setTo(std::numeric_limits<float>::quiet_NaN());
  PairSignal signal;
  signal.left.noise = signal.right.noise = noise_dn / 255.0;
  signal.left.texture_to_noise = signal.right.texture_to_noise = ratio;
  return check(s, {}, 0, {}, signal);
}

TEST(FrameChecks, TexturedUnmatchedOutsideTheRutIsVegetation) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(unmatched_blocks(25, nan, nan).conditions & kConditionVegetation);
  EXPECT_EQ(check(Strips(120, 25)).conditions & kConditionVegetation, 0);
}

// Snow under gain (the images' texture under their noise): as above, a texture of a few grey levels (an RMS
// neighbour difference of about 4, above min_texture) that the cameras' read noise alone would give is
// no blades where DIC leaves it unmatched. Real texture unmatched is vegetation at the same noise, and
// that texture is too with little noise or with the noise unknown, and where the images' texture
// exceeds their noise (whose figure, a Laplacian's median, then takes fine blades for noise).
TEST(FrameChecks, UnmatchedTextureTheNoiseExplainsIsNoVegetation) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(unmatched_blocks(6, 2.0).conditions & kConditionVegetation, 0);
  EXPECT_EQ(unmatched_blocks(6, 1.6).conditions & kConditionVegetation, 0);
  EXPECT_TRUE(unmatched_blocks(25, 2.0).conditions & kConditionVegetation);
  EXPECT_TRUE(unmatched_blocks(6, 0.5).conditions & kConditionVegetation);
  EXPECT_TRUE(unmatched_blocks(6, nan).conditions & kConditionVegetation);
  EXPECT_TRUE(unmatched_blocks(6, 2.0, 1.2).conditions & kConditionVegetation);
  EXPECT_TRUE(unmatched_blocks(6, 2.0, nan).conditions & kConditionVegetation);
}

}  // namespace
}  // namespace rutd
