// The synthetic renderer's optics against independent physics: stereo through clear water against
// two-media photogrammetry (Snell's law solved here for each camera), the water's reflection against
// the Fresnel equations, attenuation against Beer-Lambert along the refracted path, free-running cameras
// against the row shift the motion predicts, auto exposure and gain against the sensor's noise model,
// and faults on the lenses against the geometry of an out-of-focus window.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "synthetic/synthetic_renderer.hpp"

namespace rutd {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kWater = 1.333;

cv::Mat as_float(const cv::Mat& image16) {
  cv::Mat f;
  image16.convertTo(f, CV_64F, 1.0 / 257.0);  // grey levels of the 8-bit scale
  return f;
}

// A wide rut whose flat bottom fills the middle of the view, water over it, no noise, 16 bits.
SyntheticRendererConfig pool_params(double level_mm, double attenuation) {
  SyntheticRendererConfig p;
  p.noise_sigma = 0;
  p.full_well_e = 0;
  p.bit_depth = 16;
  p.rut.depth_mm = 40;
  p.rut.width_mm = 420;
  p.rut.bottom_width_mm = 300;
  p.rut.pile_left_mm = p.rut.pile_right_mm = 0;
  WaterConfig& w = p.conditions.water;
  w.level_mm = level_mm;
  w.refractive_index = kWater;
  w.attenuation_per_mm = attenuation;
  w.silt_contrast = 0;
  p.conditions.sky.underside_height_mm = 0;     // open sky: nothing sharp to reflect
  p.conditions.sky.sun = cv::Vec3d(1, 0, 0.3);  // low, to the side: its glint far outside the view
  return p;
}

// ---------------------------------------------------------------------------------------------------
// Stereo through clear water

// The x in [0, span] where a ray from a camera `above` the surface to a point `below` it, `span` apart
// horizontally, crosses the surface: Snell's law sin(air) = n sin(water), by bisection.
double snell_crossing(double span, double above, double below, double n) {
  double lo = 0, hi = span;
  for (int i = 0; i < 200; ++i) {
    const double x = 0.5 * (lo + hi);
    const double f = x / std::hypot(x, above) - n * (span - x) / std::hypot(span - x, below);
    (f < 0 ? lo : hi) = x;
  }
  return 0.5 * (lo + hi);
}

// Disparity of left rectified pixel (u, v) in `right`, both rectified CV_64F images: integer
// normalised cross-correlation over [d_lo, d_hi], then Gauss-Newton on the zero-normalised SSD of a
// (2 half + 1)^2 window with the right window cubic-interpolated. NaN when the window does not fit.
double match_disparity(const cv::Mat& left, const cv::Mat& right, const cv::Mat& right_dx, int u, int v, int d_lo,
                       int d_hi, int half) {
  const int w = 2 * half + 1;
  if (u - half - d_hi < 0 || u + half >= left.cols || v - half < 0 || v + half >= left.rows) return NAN;
  cv::Mat templ, area, score;
  left(cv::Rect(u - half, v - half, w, w)).convertTo(templ, CV_32F);
  right(cv::Rect(u - half - d_hi, v - half, w + d_hi - d_lo, w)).convertTo(area, CV_32F);
  cv::matchTemplate(area, templ, score, cv::TM_CCOEFF_NORMED);
  cv::Point best;
  cv::minMaxLoc(score, nullptr, nullptr, nullptr, &best);
  double d = d_hi - best.x;
  cv::Scalar tm, ts;
  cv::meanStdDev(templ, tm, ts);
  cv::Mat map_x(w, w, CV_32F), map_y(w, w, CV_32F), patch, slope;
  for (int it = 0; it < 30; ++it) {
    for (int j = 0; j < w; ++j)
      for (int i = 0; i < w; ++i) {
        map_x.at<float>(j, i) = static_cast<float>(u - half + i - d);
        map_y.at<float>(j, i) = static_cast<float>(v - half + j);
      }
    cv::remap(right, patch, map_x, map_y, cv::INTER_CUBIC);
    cv::remap(right_dx, slope, map_x, map_y, cv::INTER_CUBIC);
    cv::Scalar pm, ps;
    cv::meanStdDev(patch, pm, ps);
    const double gain = ts[0] / std::max(ps[0], 1e-9);
    double num = 0, den = 0;
    for (int j = 0; j < w; ++j)
      for (int i = 0; i < w; ++i) {
        const double e = (patch.at<double>(j, i) - pm[0]) * gain - (templ.at<float>(j, i) - tm[0]);
        const double g = slope.at<double>(j, i) * gain;
        num += g * e, den += g * g;
      }
    const double step = num / std::max(den, 1e-12);
    d += step;
    if (std::abs(step) < 1e-5) break;
  }
  return d;
}

TEST(SyntheticOptics, StereoSeesTheBottomThroughClearWaterWhereTwoMediaPhotogrammetryPuts) {
  const SyntheticRendererConfig p = pool_params(20, 0.0);
  const SyntheticRenderer renderer(p);
  StereoFrame frame;
  renderer.render(0, frame);
  // Rectify as any stereo system would, with OpenCV and the renderer's calibration.
  const StereoCalibration& c = renderer.calibration();
  cv::Mat R1, R2, P1, P2, Q, m1x, m1y, m2x, m2y, left, right, right_dx;
  cv::stereoRectify(c.M1, c.D1, c.M2, c.D2, c.image_size, c.R, c.T, R1, R2, P1, P2, Q, cv::CALIB_ZERO_DISPARITY);
  cv::initUndistortRectifyMap(c.M1, c.D1, R1, P1, c.image_size, CV_32FC1, m1x, m1y);
  cv::initUndistortRectifyMap(c.M2, c.D2, R2, P2, c.image_size, CV_32FC1, m2x, m2y);
  cv::remap(as_float(frame.left), left, m1x, m1y, cv::INTER_CUBIC);
  cv::remap(as_float(frame.right), right, m2x, m2y, cv::INTER_CUBIC);
  cv::Sobel(right, right_dx, CV_64F, 1, 0, 1, 0.5);  // central difference
  const double f = P1.at<double>(0, 0), cx = P1.at<double>(0, 2), cy = P1.at<double>(1, 2);
  const double cx2 = P2.at<double>(0, 2);
  const cv::Matx33d rect1(R1), rect2(R2);

  const double z_water = -p.rut.depth_mm + p.conditions.water.level_mm, z_bottom = -p.rut.depth_mm;
  const cv::Vec3d left_centre = renderer.camera_centre(Camera::Left, 0);
  const cv::Vec3d right_centre = renderer.camera_centre(Camera::Right, 0);
  const cv::Matx33d world_from_left = renderer.camera_rotation(Camera::Left);
  const cv::Matx33d world_from_right = renderer.camera_rotation(Camera::Right);
  const auto right_column = [&](const cv::Vec3d& world_dir, double& row) {
    const cv::Vec3d r = rect2 * (world_from_right.t() * world_dir);
    row = f * r[1] / r[2] + cy;
    return f * r[0] / r[2] + cx2;
  };
  int checked = 0;
  double sum = 0, sum2 = 0, worst_row = 0, ratio_sum = 0;
  double naive_gap = 1e9;
  for (int dv = -8; dv <= 8; dv += 8) {
    const int v = static_cast<int>(std::lround(cy)) + dv;
    for (int u = 60; u < 600; u += 12) {
      // The left pixel's ray, refracted at the surface, to the flat bottom.
      const cv::Vec3d ray = world_from_left * (rect1.t() * cv::Vec3d((u - cx) / f, (v - cy) / f, 1));
      const cv::Vec3d at_surface = left_centre + ((z_water - left_centre[2]) / ray[2]) * ray;
      const cv::Vec3d in = cv::normalize(ray);
      const double cos_i = -in[2], eta = 1 / kWater;
      const double cos_t = std::sqrt(1 - eta * eta * (1 - cos_i * cos_i));
      const cv::Vec3d bent = eta * in + (eta * cos_i - cos_t) * cv::Vec3d(0, 0, 1);
      const cv::Vec3d bottom = at_surface + ((z_bottom - z_water) / bent[2]) * bent;
      const double lateral = bottom[0] - p.rut.lateral_offset_mm;
      if (std::abs(at_surface[0] - p.rut.lateral_offset_mm) > 120 || std::abs(lateral) > 130) continue;
      // The right camera sees that bottom point through the surface where Snell's law says.
      const cv::Vec2d span(bottom[0] - right_centre[0], bottom[1] - right_centre[1]);
      const double x = snell_crossing(cv::norm(span), right_centre[2] - z_water, z_water - z_bottom, kWater);
      const cv::Vec2d towards = span / cv::norm(span);
      const cv::Vec3d crossing(right_centre[0] + x * towards[0], right_centre[1] + x * towards[1], z_water);
      double row = 0, naive_row = 0;
      const double predicted = u - right_column(crossing - right_centre, row);
      // Without refraction both cameras would see the bottom straight along their rays.
      const cv::Vec3d straight = left_centre + ((z_bottom - left_centre[2]) / ray[2]) * ray;
      const double naive = u - right_column(straight - right_centre, naive_row);
      worst_row = std::max(worst_row, std::abs(row - v));
      naive_gap = std::min(naive_gap, std::abs(naive - predicted));
      const double measured = match_disparity(left, right, right_dx, u, v, static_cast<int>(predicted) - 12,
                                              static_cast<int>(predicted) + 12, 10);
      ASSERT_TRUE(std::isfinite(measured)) << u << "," << v;
      const double error = measured - predicted;
      sum += error, sum2 += error * error;
      // Apparent depth of the bottom below the surface / true water depth, from the measured disparity.
      const cv::Vec4d h = cv::Matx44d(Q) * cv::Vec4d(u, v, measured, 1);
      const double z_apparent = h[2] / h[3];
      const double z_surface = (rect1 * (world_from_left.t() * (at_surface - left_centre)))[2];
      const double z_true = (rect1 * (world_from_left.t() * (bottom - left_centre)))[2];
      ratio_sum += (z_apparent - z_surface) / (z_true - z_surface);
      ++checked;
    }
  }
  const double mean = sum / checked, rms = std::sqrt(sum2 / checked);
  std::printf(
      "%d bottom points through 20 mm of clear water: disparity - two-media prediction mean %+.3f px, rms %.3f px; "
      "refraction moves it by at least %.2f px; apparent / true depth under the surface %.3f (1/n = %.3f); "
      "vertical parallax up to %.3f px\n",
      checked, mean, rms, naive_gap, ratio_sum / checked, 1 / kWater, worst_row - 0);
  ASSERT_GE(checked, 40);
  EXPECT_GT(naive_gap, 0.5);  // the test can tell refraction from none
  EXPECT_LT(std::abs(mean), 0.03);
  EXPECT_LT(rms, 0.06);
  EXPECT_NEAR(ratio_sum / checked, 1 / kWater, 0.03);
}

// ---------------------------------------------------------------------------------------------------
// Fresnel reflection

// Unpolarised reflectance of air to water at incidence theta, from the Fresnel equations as textbooks
// write them (Hecht, Optics, 4.42-4.43), in angles.
double fresnel_textbook(double theta, double n) {
  if (theta < 1e-9) return std::pow((n - 1) / (n + 1), 2);
  const double t = std::asin(std::sin(theta) / n);
  const double rs = std::sin(theta - t) / std::sin(theta + t);
  const double rp = std::tan(theta - t) / std::tan(theta + t);
  return 0.5 * (rs * rs + rp * rp);
}

TEST(SyntheticOptics, OpaqueWaterReflectsAUniformSkyByTheFresnelEquations) {
  // A pool wider than the view, black and opaque below its surface, under a uniform sky of radiance 1:
  // every pixel sees R(theta) of its view ray. A pitched rig with a wide lens spans 0-80 degrees.
  SyntheticRendererConfig p = pool_params(30, 100);
  p.rut.width_mm = 3000, p.rut.bottom_width_mm = 2800;
  p.conditions.water.body_albedo = 0;
  p.conditions.water.roughness_deg = 0;  // no glint lobe
  p.conditions.sky.zenith = p.conditions.sky.horizon = 1;
  p.rig.pitch_deg = 40;
  p.rig.hfov_deg = 100;
  p.rig.image_size = {320, 240};
  p.exposure = 2;
  const SyntheticRenderer renderer(p);
  StereoFrame frame;
  renderer.render(0, frame);
  const cv::Mat grey = as_float(frame.left);
  int checked = 0;
  double worst = 0, schlick_gap = 0, lo = 90, hi = 0;
  for (int v = 2; v < 238; ++v) {
    for (int u = 100; u <= 220; u += 60) {
      const cv::Vec3d dir = renderer.camera_rotation(Camera::Left) * renderer.pixel_ray(Camera::Left, u, v);
      const double theta = std::acos(-dir[2] / cv::norm(dir));
      if (theta > 80 * kPi / 180) continue;
      const double expected = fresnel_textbook(theta, kWater);
      const double seen = grey.at<double>(v, u) / (255.0 * p.exposure);
      worst = std::max(worst, std::abs(seen - expected) / expected);
      const double schlick = 0.02 + 0.98 * std::pow(1 - std::cos(theta), 5);
      schlick_gap = std::max(schlick_gap, std::abs(schlick - expected) / expected);
      lo = std::min(lo, theta * 180 / kPi), hi = std::max(hi, theta * 180 / kPi);
      ++checked;
    }
  }
  std::printf(
      "%d pixels at %.0f-%.0f degrees: reflectance within %.2f %% of the Fresnel equations (Schlick's "
      "approximation is off by up to %.1f %%)\n",
      checked, lo, hi, 100 * worst, 100 * schlick_gap);
  ASSERT_GE(checked, 300);
  EXPECT_LT(lo, 10);
  EXPECT_GT(hi, 70);
  EXPECT_LT(worst, 0.01);
  EXPECT_GT(schlick_gap, 5 * 0.01);  // the tolerance tells the exact equations from an approximation
}

// ---------------------------------------------------------------------------------------------------
// Beer-Lambert attenuation

TEST(SyntheticOptics, AttenuationFollowsBeerLambertAlongTheRefractedPath) {
  // No reflection (black sky) and no body colour: each pixel's radiance is the bottom's, times
  // exp(-c s) over its refracted path s through the water. Two regions seen at different angles hold
  // the same texture statistics; the ratio of their attenuation (turbid over clear) is exp(-c (s_a -
  // s_b)), whatever the light that reached the bottom.
  const double level = 20, c = 0.08;
  const auto params = [&](double attenuation) {
    SyntheticRendererConfig p = pool_params(level, attenuation);
    p.rut.width_mm = 3000, p.rut.bottom_width_mm = 2800;
    p.conditions.water.body_albedo = 0;
    p.conditions.water.roughness_deg = 0;
    p.conditions.sky.zenith = p.conditions.sky.horizon = 0;
    p.rig.pitch_deg = 30;
    p.rig.hfov_deg = 90;
    p.rig.image_size = {320, 240};
    p.exposure = 3;
    return p;
  };
  const SyntheticRenderer clear(params(0)), turbid(params(c));
  StereoFrame a, b;
  clear.render(0, a);
  turbid.render(0, b);
  const cv::Mat ca = as_float(a.left), tb = as_float(b.left);
  // Path length in the water of the ray of pixel (u, v): level / cos(refracted angle).
  const auto path = [&](int u, int v) {
    const cv::Vec3d d = cv::normalize(clear.camera_rotation(Camera::Left) * clear.pixel_ray(Camera::Left, u, v));
    const double sin_t = std::sqrt(1 - d[2] * d[2]) / kWater;
    return level / std::sqrt(1 - sin_t * sin_t);
  };
  struct Region {
    cv::Rect box;
    double ratio = 0, path = 0;
  };
  Region regions[2] = {{cv::Rect(130, 200, 60, 30)}, {cv::Rect(130, 20, 60, 30)}};  // near nadir, oblique
  for (Region& r : regions) {
    std::vector<double> ratios;
    double paths = 0;
    for (int v = r.box.y; v < r.box.y + r.box.height; ++v) {
      for (int u = r.box.x; u < r.box.x + r.box.width; ++u) {
        ratios.push_back(tb.at<double>(v, u) / ca.at<double>(v, u));
        paths += path(u, v);
      }
    }
    std::nth_element(ratios.begin(), ratios.begin() + ratios.size() / 2, ratios.end());
    r.ratio = ratios[ratios.size() / 2];
    r.path = paths / static_cast<double>(ratios.size());
  }
  const double measured = regions[1].ratio / regions[0].ratio;
  const double expected = std::exp(-c * (regions[1].path - regions[0].path));
  const double vertical = 1.0;  // attenuation over the depth alone would not depend on the angle
  std::printf("paths %.2f and %.2f mm: attenuation ratio %.4f, Beer-Lambert along the refracted path %.4f\n",
              regions[0].path, regions[1].path, measured, expected);
  EXPECT_GT(regions[1].path - regions[0].path, 3.0);  // the regions' paths differ enough to tell
  EXPECT_NEAR(measured, expected, 0.02);
  EXPECT_GT(std::abs(vertical - expected), 0.1);

  // Turbid water: the bottom's texture is gone, the body colour remains.
  SyntheticRendererConfig murky = params(1.0);
  murky.conditions.water.body_albedo = 0.15;
  StereoFrame m;
  SyntheticRenderer(murky).render(0, m);
  cv::Scalar mean_clear, std_clear, mean_murky, std_murky;
  cv::meanStdDev(ca(regions[0].box), mean_clear, std_clear);
  cv::meanStdDev(as_float(m.left)(regions[0].box), mean_murky, std_murky);
  std::printf("texture through 20 mm: clear std %.2f, turbid (c = 1/mm) std %.4f grey levels at mean %.1f\n",
              std_clear[0], std_murky[0], mean_murky[0]);
  EXPECT_LT(std_murky[0], 0.01 * std_clear[0]);
  EXPECT_GT(mean_murky[0], 5);
}

// ---------------------------------------------------------------------------------------------------
// Free-running cameras

TEST(SyntheticOptics, FreeRunningRightCameraSeesTheGroundMovedByTheSkew) {
  // Flat ground, no distortion: with the right exposure `delay` later at a speed that moves the ground by
  // exactly 5 pixel rows in that time, the right image is the synchronised one shifted by 5 rows; the
  // left image does not change.
  SyntheticRendererConfig p;
  p.noise_sigma = 0;
  p.full_well_e = 0;
  p.bit_depth = 16;
  p.rig.image_size = {320, 240};
  p.rig.distortion_left = p.rig.distortion_right = cv::Vec<double, 5>(0, 0, 0, 0, 0);
  p.rig.misalign_pitch_deg = p.rig.misalign_roll_deg = p.rig.misalign_yaw_deg = 0;
  p.rut.lateral_offset_mm = 5000;
  p.speed_mm_s = 10000;  // 36 km/h
  const double fr = 160 / std::tan(p.rig.hfov_deg / 2 * kPi / 180) * p.rig.focal_scale_right;
  const double rows = 5;
  SyntheticRendererConfig skewed = p;
  skewed.right_delay_ms = rows * p.rig.height_mm / fr / p.speed_mm_s * 1e3;
  StereoFrame a, b;
  SyntheticRenderer(p).render(3, a);
  const SyntheticRenderer renderer(skewed);
  renderer.render(3, b);
  EXPECT_EQ(cv::norm(a.left, b.left, cv::NORM_INF), 0);
  const cv::Mat before = a.right(cv::Rect(0, 0, 320, 235)), after = b.right(cv::Rect(0, 5, 320, 235));
  double worst = 0;
  cv::minMaxLoc(cv::abs(cv::Mat_<double>(before) - cv::Mat_<double>(after)), nullptr, &worst);
  cv::Mat diff;
  cv::absdiff(a.right, b.right, diff);
  const double unshifted = cv::mean(diff)[0];
  std::printf(
      "right delayed %.3f ms at 10 m/s: shifted by 5 rows it differs by at most %.0f of 65535 "
      "(unshifted %.0f on average); truth right_delay_ns %lld\n",
      skewed.right_delay_ms, worst, unshifted, static_cast<long long>(renderer.truth(3).right_delay_ns));
  EXPECT_LE(worst, 2);
  EXPECT_GT(unshifted, 500);
  EXPECT_EQ(renderer.truth(3).right_delay_ns, std::llround(skewed.right_delay_ms * 1e6));
}

// ---------------------------------------------------------------------------------------------------
// Auto exposure and gain

TEST(SyntheticOptics, AutoExposureHoldsTheMedianWhileGainRaisesTheNoise) {
  // Flat sand, the scene still (speed 0) so two frames differ only by their noise. As the light falls,
  // auto exposure holds the median by exposure up to its limit, then by gain; the noise is then
  // gain * sqrt(read^2 + signal * 255 / full well) with signal = median / gain at gain 1.
  SyntheticRendererConfig p;
  p.rig.image_size = {320, 240};
  p.rut.lateral_offset_mm = 5000;
  p.speed_mm_s = 0;
  p.auto_exposure.enabled = true;
  p.auto_exposure.target = 0.4;
  p.auto_exposure.max_exposure = 2;
  p.auto_exposure.max_gain = 16;
  p.right_response = 1.04;
  const double target = 0.4 * 255;
  double noise_bright = 0, noise_dim = 0, usable_bright = 0, usable_dim = 0;
  for (const double light : {1.0, 0.3, 0.05}) {
    p.light = light;
    const SyntheticRenderer renderer(p);
    StereoFrame a, b;
    const CameraSettings s = renderer.render(1, a);
    renderer.render(2, b);
    cv::Mat left;
    a.left.convertTo(left, CV_64F);
    std::vector<double> values(left.begin<double>(), left.end<double>());
    std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
    const double median = values[values.size() / 2];
    cv::Mat d;
    cv::subtract(cv::Mat_<double>(a.left), cv::Mat_<double>(b.left), d);
    cv::Scalar mean, deviation;
    cv::meanStdDev(d, mean, deviation);
    const double noise = deviation[0] / std::sqrt(2.0);
    const double signal = median / s.gain;  // grey levels at gain 1
    const double predicted = s.gain * std::sqrt(p.noise_sigma * p.noise_sigma + signal * 255 / p.full_well_e);
    cv::Scalar image_mean, image_std;
    cv::meanStdDev(left, image_mean, image_std);
    // Texture over noise: what matching has to work with.
    const double usable = std::sqrt(std::max(image_std[0] * image_std[0] - noise * noise, 0.0)) / noise;
    // The right camera 4 % brighter: against a pair of equal response, which sees the same ground.
    SyntheticRendererConfig equal = p;
    equal.right_response = 1;
    StereoFrame e;
    SyntheticRenderer(equal).render(1, e);
    const double right_ratio = cv::mean(a.right)[0] / cv::mean(e.right)[0];
    std::printf(
        "light %.2f: exposure %.2f gain %.2f median %.0f (target %.0f), noise %.2f (model %.2f), "
        "texture/noise %.1f, right brighter x %.3f\n",
        light, s.exposure, s.gain, median, target, noise, predicted, usable, right_ratio);
    EXPECT_NEAR(median, target, 2.5);
    EXPECT_NEAR(noise, predicted, 0.1 * predicted);
    EXPECT_NEAR(right_ratio, 1.04, 0.004);
    if (light == 1.0) noise_bright = noise, usable_bright = usable;
    if (light == 0.05) {
      noise_dim = noise, usable_dim = usable;
      EXPECT_DOUBLE_EQ(s.exposure, 2);
      EXPECT_GT(s.gain, 8);
    }
  }
  EXPECT_GT(noise_dim, 3 * noise_bright);
  EXPECT_LT(usable_dim, usable_bright / 3);
  // Below what the longest exposure and the highest gain can make up for, the median falls.
  p.light = 0.005;
  StereoFrame dark;
  const CameraSettings s = SyntheticRenderer(p).render(1, dark);
  EXPECT_DOUBLE_EQ(s.gain, 16);
  EXPECT_LT(cv::mean(dark.left)[0], 0.5 * target);
}

// ---------------------------------------------------------------------------------------------------
// Faults on the lenses

SyntheticRendererConfig lens_params() {
  SyntheticRendererConfig p;
  p.noise_sigma = 0;
  p.full_well_e = 0;
  p.bit_depth = 16;
  p.rig.image_size = {320, 240};
  p.rig.distortion_left = p.rig.distortion_right = cv::Vec<double, 5>(0, 0, 0, 0, 0);
  return p;
}

cv::Mat highpass(const cv::Mat& image) {
  cv::Mat smooth;
  cv::GaussianBlur(image, smooth, cv::Size(0, 0), 4);
  return image - smooth;
}

TEST(SyntheticOptics, DustFilmScalesContrastByItsTransmittanceAndAddsASmoothVeil) {
  SyntheticRendererConfig p = lens_params();
  StereoFrame clean, dusty;
  SyntheticRenderer(p).render(0, clean);
  const double haze = 0.6;
  p.conditions.lens.faults = {{LensFaultKind::Dust, LensSide::Both, haze, 0.5}};
  SyntheticRenderer(p).render(0, dusty);
  const cv::Rect inner(20, 20, 280, 200);
  cv::Scalar m0, s0, m1, s1;
  cv::meanStdDev(highpass(as_float(clean.left))(inner), m0, s0);
  cv::meanStdDev(highpass(as_float(dusty.left))(inner), m1, s1);
  const double mean_clean = cv::mean(as_float(clean.left)(inner))[0],
               mean_dusty = cv::mean(as_float(dusty.left)(inner))[0];
  std::printf("dust film of haze %.1f: fine contrast x %.3f (expected %.3f), mean %.1f -> %.1f grey levels\n", haze,
              s1[0] / s0[0], 1 - haze, mean_clean, mean_dusty);
  EXPECT_NEAR(s1[0] / s0[0], 1 - haze, 0.01);
  EXPECT_NEAR(mean_dusty, mean_clean, 0.25 * mean_clean);  // the veil gives back most of the light
}

TEST(SyntheticOptics, OutOfFocusMudBlursOverTheApertureDiscAndSameSprayMatchesOnBothLenses) {
  SyntheticRendererConfig p = lens_params();
  StereoFrame clean;
  SyntheticRenderer(p).render(0, clean);
  const cv::Mat left_clean = as_float(clean.left), right_clean = as_float(clean.right);
  // A mud blob: along the middle row the transmitted share rises from 0 to 1 over the aperture disc's
  // diameter on the window, 2 defocus f pixels (a straight edge convolved with a disc), whatever the
  // blob's own rim.
  p.conditions.lens.defocus = 0.05;
  p.conditions.lens.faults = {{LensFaultKind::Mud, LensSide::Left, 0.4, 0.35}};
  StereoFrame mud;
  const double f = 160 / std::tan(p.rig.hfov_deg / 2 * kPi / 180);
  const SyntheticRenderer muddy(p);
  muddy.render(0, mud);
  const int row = 120;
  int first_clear = -1, last_dark = -1;
  for (int u = 0; u < 320; ++u) {
    const double s = muddy.lens_transmission(Camera::Left, u, row);
    if (u > 150 && first_clear < 0 && s > 0.98) first_clear = u;
    if (u < 200 && s < 0.02) last_dark = u;
  }
  const double width = first_clear - last_dark, disc = 2 * p.conditions.lens.defocus * f;
  std::printf("mud edge: dark to clear over %.0f px; the aperture disc on the window spans %.1f px\n", width, disc);
  EXPECT_GT(last_dark, 0);
  EXPECT_GT(width, 0.6 * disc);
  EXPECT_LT(width, 1.2 * disc);
  EXPECT_LT(cv::norm(as_float(mud.right), right_clean, cv::NORM_INF), 1e-9);  // the other lens is clean

  // Spray: "both" lays one pattern at the same place on both windows, "each" one per window (cameras of
  // equal intrinsics, so the same place on the window is the same pixel).
  const auto attenuation_correlation = [&](LensSide side) {
    SyntheticRendererConfig q = lens_params();
    q.rig.principal_offset_right = q.rig.principal_offset_left;
    q.rig.focal_scale_right = 1;
    q.conditions.lens.faults = {{LensFaultKind::Spray, side, 0.2, 0.5}};
    const SyntheticRenderer renderer(q);
    cv::Mat a(240, 320, CV_64F), b(240, 320, CV_64F);
    for (int v = 0; v < 240; ++v)
      for (int u = 0; u < 320; ++u) {
        a.at<double>(v, u) = renderer.lens_transmission(Camera::Left, u, v);
        b.at<double>(v, u) = renderer.lens_transmission(Camera::Right, u, v);
      }
    cv::Scalar ma, sa, mb, sb;
    cv::meanStdDev(a, ma, sa);
    cv::meanStdDev(b, mb, sb);
    return cv::mean((a - ma[0]).mul(b - mb[0]))[0] / (sa[0] * sb[0]);
  };
  const double same = attenuation_correlation(LensSide::Both), own = attenuation_correlation(LensSide::Each);
  std::printf("spray shadows left against right: correlation %.3f on both lenses alike, %.3f each its own\n", same,
              own);
  EXPECT_GT(same, 0.95);
  EXPECT_LT(std::abs(own), 0.3);
}

TEST(SyntheticOptics, WaterDropsBendTheViewWithoutDarkeningIt) {
  // Drops are clear: where a pixel looks through them the light still arrives (but for their rims), from
  // elsewhere in the scene and blurred, so its fine detail is not the clean view's.
  SyntheticRendererConfig p = lens_params();
  StereoFrame clean, wet;
  SyntheticRenderer(p).render(0, clean);
  p.conditions.lens.faults = {{LensFaultKind::Drops, LensSide::Left, 0.5, 0.5}};
  const SyntheticRenderer renderer(p);
  renderer.render(0, wet);
  const cv::Mat ha = highpass(as_float(clean.left)), hb = highpass(as_float(wet.left));
  double sa = 0, sb = 0, sab = 0, saa = 0, sbb = 0, clean_sum = 0, wet_sum = 0;
  int through = 0;
  for (int v = 20; v < 220; ++v) {
    for (int u = 20; u < 300; ++u) {
      if (renderer.lens_transmission(Camera::Left, u, v) > 0.2) continue;  // mostly through drops
      const double a = ha.at<double>(v, u), b = hb.at<double>(v, u);
      sa += a, sb += b, sab += a * b, saa += a * a, sbb += b * b;
      clean_sum += clean.left.at<std::uint16_t>(v, u), wet_sum += wet.left.at<std::uint16_t>(v, u);
      ++through;
    }
  }
  const double n = through;
  const double correlation = (sab - sa * sb / n) / std::sqrt((saa - sa * sa / n) * (sbb - sb * sb / n));
  std::printf("%d pixels seeing through drops: brightness x %.3f, fine detail correlates %.2f with the clean view\n",
              through, wet_sum / clean_sum, correlation);
  ASSERT_GT(through, 2000);
  EXPECT_GT(wet_sum / clean_sum, 0.6);
  EXPECT_LT(correlation, 0.5);
  EXPECT_EQ(cv::norm(clean.right, wet.right, cv::NORM_INF), 0);
}

}  // namespace
}  // namespace rutd
