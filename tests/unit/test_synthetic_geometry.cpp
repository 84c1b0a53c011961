// Geometry of the synthetic renderer against independent references: OpenCV's projection model, the
// analytic ground plane, a brute-force first-hit search, and OpenCV's rectification.
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include "synthetic/synthetic_renderer.hpp"

namespace rutd {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180;

SyntheticRendererConfig small_params() {
  SyntheticRendererConfig p;
  p.rig.image_size = {320, 240};
  return p;
}

cv::Point2d project(const cv::Vec3d& point, const cv::Matx33d& K, const cv::Mat& D) {
  std::vector<cv::Point3d> in{cv::Point3d(point[0], point[1], point[2])};
  std::vector<cv::Point2d> out;
  cv::projectPoints(in, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, D, out);
  return out[0];
}

// The terrain of the spec (synthetic_scene.hpp header comment), written independently of RutTerrain.
double reference_height(const RutShape& r, double x, double y) {
  const double xc = r.lateral_offset_mm + r.wander_amplitude_mm * std::sin(2 * kPi * y / r.wander_wavelength_mm);
  const double s = x - xc, a = std::abs(s);
  const double b2 = r.bottom_width_mm / 2, w2 = r.width_mm / 2;
  double h = 0;
  if (a <= b2) {
    h = -r.depth_mm;
    if (r.tread) {
      const double inner = b2 - r.tread_taper_mm;
      const double across = a <= inner ? 1 : 0.5 * (1 + std::cos(kPi * (a - inner) / r.tread_taper_mm));
      h -= r.tread_depth_mm * across * 0.5 * (1 - std::cos(2 * kPi * y / r.tread_pitch_mm));
    }
  } else if (a <= w2) {
    h = -r.depth_mm * 0.5 * (1 + std::cos(kPi * (a - b2) / (w2 - b2)));
  } else if (a <= w2 + r.pile_width_mm) {
    const double v = std::sin(kPi * (a - w2) / r.pile_width_mm);
    h = (s < 0 ? r.pile_left_mm : r.pile_right_mm) * v * v;
  }
  return h;
}

TEST(SyntheticGeometry, PixelRaysReprojectOntoTheirPixels) {
  const SyntheticRenderer renderer(small_params());
  const StereoCalibration& c = renderer.calibration();
  double worst = 0;
  for (Camera camera : {Camera::Left, Camera::Right}) {
    const cv::Matx33d& K = camera == Camera::Left ? c.M1 : c.M2;
    const cv::Mat& D = camera == Camera::Left ? c.D1 : c.D2;
    for (int v = 0; v < 240; v += 13) {
      for (int u = 0; u < 320; u += 17) {
        for (const cv::Point2d o : {cv::Point2d(0, 0), cv::Point2d(-1.0 / 3, 1.0 / 3), cv::Point2d(0.45, -0.4)}) {
          const cv::Point2d px = project(renderer.pixel_ray(camera, u, v, o.x, o.y), K, D);
          worst = std::max(worst, cv::norm(px - cv::Point2d(u + o.x, v + o.y)));
        }
      }
    }
  }
  std::printf("worst ray reprojection error %.3g px\n", worst);
  EXPECT_LT(worst, 1e-3);
}

TEST(SyntheticGeometry, FlatGroundHitIsAtCameraHeight) {
  SyntheticRendererConfig p = small_params();
  p.rut.lateral_offset_mm = 5000;  // out of view: flat ground only
  const SyntheticRenderer renderer(p);
  for (double x : {-0.8, -0.3, 0.0, 0.25, 0.7}) {
    for (double y : {-0.6, 0.0, 0.5}) {
      const cv::Vec3d dir(x, y, 1);
      const auto hit = renderer.intersect_left(7, dir);
      ASSERT_TRUE(hit.has_value());
      EXPECT_NEAR(cv::norm(*hit - dir * p.rig.height_mm), 0.0, 1e-6);
    }
  }
}

TEST(SyntheticGeometry, FlatGroundUnderRollAndPitchFollowsTheRigConvention) {
  SyntheticRendererConfig p = small_params();
  p.rut.lateral_offset_mm = 5000;
  p.rig.roll_deg = 6;
  p.rig.pitch_deg = -4;
  const SyntheticRenderer renderer(p);
  // Left camera pose from the documented convention: Ry(roll) Rx(pitch) applied to the looking-down
  // frame (X = x, Y = -y, Z = -z), centre at the rig midpoint minus baseline/2 along the rig's x axis.
  const double r = p.rig.roll_deg * kDeg, q = p.rig.pitch_deg * kDeg;
  const cv::Matx33d Ry(std::cos(r), 0, std::sin(r), 0, 1, 0, -std::sin(r), 0, std::cos(r));
  const cv::Matx33d Rx(1, 0, 0, 0, std::cos(q), -std::sin(q), 0, std::sin(q), std::cos(q));
  const cv::Matx33d world_from_left = Ry * Rx * cv::Matx33d(1, 0, 0, 0, -1, 0, 0, 0, -1);
  const std::uint64_t index = 3;
  const cv::Vec3d centre =
      cv::Vec3d(0, index * p.speed_mm_s / p.fps, p.rig.height_mm) + Ry * Rx * cv::Vec3d(-p.rig.baseline_mm / 2, 0, 0);
  EXPECT_LT(cv::norm(renderer.camera_centre(Camera::Left, index) - centre), 1e-9);
  for (double x : {-0.7, 0.0, 0.6}) {
    for (double y : {-0.5, 0.4}) {
      const auto hit = renderer.intersect_left(index, cv::Vec3d(x, y, 1));
      ASSERT_TRUE(hit.has_value());
      const cv::Vec3d world = world_from_left * *hit + centre;
      EXPECT_NEAR(world[2], 0.0, 1e-6);
      EXPECT_NEAR((*hit)[0] / (*hit)[2], x, 1e-12);  // on the ray
    }
  }
  // Positive roll lowers the right camera.
  EXPECT_LT(renderer.camera_centre(Camera::Right, 0)[2], renderer.camera_centre(Camera::Left, 0)[2]);
}

// First root of z_ray(t) - h(x(t), y(t)) by fine stepping and bisection; counts the sign changes.
double brute_force_hit(const RutShape& shape, const cv::Vec3d& o, const cv::Vec3d& d, int& crossings) {
  const auto f = [&](double t) { return o[2] + t * d[2] - reference_height(shape, o[0] + t * d[0], o[1] + t * d[1]); };
  const double top = std::max(shape.pile_left_mm, shape.pile_right_mm) + 1;
  const double t0 = (o[2] - top) / -d[2];
  const double t1 = (o[2] + shape.depth_mm + shape.tread_depth_mm + 1) / -d[2];
  const double dt = 0.004;
  double first = -1;
  crossings = 0;
  double prev = f(t0);
  for (double t = t0 + dt; t <= t1; t += dt) {
    const double now = f(t);
    if ((prev > 0) != (now > 0)) {
      ++crossings;
      if (first < 0) {
        double a = t - dt, b = t;
        for (int i = 0; i < 60; ++i) ((f(0.5 * (a + b)) > 0) ? a : b) = 0.5 * (a + b);
        first = 0.5 * (a + b);
      }
    }
    prev = now;
  }
  return first;
}

// Random rays and rays aimed just below each pile crest, against brute_force_hit.
void expect_first_hits_match_brute_force(const SyntheticRendererConfig& p) {
  const SyntheticRenderer renderer(p);
  const std::uint64_t index = 11;
  const cv::Vec3d o = renderer.camera_centre(Camera::Left, index);
  const cv::Matx33d R = renderer.camera_rotation(Camera::Left);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> ux(-0.75, 0.75), uy(-0.55, 0.55);
  std::vector<cv::Vec3d> dirs;
  for (int i = 0; i < 1500; ++i) dirs.emplace_back(ux(rng), uy(rng), 1);
  // Rays aimed just below the crest of each pile: they enter the pile, leave it through its far side
  // and would meet the ground behind it, so only a first-hit search gets them right.
  for (double side : {-1.0, 1.0}) {
    const double pile = side < 0 ? p.rut.pile_left_mm : p.rut.pile_right_mm;
    for (double y : {o[1] - 40, o[1], o[1] + 40}) {
      const double xc =
          p.rut.lateral_offset_mm + p.rut.wander_amplitude_mm * std::sin(2 * kPi * y / p.rut.wander_wavelength_mm);
      const double crest = xc + side * (p.rut.width_mm / 2 + p.rut.pile_width_mm / 2);
      for (double dx : {-2.0, 0.0, 2.0, 4.0}) {
        for (double dz : {0.5, 2.0, 6.0}) {
          dirs.push_back(R.t() * (cv::Vec3d(crest + side * dx, y, pile - dz) - o));
        }
      }
    }
  }
  int occluded = 0, checked = 0;
  double worst = 0;
  for (const cv::Vec3d& dir : dirs) {
    const auto hit = renderer.intersect_left(index, dir);
    int crossings = 0;
    const double t_ref = brute_force_hit(p.rut, o, R * dir, crossings);
    ASSERT_TRUE(hit.has_value());
    ASSERT_GT(t_ref, 0);
    worst = std::max(worst, cv::norm(*hit - dir * t_ref));
    occluded += crossings > 1;
    ++checked;
  }
  std::printf("%d rays, %d cross the surface more than once, worst hit error %.3g mm\n", checked, occluded, worst);
  EXPECT_GT(occluded, 5);  // the test exercises occlusion
  EXPECT_LT(worst, 0.01);
}

SyntheticRendererConfig occluding_params() {
  SyntheticRendererConfig p = small_params();
  p.rig.roll_deg = 8;
  p.rut.pile_left_mm = 35;  // tall, narrow piles occlude the walls behind them
  p.rut.pile_right_mm = 25;
  p.rut.pile_width_mm = 30;
  p.rut.lateral_offset_mm = 40;
  return p;
}

TEST(SyntheticGeometry, FirstHitMatchesBruteForceWithOcclusionWanderAndTread) {
  SyntheticRendererConfig p = occluding_params();  // the general terrain: marched
  p.rut.wander_amplitude_mm = 30;
  p.rut.wander_wavelength_mm = 700;
  p.rut.tread = true;
  expect_first_hits_match_brute_force(p);
}

TEST(SyntheticGeometry, FirstHitMatchesBruteForceOnAStraightRutWithOcclusion) {
  SyntheticRendererConfig p = occluding_params();  // a straight rut without tread: solved piece by piece
  expect_first_hits_match_brute_force(p);
  p.rig.roll_deg = -5, p.rig.pitch_deg = 12;
  p.rut.bottom_width_mm = 0;  // no flat bottom: the walls meet
  p.rut.pile_right_mm = 0;
  p.rut.lateral_offset_mm = -60;
  expect_first_hits_match_brute_force(p);
}

TEST(SyntheticGeometry, StraightDownTheRutAxis) {
  // Rays in a plane of constant world x (d_x = 0 exactly) meet the profile at that x.
  SyntheticRendererConfig p = small_params();
  p.rig.baseline_mm = 100;  // left camera at x = -50
  const SyntheticRenderer renderer(p);
  const RutTerrain terrain(p.rut, p.rut.depth_mm);
  const cv::Vec3d o = renderer.camera_centre(Camera::Left, 0);
  for (double dy : {-0.3, 0.0, 0.4}) {
    const double t = cast_ray(terrain, o, cv::Vec3d(0, dy, -1));
    EXPECT_NEAR(o[2] - t, reference_height(p.rut, o[0], o[1] + t * dy), 1e-7);
  }
}

TEST(SyntheticGeometry, CalibrationMatchesTheRig) {
  const SyntheticRendererConfig p = small_params();
  const SyntheticRenderer renderer(p);
  const StereoCalibration& c = renderer.calibration();
  EXPECT_EQ(c.image_size, p.rig.image_size);
  EXPECT_NEAR(cv::norm(c.T), p.rig.baseline_mm, 1e-9);
  EXPECT_LT(c.T[0], -0.99 * p.rig.baseline_mm);  // right camera at +X of the left one
  EXPECT_LT(cv::norm(c.R.t() * c.R - cv::Matx33d::eye()), 1e-12);
  // The right camera's centre in the left frame is -R^T T = (B, 0, 0), where the rig puts it.
  const cv::Vec3d right_in_left = -(c.R.t() * c.T);
  EXPECT_LT(cv::norm(right_in_left - cv::Vec3d(p.rig.baseline_mm, 0, 0)), 1e-9);
  // World poses agree with R: R = R_right^T R_left (camera frames to world).
  const cv::Matx33d R = renderer.camera_rotation(Camera::Right).t() * renderer.camera_rotation(Camera::Left);
  EXPECT_LT(cv::norm(R - c.R), 1e-12);
  const double angle = std::acos((cv::trace(c.R) - 1) / 2) / kDeg;
  EXPECT_GT(angle, 0.3);  // really misaligned (0.4, 0.3, 0.2 degrees by default)
}

TEST(SyntheticGeometry, MisalignedRowsLineUpOnlyAfterRectification) {
  const SyntheticRenderer renderer(small_params());
  const StereoCalibration& c = renderer.calibration();
  cv::Mat R1, R2, P1, P2, Q;
  cv::stereoRectify(c.M1, c.D1, c.M2, c.D2, c.image_size, c.R, c.T, R1, R2, P1, P2, Q);
  double raw_worst = 0, rect_worst = 0;
  for (double x : {-0.6, 0.0, 0.6}) {
    for (double y : {-0.5, 0.0, 0.5}) {
      const auto hit = renderer.intersect_left(0, cv::Vec3d(x, y, 1));
      ASSERT_TRUE(hit.has_value());
      const cv::Vec3d in_right = c.R * *hit + c.T;
      const cv::Point2d l = project(*hit, c.M1, c.D1), r = project(in_right, c.M2, c.D2);
      raw_worst = std::max(raw_worst, std::abs(l.y - r.y));
      std::vector<cv::Point2d> lr, rr;
      cv::undistortPoints(std::vector<cv::Point2d>{l}, lr, c.M1, c.D1, R1, P1);
      cv::undistortPoints(std::vector<cv::Point2d>{r}, rr, c.M2, c.D2, R2, P2);
      rect_worst = std::max(rect_worst, std::abs(lr[0].y - rr[0].y));
    }
  }
  std::printf("row difference: raw %.2f px, rectified %.2g px\n", raw_worst, rect_worst);
  EXPECT_GT(raw_worst, 1.0);
  EXPECT_LT(rect_worst, 0.01);
}

TEST(SyntheticGeometry, ImpossibleParametersAreRejected) {
  const auto rejects = [](auto change) {
    SyntheticRendererConfig p = small_params();
    change(p);
    EXPECT_THROW(SyntheticRenderer{p}, std::invalid_argument);
  };
  rejects([](SyntheticRendererConfig& p) { p.rig.baseline_mm = 0; });
  rejects([](SyntheticRendererConfig& p) { p.rig.height_mm = 15; });
  rejects([](SyntheticRendererConfig& p) { p.rig.hfov_deg = 170; });
  rejects([](SyntheticRendererConfig& p) { p.rig.image_size = {8, 8}; });
  rejects([](SyntheticRendererConfig& p) { p.rig.distortion_left[0] = -0.9; });  // folds over inside the image
  rejects([](SyntheticRendererConfig& p) { p.rut.bottom_width_mm = p.rut.width_mm; });
  rejects([](SyntheticRendererConfig& p) { p.rut.pile_left_mm = -1; });
  rejects([](SyntheticRendererConfig& p) { p.rut.depth_mm = NAN; });
  rejects([](SyntheticRendererConfig& p) { p.fps = 0; });
  rejects([](SyntheticRendererConfig& p) { p.supersample = 0; });
  rejects([](SyntheticRendererConfig& p) { p.bit_depth = 12; });
  rejects([](SyntheticRendererConfig& p) { p.depth_profile = {{5, 30}, {5, 40}}; });
  rejects([](SyntheticRendererConfig& p) { p.depth_profile = {{0, 30}, {9, 0}}; });
}

}  // namespace
}  // namespace rutd
