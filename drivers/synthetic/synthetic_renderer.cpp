// The synthetic stereo renderer (synthetic/synthetic_renderer.hpp).
#include "synthetic/synthetic_renderer.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/utility.hpp>

#include "lens_window.hpp"
#include "water_optics.hpp"

namespace rutd {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;
// Marching never advances less than this along z: a sliver of terrain thinner than this above a ray
// could be stepped over. Far below anything the scene contains (the finest feature is a 3 mm groove).
constexpr double kMinStepZmm = 0.01;
// Refinement stops when the ray is this close to the surface along z.
constexpr double kHitToleranceMm = 1e-7;
// Pixel-centre rays are refined until they reproject this close to the pixel.
constexpr double kRayTolerancePx = 1e-6;
constexpr double kAmbient = 0.35;  // fraction of radiance that does not depend on the sun
// A pixel whose hit distance deviates by more than this (second difference) from its row neighbours'
// straddles a silhouette. A smooth surface seen at the rig's scale bends the hit distance by far less
// per pixel; an over-eager test only costs time.
constexpr double kEdgeJumpMm = 1.0;

void require(bool ok, const std::string& field, const std::string& what) {
  if (!ok) throw std::invalid_argument("synthetic: " + field + ": " + what);
}

cv::Matx33d rot_x(double a) {
  const double c = std::cos(a), s = std::sin(a);
  return {1, 0, 0, 0, c, -s, 0, s, c};
}
cv::Matx33d rot_y(double a) {
  const double c = std::cos(a), s = std::sin(a);
  return {c, 0, s, 0, 1, 0, -s, 0, c};
}
cv::Matx33d rot_z(double a) {
  const double c = std::cos(a), s = std::sin(a);
  return {c, -s, 0, s, c, 0, 0, 0, 1};
}

// OpenCV's distortion model (as cv::projectPoints) on normalised coordinates, and its Jacobian.
cv::Vec2d distort(const cv::Vec<double, 5>& k, const cv::Vec2d& n) {
  const double x = n[0], y = n[1], r2 = x * x + y * y;
  const double radial = 1 + r2 * (k[0] + r2 * (k[1] + r2 * k[4]));
  return {x * radial + 2 * k[2] * x * y + k[3] * (r2 + 2 * x * x),
          y * radial + k[2] * (r2 + 2 * y * y) + 2 * k[3] * x * y};
}

cv::Matx22d distortion_jacobian(const cv::Vec<double, 5>& k, const cv::Vec2d& n) {
  const double x = n[0], y = n[1], r2 = x * x + y * y;
  const double radial = 1 + r2 * (k[0] + r2 * (k[1] + r2 * k[4]));
  const double dradial = k[0] + 2 * k[1] * r2 + 3 * k[4] * r2 * r2;  // d radial / d r2
  const double xy = 2 * x * y * dradial + 2 * k[2] * x + 2 * k[3] * y;
  return {radial + 2 * x * x * dradial + 2 * k[2] * y + 6 * k[3] * x, xy, xy,
          radial + 2 * y * y * dradial + 6 * k[2] * y + 2 * k[3] * x};
}

cv::Vec2d to_distorted_normalised(const cv::Matx33d& K, double u, double v) {
  return {(u - K(0, 2)) / K(0, 0), (v - K(1, 2)) / K(1, 1)};
}

// Undistorted normalised coordinates of every pixel centre: Newton steps on OpenCV's forward model
// until the ray reprojects within kRayTolerancePx, started from cv::undistortPoints at the first pixel
// of each row and from the previous pixel's solution (moved by the pixel step) along the row. The
// model must be invertible and orientation-preserving (positive Jacobian determinant) at every pixel.
cv::Mat pixel_centre_rays(const cv::Matx33d& K, const cv::Vec<double, 5>& dist, cv::Size size,
                          const std::string& field) {
  cv::Mat centres(size, CV_64FC2);
  const double f = std::max(K(0, 0), K(1, 1));
  std::atomic<bool> invertible{true};
  cv::parallel_for_(cv::Range(0, size.height), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v) {
      std::vector<cv::Point2d> first{cv::Point2d(0, v)}, undistorted;
      cv::undistortPoints(first, undistorted, K, dist, cv::noArray(), cv::noArray(),
                          cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 20, 1e-9));
      cv::Vec2d n(undistorted[0].x, undistorted[0].y), previous_target = to_distorted_normalised(K, 0, v);
      cv::Vec2d* row = centres.ptr<cv::Vec2d>(v);
      for (int u = 0; u < size.width; ++u) {
        const cv::Vec2d target = to_distorted_normalised(K, u, v);
        if (u > 0) n += distortion_jacobian(dist, n).inv() * (target - previous_target);
        previous_target = target;
        for (int i = 0; i < 8; ++i) {
          const cv::Vec2d step = distortion_jacobian(dist, n).inv() * (distort(dist, n) - target);
          n -= step;
          if (cv::norm(step) * f < 1e-3 * kRayTolerancePx) break;
        }
        if (!(cv::norm(distort(dist, n) - target) * f < kRayTolerancePx) ||
            !(cv::determinant(distortion_jacobian(dist, n)) > 0)) {
          invertible = false;
        }
        row[u] = n;
      }
    }
  });
  require(invertible, field, "the distortion cannot be inverted over the image (not monotonic)");
  return centres;
}

// Illinois false position on [ta, tb] with f(ta) > 0 >= f(tb): converges to the root in the bracket.
// Stops when |f| < tolerance; leaves the last bracket in ta, tb.
template <class F>
double refine_root(const F& f, double& ta, double fa, double& tb, double fb, double tolerance) noexcept {
  int side = 0;
  for (int i = 0; i < 100 && fb != 0; ++i) {
    double t = tb - fb * (tb - ta) / (fb - fa);
    if (!(t > ta && t < tb)) t = 0.5 * (ta + tb);
    const double ft = f(t);
    if (std::abs(ft) < tolerance) return t;
    if (ft > 0) {
      ta = t, fa = ft;
      if (side == 1) fb *= 0.5;
      side = 1;
    } else {
      tb = t, fb = ft;
      if (side == -1) fa *= 0.5;
      side = -1;
    }
    if (tb - ta <= 1e-12 * tb) break;
  }
  return tb;
}

std::uint64_t splitmix64(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// Standard normal deviates from a splitmix64 stream (Box-Muller, both values used). Deterministic.
class Gaussian {
 public:
  explicit Gaussian(std::uint64_t seed) : state_(seed) {}
  double operator()() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double u1 = (static_cast<double>(splitmix64(state_) >> 11) + 0.5) * 0x1.0p-53;
    const double u2 = static_cast<double>(splitmix64(state_) >> 11) * 0x1.0p-53;
    const double r = std::sqrt(-2 * std::log(u1));
    spare_ = r * std::sin(2 * kPi * u2);
    has_spare_ = true;
    return r * std::cos(2 * kPi * u2);
  }

 private:
  std::uint64_t state_;
  double spare_ = 0;
  bool has_spare_ = false;
};

std::uint64_t row_seed(std::uint64_t seed, std::uint64_t index, Camera camera, int row) {
  std::uint64_t state = seed;
  std::uint64_t h = splitmix64(state) ^ index;
  h = splitmix64(h) ^ (static_cast<std::uint64_t>(row) << 1 | (camera == Camera::Right ? 1u : 0u));
  return splitmix64(h);
}

void validate_rig(const RigConfig& rig) {
  for (double v : {rig.baseline_mm, rig.height_mm, rig.roll_deg, rig.pitch_deg, rig.hfov_deg, rig.focal_scale_right,
                   rig.misalign_yaw_deg, rig.misalign_pitch_deg, rig.misalign_roll_deg, rig.principal_offset_left.x,
                   rig.principal_offset_left.y, rig.principal_offset_right.x, rig.principal_offset_right.y}) {
    require(std::isfinite(v), "rig", "every value must be finite");
  }
  require(rig.baseline_mm > 0, "baseline_mm", "must be > 0");
  require(std::abs(rig.roll_deg) < 45, "roll_deg", "must be within (-45, 45)");
  require(std::abs(rig.pitch_deg) < 45, "pitch_deg", "must be within (-45, 45)");
  require(rig.hfov_deg >= 5 && rig.hfov_deg <= 150, "hfov_deg", "must be within [5, 150]");
  require(rig.image_size.width >= 16 && rig.image_size.height >= 16, "image_size", "must be >= 16 x 16");
  require(rig.focal_scale_right > 0, "focal_scale_right", "must be > 0");
  for (double a : {rig.misalign_yaw_deg, rig.misalign_pitch_deg, rig.misalign_roll_deg}) {
    require(std::abs(a) <= 10, "misalign_*_deg", "must be within [-10, 10]");
  }
}

void validate_params(const SyntheticRendererConfig& p) {
  validate_rig(p.rig);
  validate(p.rut, p.depth_profile.empty());
  validate(p.depth_profile);
  require(std::isfinite(p.fps) && p.fps > 0, "fps", "must be > 0");
  require(std::isfinite(p.speed_mm_s), "speed_mm_s", "must be finite");
  require(std::isfinite(p.noise_sigma) && p.noise_sigma >= 0, "noise_sigma", "must be >= 0");
  require(std::isfinite(p.full_well_e) && p.full_well_e >= 0, "full_well_e", "must be >= 0");
  require(std::isfinite(p.exposure) && p.exposure > 0, "exposure", "must be > 0");
  require(p.supersample >= 1 && p.supersample <= 8, "supersample", "must be within [1, 8]");
  require(p.edge_supersample >= 1 && p.edge_supersample <= 8, "edge_supersample", "must be within [1, 8]");
  require(p.bit_depth == 8 || p.bit_depth == 16, "bit_depth", "must be 8 or 16");
  const double tilt = std::sin(std::abs(p.rig.roll_deg) * kDeg) * p.rig.baseline_mm / 2;
  const double pile = std::max(p.rut.pile_left_mm, p.rut.pile_right_mm);
  const double tread = p.rut.tread ? p.rut.tread_depth_mm : 0.0;
  require(p.rig.height_mm - tilt > pile + tread + 10, "height_mm",
          "both cameras must be more than 10 mm above the highest pile");
  const SceneConditions& c = p.conditions;
  double min_depth = p.rut.depth_mm;
  if (!p.depth_profile.empty()) {
    min_depth = p.depth_profile.front().second;
    for (const auto& knot : p.depth_profile) min_depth = std::min(min_depth, knot.second);
  }
  validate(c, min_depth);
  require(p.rig.height_mm > pile + c.grass_height_mm + 10, "grass_height_mm",
          "grass must stay more than 10 mm below the cameras");
  require(std::isfinite(p.gain) && p.gain >= 1, "gain", "must be >= 1");
  require(std::isfinite(p.light) && p.light > 0, "light", "must be > 0");
  const AutoExposureConfig& ae = p.auto_exposure;
  require(std::isfinite(ae.target) && ae.target > 0 && ae.target < 1, "auto_exposure.target", "must be within (0, 1)");
  require(std::isfinite(ae.max_exposure) && ae.max_exposure > 0, "auto_exposure.max_exposure", "must be > 0");
  require(std::isfinite(ae.max_gain) && ae.max_gain >= 1, "auto_exposure.max_gain", "must be >= 1");
  require(std::isfinite(p.right_response) && p.right_response > 0.5 && p.right_response < 2, "right_response",
          "must be within (0.5, 2)");
  require(std::isfinite(p.right_delay_ms) && std::abs(p.right_delay_ms) * p.fps < 1000, "right_delay_ms",
          "must be shorter than a frame period");
}

}  // namespace

void validate(const SyntheticRendererConfig& params) { validate_params(params); }

// ---------------------------------------------------------------------------------------------------
// Ray casting

namespace {

// One ray against one frame's terrain: f(t) = height of the ray above the terrain at parameter t.
struct RayOnTerrain {
  const RutTerrain& terrain;
  const cv::Vec3d& o;
  const cv::Vec3d& d;

  double f(double t) const noexcept {  // on the tabulated terrain (< 1e-9 mm from the exact one)
    return o[2] + t * d[2] - terrain.height_fast(o[0] + t * d[0], o[1] + t * d[1]);
  }
  double f_exact(double t) const noexcept { return o[2] + t * d[2] - terrain.height(o[0] + t * d[0], o[1] + t * d[1]); }
  double slope(double t) const noexcept {  // df/dt
    const cv::Vec2d g = terrain.gradient_fast(o[0] + t * d[0], o[1] + t * d[1]);
    return d[2] - g[0] * d[0] - g[1] * d[1];
  }
  // The root in [ta, tb], f(ta) > 0 >= f(tb), the only one there: bracketed on `fast` (f or a cheaper
  // closed form of it, within 1e-9 mm), polished on the exact terrain.
  template <class Fast>
  double root(const Fast& fast, double ta, double fa, double tb, double fb) const noexcept {
    const auto exact = [this](double t) { return f_exact(t); };
    const double t = refine_root(fast, ta, fa, tb, fb, 0.1 * kHitToleranceMm);
    if (std::abs(f_exact(t)) < kHitToleranceMm) return t;
    // Only if the table were off by more than the tolerance: refine on the exact terrain.
    const double ea = f_exact(ta), eb = f_exact(tb);
    if (!(ea > 0 && eb <= 0)) return t;
    return refine_root(exact, ta, ea, tb, eb, kHitToleranceMm);
  }
  double root(double ta, double fa, double tb, double fb) const noexcept {
    return root([this](double t) { return f(t); }, ta, fa, tb, fb);
  }
};

// First hit with a straight rut without tread, where h = P(x - c) depends on world x only. P splits
// into 15 pieces (flat ground, pile quarters, wall halves, bottom) on each of which it is monotone and
// either convex or concave, with known heights at the ends. Along the ray f(t) = z(t) - P(s(t)) is then
// concave (P convex) or convex on each piece, so the first root is found exactly piece by piece
// without marching: a concave f that is positive at both ends of a piece stays positive; a convex f
// that is positive at both ends dips below 0 only if its minimum (where f' = 0) does; a sign change
// over a piece brackets its only root there.
double cast_straight(const RayOnTerrain& ray, double ta, double t_bottom) noexcept {
  const RutTerrain& terrain = ray.terrain;
  const cv::Vec3d& o = ray.o;
  const cv::Vec3d& d = ray.d;
  const double s0 = o[0] - terrain.shape().lateral_offset_mm;  // profile position at t = 0
  if (d[0] == 0) return (o[2] - terrain.profile(s0)) / -d[2];
  constexpr int kPieces = RutTerrain::kProfilePieces;
  const bool forward = d[0] > 0;  // walking towards larger s
  const double t_per_s = 1.0 / d[0];
  double fa = ray.f(ta);
  if (fa <= 0) return ta;
  for (int step = 0; step < kPieces; ++step) {
    const int k = forward ? step : kPieces - 1 - step;
    const RutTerrain::ProfilePiece& piece = terrain.piece(k);
    // The walk leaves piece k at its end going forward, at the end of piece k - 1 going backward.
    const bool open_end = forward ? k == kPieces - 1 : k == 0;
    const double s_exit = open_end ? 0.0 : (forward ? piece.s_end : terrain.piece(k - 1).s_end);
    double tb = t_bottom;
    if (!open_end) {
      tb = (s_exit - s0) * t_per_s;
      if (tb <= ta) continue;  // behind the start (or a piece of zero width)
    }
    const bool clipped = tb >= t_bottom;
    double fb;
    if (clipped) {
      tb = t_bottom;
      fb = ray.f(tb);
    } else {
      fb = o[2] + tb * d[2] - (forward ? piece.h_end : terrain.piece(k - 1).h_end);
    }
    if (fb <= 0) {
      // f(t) = o_z + t d_z - a - b cos(pi (w0 + w1 t)) on this piece: one table lookup per evaluation.
      const double w0 = piece.g * s0 + piece.m, w1 = piece.g * d[0], z0 = o[2] - piece.a, b = piece.b;
      const auto on_piece = [&](double t) { return z0 + t * d[2] - b * fast_cos_pi(w0 + w1 * t); };
      return ray.root(on_piece, ta, fa, tb, fb);
    }
    const double h_start = k == 0 ? 0.0 : terrain.piece(k - 1).h_end;
    if (!piece.convex && o[2] + tb * d[2] <= std::max(h_start, piece.h_end)) {
      // Convex f, positive at both ends: a root needs a minimum inside with f <= 0.
      const double ga = ray.slope(ta), gb = ray.slope(tb);
      if (ga < 0 && gb > 0) {
        double lo = ta, hi = tb;
        const auto minus_slope = [&ray](double t) { return -ray.slope(t); };
        const double tm = refine_root(minus_slope, lo, -ga, hi, -gb, 1e-12);
        const double fm = ray.f(tm);
        if (fm <= 0) return ray.root(ta, fa, tm, fm);
      }
    }
    if (clipped) return tb;  // unreachable: f(t_bottom) <= 0 as h >= min_height
    ta = tb, fa = fb;
  }
  return t_bottom;
}

}  // namespace

double cast_ray(const RutTerrain& terrain, const cv::Vec3d& o, const cv::Vec3d& d) noexcept {
  if (!(d[2] < 0)) return -1;
  const double inv = -1.0 / d[2];
  const double t_top = std::max(0.0, (o[2] - terrain.max_height()) * inv);
  const double t_bottom = (o[2] - terrain.min_height()) * inv;
  if (t_bottom <= 0) return -1;
  const double xa = o[0] + t_top * d[0], xb = o[0] + t_bottom * d[0];
  const double x_lo = std::min(xa, xb), x_hi = std::max(xa, xb);
  if (x_hi < terrain.disturbed_x_min() || x_lo > terrain.disturbed_x_max()) return o[2] * inv;
  const RutShape& shape = terrain.shape();
  if (!shape.tread && shape.wander_amplitude_mm == 0 && x_lo >= shape.lateral_offset_mm - shape.bottom_width_mm / 2 &&
      x_hi <= shape.lateral_offset_mm + shape.bottom_width_mm / 2) {
    return (o[2] + shape.depth_mm) * inv;  // the whole slab crossing lies over the flat bottom
  }
  const RayOnTerrain ray{terrain, o, d};
  if (!shape.tread && shape.wander_amplitude_mm == 0) return cast_straight(ray, t_top, t_bottom);
  // March and bracket on the tabulated terrain (error < 1e-9 mm, far below the 0.01 mm sliver the
  // marching may step over anyway); the root itself is polished on the exact terrain.
  const auto f = [&ray](double t) { return ray.f(t); };
  // f(t) = ray height above the terrain. |f'| <= lipschitz, so a step of f / lipschitz never passes a
  // root ("safe" step). |f''| <= curvature: when the secant over [ta, tb] falls faster than
  // curvature * (tb - ta), f is strictly decreasing on it and has at most one root there. Bolder steps
  // (aimed just past the secant-predicted root) are kept only when one of these proves them safe.
  const double lipschitz = -d[2] + terrain.max_slope_x() * std::abs(d[0]) + terrain.max_slope_y() * std::abs(d[1]);
  const double curvature = terrain.max_curvature() * (d[0] * d[0] + d[1] * d[1]);
  const double min_step = kMinStepZmm * inv;
  double ta = t_top, fa = f(ta), slope = 0;
  if (fa <= 0) return ta;
  for (;;) {
    const double safe = std::max(fa / lipschitz, min_step);
    double step = safe;
    if (slope < 0) {  // bold only where the monotonicity test can pass: width < |slope| / curvature
      const double bold = 1.2 * fa / -slope;
      if (bold > safe && bold * curvature < 0.5 * -slope) step = bold;
    }
    for (;;) {
      const double tb = std::min(ta + step, t_bottom);
      const double fb = f(tb);
      const double width = tb - ta;
      const bool decreasing = fa - fb > curvature * width * width;
      const bool bold = step > safe;
      if (fb <= 0) {
        if (!bold || decreasing) return ray.root(ta, fa, tb, fb);
      } else if (!bold || decreasing || fa + fb >= lipschitz * width) {
        if (tb >= t_bottom) return tb;  // unreachable: f(t_bottom) <= 0 as h >= min_height
        slope = (fb - fa) / width;
        ta = tb, fa = fb;
        break;
      }
      step = safe;  // the bold step was not provably safe: retry with the safe one
    }
  }
}

// ---------------------------------------------------------------------------------------------------
// Construction

SyntheticRenderer::SyntheticRenderer(const SyntheticRendererConfig& params)
    : params_(params), texture_((validate_params(params), params.texture), params.seed) {
  const RigConfig& rig = params_.rig;
  const cv::Size size = rig.image_size;
  const double f = (size.width / 2.0) / std::tan(rig.hfov_deg * kDeg / 2);
  const double fr = f * rig.focal_scale_right;
  const double cx = (size.width - 1) / 2.0, cy = (size.height - 1) / 2.0;
  left_.K = {f, 0, cx + rig.principal_offset_left.x, 0, f, cy + rig.principal_offset_left.y, 0, 0, 1};
  right_.K = {fr, 0, cx + rig.principal_offset_right.x, 0, fr, cy + rig.principal_offset_right.y, 0, 0, 1};
  left_.dist = rig.distortion_left;
  right_.dist = rig.distortion_right;

  const cv::Matx33d rig_rotation = rot_y(rig.roll_deg * kDeg) * rot_x(rig.pitch_deg * kDeg);
  const cv::Matx33d looking_down(1, 0, 0, 0, -1, 0, 0, 0, -1);
  const cv::Matx33d misalignment =
      rot_z(rig.misalign_roll_deg * kDeg) * rot_y(rig.misalign_yaw_deg * kDeg) * rot_x(rig.misalign_pitch_deg * kDeg);
  left_.world_from_camera = rig_rotation * looking_down;
  // The calibration written below keeps `misalignment`; SceneConditions may turn the real camera further.
  const cv::Matx33d error =
      rot_z(params_.conditions.right_roll_error_deg * kDeg) * rot_x(params_.conditions.right_pitch_error_deg * kDeg);
  right_.world_from_camera = left_.world_from_camera * (error * misalignment).t();
  left_.rig_offset = rig_rotation * cv::Vec3d(-rig.baseline_mm / 2, 0, 0);
  right_.rig_offset = rig_rotation * cv::Vec3d(rig.baseline_mm / 2, 0, 0);
  left_.centres = pixel_centre_rays(left_.K, left_.dist, size, "distortion_left");
  right_.centres = pixel_centre_rays(right_.K, right_.dist, size, "distortion_right");

  calibration_.image_size = size;
  calibration_.M1 = left_.K;
  calibration_.M2 = right_.K;
  calibration_.D1 = cv::Mat(cv::Matx<double, 1, 5>(left_.dist.val)).clone();
  calibration_.D2 = cv::Mat(cv::Matx<double, 1, 5>(right_.dist.val)).clone();
  calibration_.R = misalignment;
  calibration_.T = misalignment * cv::Vec3d(-rig.baseline_mm, 0, 0);

  cv::Mat R1, R2, P1, P2, Q;
  cv::stereoRectify(calibration_.M1, calibration_.D1, calibration_.M2, calibration_.D2, size, calibration_.R,
                    calibration_.T, R1, R2, P1, P2, Q, cv::CALIB_ZERO_DISPARITY);
  truth_rotation_ = cv::Matx33d(R1);
  const SceneConditions& conditions = params_.conditions;
  sun_ = cv::normalize(conditions.sky.sun);
  if (conditions.water.level_mm > 0 || conditions.water.surface_depth_mm > 0)
    water_ = std::make_shared<const WaterOptics>(conditions.water, conditions.sky, sun_, kAmbient, params_.seed);
  window_[0] = LensWindow::make(conditions.lens, Camera::Left, left_.centres, left_.K(0, 0), params_.seed);
  window_[1] = LensWindow::make(conditions.lens, Camera::Right, right_.centres, right_.K(0, 0), params_.seed);
}

// ---------------------------------------------------------------------------------------------------
// Geometry queries

double SyntheticRenderer::vehicle_y(std::uint64_t index) const noexcept {
  return static_cast<double>(index) * params_.speed_mm_s / params_.fps;
}

double SyntheticRenderer::depth_mm(std::uint64_t index) const noexcept {
  return depth_at(params_.depth_profile, params_.rut.depth_mm, index);
}

cv::Matx33d SyntheticRenderer::camera_rotation(Camera camera) const { return model(camera).world_from_camera; }

cv::Vec3d SyntheticRenderer::camera_centre(Camera camera, std::uint64_t index) const {
  const double delay_y = camera == Camera::Right ? params_.speed_mm_s * params_.right_delay_ms * 1e-3 : 0.0;
  return cv::Vec3d(0, vehicle_y(index) + delay_y, params_.rig.height_mm) + model(camera).rig_offset;
}

namespace {

// Ray (x, y, 1) of the sample (du, dv) pixels from the pixel centre whose undistorted normalised
// coordinates are `centre`; `inverse_jacobian` = inverse distortion Jacobian at `centre`.
cv::Vec3d sample_ray(const cv::Matx33d& K, const cv::Vec2d& centre, const cv::Matx22d& inverse_jacobian, double du,
                     double dv) {
  const cv::Vec2d n = centre + inverse_jacobian * cv::Vec2d(du / K(0, 0), dv / K(1, 1));
  return {n[0], n[1], 1.0};
}

}  // namespace

cv::Vec3d SyntheticRenderer::pixel_ray(Camera camera, int u, int v, double du, double dv) const {
  const CameraModel& m = model(camera);
  const cv::Vec2d centre = m.centres.at<cv::Vec2d>(v, u);
  return sample_ray(m.K, centre, distortion_jacobian(m.dist, centre).inv(), du, dv);
}

double SyntheticRenderer::lens_transmission(Camera camera, int u, int v) const {
  const auto& window = window_[camera == Camera::Left ? 0 : 1];
  return window ? window->transmission(u, v) : 1.0;
}

std::optional<cv::Vec3d> SyntheticRenderer::intersect_left(std::uint64_t index, const cv::Vec3d& dir) const {
  const RutTerrain terrain(params_.rut, depth_mm(index));
  const cv::Vec3d origin = camera_centre(Camera::Left, index);
  const cv::Vec3d world_dir = left_.world_from_camera * dir;
  const double t = cast_ray(terrain, origin, world_dir);
  if (t < 0) return std::nullopt;
  return dir * t;
}

// ---------------------------------------------------------------------------------------------------
// Rendering

std::vector<StereoFrame> SyntheticRenderer::render_pairs(std::size_t count) const {
  std::vector<StereoFrame> pairs(count);
  for (std::size_t i = 0; i < count; ++i) render(i, pairs[i]);
  return pairs;
}

CameraSettings SyntheticRenderer::render(std::uint64_t index, StereoFrame& out) const {
  const RutTerrain terrain(params_.rut, depth_mm(index));
  const cv::Size size = params_.rig.image_size;
  const int type = params_.bit_depth == 16 ? CV_16UC1 : CV_8UC1;
  out.left.create(size, type);
  out.right.create(size, type);
  // Radiance first, for the whole image: the window's faults mix neighbouring pixels and auto exposure
  // meters the whole frame before the sensor turns radiance into grey levels.
  thread_local cv::Mat scratch[3];
  cv::Mat* radiance = scratch;  // the calling thread's: workers below see their own thread_locals
  cv::Mat& filtered = scratch[2];
  radiance[0].create(size, CV_64F);
  radiance[1].create(size, CV_64F);
  const double frame_time = static_cast<double>(index) / params_.fps;
  const double delay = params_.right_delay_ms * 1e-3;
  // Below the rut's bottom (a pool's surface on a frame where the rut is shallower), no ray meets it first.
  const WaterConfig& water = params_.conditions.water;
  const double water_z = !water_                      ? std::numeric_limits<double>::quiet_NaN()
                         : water.surface_depth_mm > 0 ? -water.surface_depth_mm
                                                      : -terrain.shape().depth_mm + water.level_mm;
  const Exposure exposures[2] = {
      {left_, terrain, camera_centre(Camera::Left, index), frame_time, vehicle_y(index), water_z},
      {right_, terrain, camera_centre(Camera::Right, index), frame_time + delay,
       vehicle_y(index) + params_.speed_mm_s * delay, water_z}};
  const int rows = size.height;
  cv::parallel_for_(cv::Range(0, 2 * rows), [&](const cv::Range& range) {
    for (int r = range.start; r < range.end; ++r) {
      render_row(exposures[r / rows], r % rows, radiance[r / rows].ptr<double>(r % rows));
    }
  });
  for (int k = 0; k < 2; ++k) {
    if (!window_[k]) continue;
    window_[k]->apply(radiance[k], filtered);
    std::swap(radiance[k], filtered);
  }
  const CameraSettings settings =
      params_.auto_exposure.enabled ? settle_exposure(radiance[0]) : CameraSettings{params_.exposure, params_.gain};
  expose(Camera::Left, index, radiance[0], settings, out.left);
  expose(Camera::Right, index, radiance[1], settings, out.right);
  out.seq = index;
  out.t_ns = std::llround(static_cast<double>(index) * 1e9 / params_.fps);
  out.skew_ns = std::llround(params_.right_delay_ms * 1e6);
  out.clock = ClockKind::Monotonic;
  return settings;
}

CameraSettings SyntheticRenderer::settle_exposure(const cv::Mat& left_radiance) const {
  // The grey level at gain 1 and exposure 1 is 255 light L: the median is held at target by exposure,
  // then gain.
  thread_local std::vector<double> values;
  values.assign(left_radiance.begin<double>(), left_radiance.end<double>());
  const auto mid = values.begin() + static_cast<long>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  const AutoExposureConfig& ae = params_.auto_exposure;
  const double needed = ae.target / std::max(params_.light * *mid, 1e-9);  // exposure x gain
  CameraSettings s;
  s.exposure = std::min(needed, ae.max_exposure);
  s.gain = std::clamp(needed / s.exposure, 1.0, ae.max_gain);
  return s;
}

void SyntheticRenderer::expose(Camera camera, std::uint64_t index, const cv::Mat& radiance, CameraSettings settings,
                               cv::Mat& image) const {
  const double response = camera == Camera::Right ? params_.right_response : 1.0;
  const double scale = 255.0 * settings.exposure * params_.light * response;  // grey levels at gain 1
  const double gain = settings.gain;
  const double read_var = params_.noise_sigma * params_.noise_sigma;
  const double shot_gain = params_.full_well_e > 0 ? 255.0 / params_.full_well_e : 0.0;
  const bool noisy = read_var > 0 || shot_gain > 0;
  cv::parallel_for_(cv::Range(0, image.rows), [&](const cv::Range& range) {
    for (int row = range.start; row < range.end; ++row) {
      Gaussian gauss(row_seed(params_.seed, index, camera, row));
      const double* in = radiance.ptr<double>(row);
      for (int u = 0; u < image.cols; ++u) {
        double signal = scale * in[u];  // grey levels of the 8-bit scale at gain 1
        if (noisy) signal += std::sqrt(read_var + shot_gain * std::max(signal, 0.0)) * gauss();
        if (gain != 1) signal *= gain;
        if (image.depth() == CV_8U) {
          image.ptr<std::uint8_t>(row)[u] = cv::saturate_cast<std::uint8_t>(signal);
        } else {
          image.ptr<std::uint16_t>(row)[u] = cv::saturate_cast<std::uint16_t>(signal * 257.0);
        }
      }
    }
  });
}

double SyntheticRenderer::radiance(const cv::Vec3d& p, const cv::Vec2d& g, double footprint_mm,
                                   double water_z) const noexcept {
  const double cosine = (-g[0] * sun_[0] - g[1] * sun_[1] + sun_[2]) / std::sqrt(1 + g.dot(g));
  const double light = kAmbient + (1 - kAmbient) * std::max(0.0, cosine);
  const float albedo = params_.band_limit ? texture_.albedo(p, footprint_mm) : texture_.albedo(p);
  const double dry = static_cast<float>(light) * albedo;
  if (!water_) return dry;
  // Wet soil: under the water, and over the capillary fringe above it, fading out at its top.
  const WaterConfig& w = water_->config();
  if (!(p[2] < water_z + w.wet_fringe_mm)) return dry;
  const double up = w.wet_fringe_mm > 0 ? std::clamp((p[2] - water_z) / w.wet_fringe_mm, 0.0, 1.0) : 1.0;
  return dry * (w.wet_albedo_factor + (1 - w.wet_albedo_factor) * up);
}

namespace {

// Surface distance between neighbouring samples at the hit p = o + t d (ray differentials on the
// tangent plane of normal n): dd_u, dd_v are the ray's changes per sample step along u and v.
double sample_footprint(const cv::Vec3d& d, double t, const cv::Vec3d& n, const cv::Vec3d& dd_u,
                        const cv::Vec3d& dd_v) {
  const double nd = n.dot(d);
  if (!(nd < 0)) return 1e9;  // grazing: no detail survives
  const cv::Vec3d pu = t * (dd_u - d * (n.dot(dd_u) / nd));
  const cv::Vec3d pv = t * (dd_v - d * (n.dot(dd_v) / nd));
  return std::sqrt(std::max(pu.dot(pu), pv.dot(pv)));
}

}  // namespace

double SyntheticRenderer::sample_radiance(const Exposure& e, const cv::Vec3d& dir, const cv::Vec3d& dd_u,
                                          const cv::Vec3d& dd_v, double& t, SampleKind& kind) const noexcept {
  const RutTerrain& terrain = e.terrain;
  t = cast_ray(terrain, e.origin, dir);
  // The water's surface, where the ray meets it before the terrain: it lies over the pool there.
  double t_water = -1;
  if (water_ && dir[2] < 0) {
    const double t_plane = (e.water_z - e.origin[2]) / dir[2];
    if (t_plane > 0 && (t <= 0 || t_plane < t)) t_water = t_plane;
  }
  if (params_.conditions.grass_height_mm > 0) {
    const double blade = blade_radiance(terrain, e.origin, dir, t_water > 0 ? t_water : t);
    if (blade >= 0) {
      kind = SampleKind::Blade;
      return blade;
    }
  }
  if (t_water > 0) {
    kind = SampleKind::Water;
    const double spread = std::max(cv::norm(dd_u), cv::norm(dd_v)) / cv::norm(dir);
    const WaterOptics::Ray ray{
        e.origin, dir,      t_water, sample_footprint(dir, t_water, cv::Vec3d(0, 0, 1), dd_u, dd_v),
        spread,   e.time_s, e.rig_y};
    return water_->radiance(terrain, e.water_z, ray, texture_, params_.band_limit);
  }
  if (t <= 0) {
    kind = SampleKind::Nothing;
    return 0;
  }
  kind = SampleKind::Soil;
  const cv::Vec3d p = e.origin + t * dir;
  const cv::Vec2d g = terrain.gradient_fast(p[0], p[1]);
  return radiance(p, g, sample_footprint(dir, t, cv::Vec3d(-g[0], -g[1], 1), dd_u, dd_v), e.water_z);
}

double SyntheticRenderer::pixel_radiance(const Exposure& e, const cv::Vec2d& centre, int n, double& t_centre,
                                         SampleKind& kind) const noexcept {
  const CameraModel& m = e.model;
  const cv::Matx22d inverse_jacobian = distortion_jacobian(m.dist, centre).inv();
  // World ray change per sample step (1/n pixel) along u and v, for the texture footprint.
  const cv::Vec2d step_u = inverse_jacobian * cv::Vec2d(1.0 / (n * m.K(0, 0)), 0);
  const cv::Vec2d step_v = inverse_jacobian * cv::Vec2d(0, 1.0 / (n * m.K(1, 1)));
  const cv::Vec3d dd_u = m.world_from_camera * cv::Vec3d(step_u[0], step_u[1], 0);
  const cv::Vec3d dd_v = m.world_from_camera * cv::Vec3d(step_v[0], step_v[1], 0);
  double sum = 0;
  t_centre = -1;
  kind = SampleKind::Nothing;
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      const double du = (i + 0.5) / n - 0.5, dv = (j + 0.5) / n - 0.5;
      const cv::Vec3d dir = m.world_from_camera * sample_ray(m.K, centre, inverse_jacobian, du, dv);
      double t = -1;
      SampleKind seen = SampleKind::Nothing;
      sum += sample_radiance(e, dir, dd_u, dd_v, t, seen);
      if (2 * i + 1 == n && 2 * j + 1 == n) t_centre = t * cv::norm(dir), kind = seen;
    }
  }
  return sum / (n * n);
}

void SyntheticRenderer::render_row(const Exposure& e, int row, double* out) const {
  const int n = params_.supersample;
  const int n_edge = n == 1 ? params_.edge_supersample : 1;
  const cv::Vec2d* centres = e.model.centres.ptr<cv::Vec2d>(row);
  const int cols = params_.rig.image_size.width;
  // A sliding window over the row: pixel u is finished once u + 1 is rendered, so its hit distance can
  // be compared with both neighbours'. A kink-free surface changes the hit distance smoothly from pixel
  // to pixel; a jump (a silhouette, where a pile hides what lies behind it), or a change of what is seen
  // (the waterline, a blade), is rendered again with n_edge x n_edge samples so the edge is
  // anti-aliased.
  double dist[3] = {-1, -1, -1}, value[3] = {0, 0, 0};  // previous, current, next pixel
  SampleKind kind[3] = {SampleKind::Nothing, SampleKind::Nothing, SampleKind::Nothing};
  value[2] = pixel_radiance(e, centres[0], n, dist[2], kind[2]);
  for (int u = 0; u < cols; ++u) {
    dist[0] = dist[1], value[0] = value[1], kind[0] = kind[1];
    dist[1] = dist[2], value[1] = value[2], kind[1] = kind[2];
    if (u + 1 < cols) value[2] = pixel_radiance(e, centres[u + 1], n, dist[2], kind[2]);
    double mean = value[1];
    if (n_edge > 1 && u > 0 && u + 1 < cols) {
      const int misses = (dist[0] < 0) + (dist[1] < 0) + (dist[2] < 0);  // rays above the horizon
      const bool jump = misses == 0 ? std::abs(dist[2] - 2 * dist[1] + dist[0]) > kEdgeJumpMm : misses < 3;
      if (jump || kind[0] != kind[1] || kind[2] != kind[1]) {
        double unused = 0;
        SampleKind ignored = SampleKind::Nothing;
        mean = pixel_radiance(e, centres[u], n_edge, unused, ignored);
      }
    }
    out[u] = mean;
  }
}

// ---------------------------------------------------------------------------------------------------
// Grass

namespace {

double unit_draw(std::uint64_t& state) { return static_cast<double>(splitmix64(state) >> 11) * 0x1.0p-53; }

}  // namespace

double SyntheticRenderer::blade_radiance(const RutTerrain& terrain, const cv::Vec3d& o, const cv::Vec3d& d,
                                         double t) const noexcept {
  const SceneConditions& c = params_.conditions;
  if (!(d[2] < 0)) return -1;
  if (c.grass_height_mm <= 0) return -1;
  // Blades: one per cell, a leaning cylinder from the terrain up; the nearest one the ray passes within
  // its radius, in front of the terrain hit, is seen.
  const double top = terrain.max_height() + c.grass_height_mm;
  const double t0 = (top - o[2]) / d[2];
  const double t1 = t > 0 ? t : (terrain.min_height() - o[2]) / d[2];
  if (t1 <= 0) return -1;
  const cv::Vec3d a = o + std::max(t0, 0.0) * d, b = o + t1 * d;
  // A blade's tip leans at most 0.4 of its length (at most the grass height) along either axis, and its
  // radius is at most 1.2: in plan, along either axis, no blade reaches further from its foot.
  const double reach = 0.4 * c.grass_height_mm + 1.2;
  const double cell = c.grass_spacing_mm;
  const int i0 = int(std::floor((std::min(a[0], b[0]) - reach) / cell));
  const int i1 = int(std::floor((std::max(a[0], b[0]) + reach) / cell));
  const int j0 = int(std::floor((std::min(a[1], b[1]) - reach) / cell));
  const int j1 = int(std::floor((std::max(a[1], b[1]) + reach) / cell));
  double best_t = t > 0 ? t : 1e300, best = -1;
  const double half_width = 0.5 * terrain.shape().width_mm;
  const cv::Vec2d ray_a(a[0], a[1]), ray_plan(b[0] - a[0], b[1] - a[1]);
  const double ray_plan_sq = ray_plan.dot(ray_plan);
  for (int i = i0; i <= i1; ++i) {
    for (int j = j0; j <= j1; ++j) {
      std::uint64_t state = params_.seed * 0x2545F4914F6CDD1Dull ^ (std::uint64_t(std::uint32_t(i)) << 32) ^
                            std::uint64_t(std::uint32_t(j));
      const double bx = (i + unit_draw(state)) * cell, by = (j + unit_draw(state)) * cell;
      if (std::abs(bx - terrain.centreline_x(by)) < half_width) continue;  // the tyre flattened it
      const double length = c.grass_height_mm * (0.4 + 0.6 * unit_draw(state));
      const double lean_y = unit_draw(state), lean_x = unit_draw(state);  // y first: the order fixes the scene
      const cv::Vec3d axis(0.8 * length * (lean_x - 0.5), 0.8 * length * (lean_y - 0.5), length);
      const double radius = 0.6 + 0.6 * unit_draw(state);
      // Seen from above, the blade (foot to tip, widened by its radius) must reach the line of the ray's
      // plan: the plan distance is a lower bound of the distance in space, so this skips only blades the
      // ray misses, before the terrain's height (the costly part) is looked up.
      const double side = ray_plan[0] * (by - ray_a[1]) - ray_plan[1] * (bx - ray_a[0]);  // offset x |ray_plan|
      const double lean = std::sqrt(axis[0] * axis[0] + axis[1] * axis[1]) + radius;
      if (side * side > lean * lean * ray_plan_sq) continue;
      const double shade = 0.25 + 0.35 * unit_draw(state), phase = 6.0 * unit_draw(state);
      const cv::Vec3d base(bx, by, terrain.height_fast(bx, by));
      const cv::Vec3d w0 = o - base;
      const double aa = d.dot(d), ab = d.dot(axis), cc = axis.dot(axis), dd = d.dot(w0), ee = axis.dot(w0);
      const double den = aa * cc - ab * ab;
      if (den <= 1e-12) continue;
      const double tc = (ab * ee - cc * dd) / den, sc = (aa * ee - ab * dd) / den;
      if (sc < 0 || sc > 1 || tc <= 0 || tc >= best_t) continue;
      const cv::Vec3d gap = (o + tc * d) - (base + sc * axis);
      if (gap.dot(gap) > radius * radius) continue;
      best_t = tc;
      // Darker near the soil, veined along the blade.
      best = shade * (0.55 + 0.45 * sc) * (0.75 + 0.25 * std::sin(2 * kPi * 3 * sc + phase));
    }
  }
  return best;
}

// ---------------------------------------------------------------------------------------------------
// Ground truth

RutTruth SyntheticRenderer::truth(std::uint64_t index) const {
  const RutTerrain terrain(params_.rut, depth_mm(index));
  const RutShape& shape = terrain.shape();
  const cv::Matx33d world_from_rect = left_.world_from_camera * truth_rotation_.t();
  const cv::Vec3d a(world_from_rect(0, 0), world_from_rect(1, 0), world_from_rect(2, 0));  // rect X
  const cv::Vec3d b(world_from_rect(0, 2), world_from_rect(1, 2), world_from_rect(2, 2));  // rect Z
  const cv::Vec3d centre = camera_centre(Camera::Left, index);
  // Ground z = 0 in the plane Y = 0: centre + X a + Z b with z = 0 gives Z = m X + c.
  const double m = -a[2] / b[2], c = -centre[2] / b[2];
  const cv::Vec3d along = a + m * b;  // world displacement per unit X along the ground line
  // Points of the plane Y = 0 at world height z: centre + X a + Z b with Z = m_z X + c_z.
  const auto level_point = [&](double X, double z) {
    return centre + X * a + (((z - centre[2]) - a[2] * X) / b[2]) * b;
  };
  const auto ground_point = [&](double X) { return centre + X * a + (m * X + c) * b; };
  const auto s_at = [&](double X, double z) {
    const cv::Vec3d p = z == 0 ? ground_point(X) : level_point(X, z);
    return p[0] - terrain.centreline_x(p[1]);
  };
  // X where the line of height z in the plane crosses lateral distance s_target from the centreline.
  const auto crossing_at = [&](double s_target, double z) {
    const double dx = z == 0 ? along[0] : level_point(1, z)[0] - level_point(0, z)[0];
    double X = (s_target - s_at(0, z)) / dx;
    for (int i = 0; i < 60; ++i) {  // Newton; s is linear in X unless the rut wanders
      const double h = 1e-3;
      const double slope = (s_at(X + h, z) - s_at(X - h, z)) / (2 * h);
      const double step = (s_at(X, z) - s_target) / slope;
      X -= step;
      if (std::abs(step) < 1e-12) break;
    }
    return X;
  };
  const auto crossing = [&](double s_target) { return crossing_at(s_target, 0.0); };
  const double x_minus = crossing(-shape.width_mm / 2), x_plus = crossing(shape.width_mm / 2);
  const double k = 1.0 / std::sqrt(a[2] * a[2] + b[2] * b[2]);  // world height -> height above the line
  const double stretch = std::sqrt(1 + m * m);                  // length along the line per unit X

  RutTruth t;
  t.index = index;
  t.depth_mm = shape.depth_mm * k;
  t.width_mm = std::abs(x_plus - x_minus) * stretch;
  const bool flipped = x_minus > x_plus;
  t.left_pile_mm = (flipped ? shape.pile_right_mm : shape.pile_left_mm) * k;
  t.right_pile_mm = (flipped ? shape.pile_left_mm : shape.pile_right_mm) * k;
  if (shape.wander_amplitude_mm == 0) {
    const double world_area = shape.depth_mm * (shape.bottom_width_mm + (shape.width_mm - shape.bottom_width_mm) / 2);
    t.area_mm2 = world_area * k * stretch / std::abs(along[0]);
  } else {  // composite Simpson over the cross-section
    constexpr int kIntervals = 20000;
    const double lo = std::min(x_minus, x_plus), hi = std::max(x_minus, x_plus);
    const double h = (hi - lo) / kIntervals;
    double sum = 0;
    for (int i = 0; i <= kIntervals; ++i) {
      const double w = (i == 0 || i == kIntervals) ? 1 : (i % 2 ? 4 : 2);
      sum += w * -terrain.profile(s_at(lo + i * h, 0.0));
    }
    t.area_mm2 = sum * h / 3 * k * stretch;
  }
  t.ground_slope_deg = std::atan(m) / kDeg;
  t.center_x_mm = (x_minus + x_plus) / 2;
  t.tread_depth_mm = shape.tread ? shape.tread_depth_mm * k : 0.0;
  t.y_mm = vehicle_y(index);
  const WaterConfig& water = params_.conditions.water;
  const double level =
      water.surface_depth_mm > 0 ? std::max(0.0, shape.depth_mm - water.surface_depth_mm) : water.level_mm;
  if (level > 0) {
    // The surface meets each wall where -D (1 + cos(pi u)) / 2 = level - D, u across the wall.
    const double u = std::acos(1 - 2 * level / shape.depth_mm) / kPi;
    const double s = shape.bottom_width_mm / 2 + u * (shape.width_mm - shape.bottom_width_mm) / 2;
    const double z = level - shape.depth_mm;
    const double x_a = crossing_at(-s, z), x_b = crossing_at(s, z);
    t.water_depth_mm = level * k;
    t.waterline_depth_mm = (shape.depth_mm - level) * k;
    t.waterline_left_x_mm = std::min(x_a, x_b);
    t.waterline_right_x_mm = std::max(x_a, x_b);
  }
  t.right_delay_ns = std::llround(params_.right_delay_ms * 1e6);
  t.exposure = params_.exposure;
  t.gain = params_.gain;
  return t;
}

}  // namespace rutd
