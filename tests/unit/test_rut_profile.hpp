#pragma once
// Analytic rut terrain for the rut/ tests, written independently of rut/extract.cpp: the truth the
// tests assert against comes from here and from closed-form expressions, never from the code tested.
//
// Terrain frame: u across the rut, v height above undisturbed ground (towards the camera), mm.
// Profile (symmetric about u = center_u): flat bottom of width `bottom` at v = -depth; raised-cosine
// walls up to the opening of width `top` (v = 0, zero slope there); sin^2 piles of width pile_width
// and heights left_pile / right_pile outside the opening; flat ground (v = 0) elsewhere.
// Camera frame (X, Z): the terrain rolled by roll_deg in the X-Z plane and seen from ground_z:
//   X = u cos(r) - v sin(r),  Z = ground_z - (u sin(r) + v cos(r)).
#include <cmath>
#include <limits>
#include <random>

#include <opencv2/core.hpp>

#include "rut/extract.hpp"

namespace rutd::test {

constexpr double kPi = 3.14159265358979323846;

struct RutShape {
  double depth = 40.0;
  double bottom = 100.0;  // flat bottom width
  double top = 200.0;     // opening width (where the walls meet the ground)
  double pile_width = 60.0;
  double left_pile = 15.0;
  double right_pile = 15.0;
  double center_u = 0.0;

  // Closed-form truths (core/rut_measurement.hpp definitions).
  double width() const { return top; }
  // Bottom rectangle plus two raised-cosine walls, each of area depth * wall / 2.
  double area() const { return depth * bottom + depth * (top - bottom) / 2.0; }
};

struct View {
  double ground_z = 1500.0;
  double roll_deg = 0.0;
  double roll() const { return roll_deg * kPi / 180.0; }
  double center_x(const RutShape& s) const { return s.center_u * std::cos(roll()); }
  double slope_deg() const { return -roll_deg; }  // ground: Z = ground_z - X tan(r)
};

inline double terrain_height(const RutShape& s, double u) {
  const double a = std::abs(u - s.center_u);
  const double half_bottom = s.bottom / 2.0, half_top = s.top / 2.0;
  if (a <= half_bottom) return -s.depth;
  if (a <= half_top) {
    const double t = (a - half_bottom) / (half_top - half_bottom);
    return -s.depth * 0.5 * (1.0 + std::cos(kPi * t));
  }
  if (a <= half_top + s.pile_width) {
    const double pile = u < s.center_u ? s.left_pile : s.right_pile;
    const double sn = std::sin(kPi * (a - half_top) / s.pile_width);
    return pile * sn * sn;
  }
  return 0.0;
}

inline cv::Point2d camera_point(const RutShape& s, const View& v, double u) {
  const double h = terrain_height(s, u);
  const double r = v.roll();
  return {u * std::cos(r) - h * std::sin(r), v.ground_z - (u * std::sin(r) + h * std::cos(r))};
}

// Z of the terrain at camera X (X(u) is monotonic for the slopes used here): bisection on u.
inline double z_at_x(const RutShape& s, const View& v, double x) {
  double lo = x / std::cos(v.roll()) - 400.0, hi = x / std::cos(v.roll()) + 400.0;
  for (int i = 0; i < 80; ++i) {
    const double mid = 0.5 * (lo + hi);
    (camera_point(s, v, mid).x < x ? lo : hi) = mid;
  }
  return camera_point(s, v, 0.5 * (lo + hi)).y;
}

// Cross-section sampled at X = x0 + i dx, i < n, with Gaussian noise of `sigma` mm per bin.
inline CrossSection make_section(const RutShape& s, const View& v, double x0, int n, double dx, double sigma = 0.0,
                                 unsigned seed = 1) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma > 0.0 ? sigma : 1.0);
  CrossSection c;
  c.x0_mm = x0;
  c.dx_mm = dx;
  for (int i = 0; i < n; ++i) {
    c.z_mm.push_back(z_at_x(s, v, x0 + i * dx) + (sigma > 0.0 ? noise(rng) : 0.0));
    c.count.push_back(1);
  }
  return c;
}

// Strip of rows x cols 3D points (CV_32FC3), columns at u = u0 + j du, row r at Y = r mm, Gaussian
// noise of `sigma` mm along Z on every point.
inline cv::Mat make_strip(const RutShape& s, const View& v, double u0, double du, int cols, int rows, double sigma,
                          unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma > 0.0 ? sigma : 1.0);
  cv::Mat xyz(rows, cols, CV_32FC3);
  for (int r = 0; r < rows; ++r) {
    for (int j = 0; j < cols; ++j) {
      const cv::Point2d p = camera_point(s, v, u0 + j * du);
      const double z = p.y + (sigma > 0.0 ? noise(rng) : 0.0);
      xyz.at<cv::Vec3f>(r, j) = cv::Vec3f(float(p.x), float(r), float(z));
    }
  }
  return xyz;
}

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

}  // namespace rutd::test
