// A camera's protective window and what lies on it, out of focus (lens_window.hpp).
#include "lens_window.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

#include <opencv2/imgproc.hpp>

namespace rutd {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kWaterIndex = 1.333;
constexpr int kDiscSamples = 64;  // rays per pixel through drops (their deflection varies across the disc)

std::uint64_t mix(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// The window in normalised image coordinates, one cell per pixel of focal length: opacity A, own
// radiance S (premultiplied by A), and drops (deflection in px, x and y, and the drop's cover D).
struct Grid {
  cv::Point2d origin;  // normalised coordinates of cell (0, 0)
  double f = 1;        // cells per normalised unit
  cv::Mat opacity, glow, drops;

  cv::Point2d cell(double x, double y) const { return {(x - origin.x) * f, (y - origin.y) * f}; }
  // Cells [x0, x1) x [y0, y1) covering a normalised box, clipped to the grid.
  cv::Rect cells(double x_min, double y_min, double x_max, double y_max) const {
    const cv::Point2d a = cell(x_min, y_min), b = cell(x_max, y_max);
    const int x0 = std::max(0, static_cast<int>(std::floor(a.x))), y0 = std::max(0, static_cast<int>(std::floor(a.y)));
    const int x1 = std::min(opacity.cols, static_cast<int>(std::ceil(b.x)) + 1);
    const int y1 = std::min(opacity.rows, static_cast<int>(std::ceil(b.y)) + 1);
    return {x0, y0, std::max(0, x1 - x0), std::max(0, y1 - y0)};
  }
  // Lays a layer of coverage `alpha`, opacity `opacity` and own radiance `radiance` over what is there.
  void lay(int x, int y, double alpha, double opacity_here, double radiance) {
    const double a = alpha * opacity_here;
    if (a <= 0) return;
    float& o = opacity.at<float>(y, x);
    float& g = glow.at<float>(y, x);
    g = static_cast<float>(g * (1 - a) + a * radiance);
    o = static_cast<float>(1 - (1 - o) * (1 - a));
  }
};

// Smooth noise on the grid in [0, 1] (blurred white noise, stretched), for frost and mud's thin parts.
cv::Mat smooth_noise(cv::Size size, double sigma, std::mt19937_64& rng) {
  cv::Mat noise(size, CV_32F);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) noise.at<float>(y, x) = u(rng);
  cv::GaussianBlur(noise, noise, cv::Size(0, 0), sigma);
  double lo = 0, hi = 1;
  cv::minMaxLoc(noise, &lo, &hi);
  noise.convertTo(noise, CV_32F, 1.0 / std::max(hi - lo, 1e-6), -lo / std::max(hi - lo, 1e-6));
  return noise;
}

// Mud or snow: one irregular blob (an ellipse whose rim wobbles) `amount` of the image width across,
// as tall as the middle third of the image at least; amount >= 1 covers the window.
void lay_blob(Grid& grid, const LensFault& fault, cv::Size image, double focal_px, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const cv::Mat texture = smooth_noise(grid.opacity.size(), fault.kind == LensFaultKind::Snow ? 1.5 : 6.0, rng);
  const bool snow = fault.kind == LensFaultKind::Snow;
  const auto layer = [&](int x, int y, double alpha) {
    const double t = texture.at<float>(y, x);
    // Mud: opaque, dark brown-grey, a little lighter where thin. Snow and frost: translucent crystals
    // that scatter daylight, bright.
    grid.lay(x, y, alpha, snow ? 0.55 + 0.4 * t : 1.0, snow ? 0.45 + 0.25 * t : 0.02 + 0.03 * t);
  };
  if (fault.amount >= 1) {
    for (int y = 0; y < grid.opacity.rows; ++y)
      for (int x = 0; x < grid.opacity.cols; ++x) layer(x, y, 1.0);
    return;
  }
  const double a = 0.5 * fault.amount * image.width / focal_px;
  const double b = std::max(a, 0.3 * image.height / focal_px);
  const double cx = (fault.centre - 0.5) * (image.width - 1) / focal_px;
  double wobble[4][2];
  for (auto& w : wobble) w[0] = 0.08 * u(rng), w[1] = 2 * kPi * u(rng);
  const cv::Rect box = grid.cells(cx - 1.3 * a, -1.3 * b, cx + 1.3 * a, 1.3 * b);
  for (int y = box.y; y < box.y + box.height; ++y) {
    for (int x = box.x; x < box.x + box.width; ++x) {
      const double nx = grid.origin.x + x / grid.f - cx, ny = grid.origin.y + y / grid.f;
      const double r = std::hypot(nx / a, ny / b), theta = std::atan2(ny / b, nx / a);
      double rim = 1;
      for (int m = 0; m < 4; ++m) rim += wobble[m][0] * std::cos((m + 2) * theta + wobble[m][1]);
      layer(x, y, std::clamp(0.5 + (rim - r) * std::min(a, b) * grid.f, 0.0, 1.0));
    }
  }
}

// Specks of mud (spray) or drops of water until they cover `amount` of the image's window area; radii
// log-uniform between r_min and r_max (normalised).
template <class Lay>
void scatter(Grid& grid, double amount, double r_min, double r_max, const cv::Rect2d& area, std::mt19937_64& rng,
             const Lay& lay) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double target = std::clamp(amount, 0.0, 1.0) * area.area();
  for (double covered = 0; covered < target;) {
    const double r = r_min * std::pow(r_max / r_min, u(rng));
    const cv::Point2d c(area.x + u(rng) * area.width, area.y + u(rng) * area.height);
    const cv::Rect box =
        grid.cells(c.x - r - 2 / grid.f, c.y - r - 2 / grid.f, c.x + r + 2 / grid.f, c.y + r + 2 / grid.f);
    lay(box, c, r, u(rng));
    covered += kPi * r * r;
  }
}

void lay_spray(Grid& grid, const LensFault& fault, const cv::Rect2d& area, std::mt19937_64& rng) {
  scatter(grid, fault.amount, 0.002, 0.02, area, rng, [&](const cv::Rect& box, cv::Point2d c, double r, double shade) {
    for (int y = box.y; y < box.y + box.height; ++y) {
      for (int x = box.x; x < box.x + box.width; ++x) {
        const double d = std::hypot(grid.origin.x + x / grid.f - c.x, grid.origin.y + y / grid.f - c.y);
        grid.lay(x, y, std::clamp(0.5 + (r - d) * grid.f, 0.0, 1.0), 1.0, 0.02 + 0.04 * shade);
      }
    }
  });
}

// Drops: spherical caps of base radius r and contact angle 40-80 degrees. A ray from the camera crosses
// the window and the drop's flat base square on, and leaves through its curved face, whose normal is
// tilted by phi (sin phi = rho / R, R = r / sin(contact angle)): Snell's law bends it by
// asin(n sin phi) - phi towards the drop's centre, or reflects it back inside when n sin phi > 1.
void lay_drops(Grid& grid, const LensFault& fault, const cv::Rect2d& area, std::mt19937_64& rng) {
  scatter(grid, fault.amount, 0.008, 0.05, area, rng, [&](const cv::Rect& box, cv::Point2d c, double r, double shape) {
    const double contact = (40 + 40 * shape) * kPi / 180;
    const double sphere = r / std::sin(contact);
    for (int y = box.y; y < box.y + box.height; ++y) {
      for (int x = box.x; x < box.x + box.width; ++x) {
        const double dx = grid.origin.x + x / grid.f - c.x, dy = grid.origin.y + y / grid.f - c.y;
        const double rho = std::hypot(dx, dy);
        if (rho >= r) continue;
        const double sin_phi = rho / sphere;
        cv::Vec3f& d = grid.drops.at<cv::Vec3f>(y, x);
        if (kWaterIndex * sin_phi >= 1) {  // reflected back inside: the rim sees the dark lens housing
          d = cv::Vec3f(0, 0, 0);
          grid.lay(x, y, 1.0, 1.0, 0.03);
          continue;
        }
        const double phi = std::asin(sin_phi);
        const double bend = std::tan(std::asin(kWaterIndex * sin_phi) - phi);
        const double inward = rho > 0 ? -bend / rho * grid.f : 0.0;  // px per normalised offset
        d = cv::Vec3f(static_cast<float>(inward * dx), static_cast<float>(inward * dy), 1.0f);
      }
    }
  });
}

// Normalised disc kernel of `radius` cells with an anti-aliased rim.
cv::Mat disc_kernel(double radius) {
  const int half = static_cast<int>(std::ceil(radius)) + 1;
  cv::Mat k(2 * half + 1, 2 * half + 1, CV_32F);
  for (int y = -half; y <= half; ++y)
    for (int x = -half; x <= half; ++x)
      k.at<float>(y + half, x + half) = static_cast<float>(std::clamp(radius + 0.5 - std::hypot(x, y), 0.0, 1.0));
  return k / cv::sum(k)[0];
}

double bilinear(const cv::Mat& image, double x, double y) {
  x = std::clamp(x, 0.0, image.cols - 1.0);
  y = std::clamp(y, 0.0, image.rows - 1.0);
  const int x0 = std::min(static_cast<int>(x), image.cols - 2), y0 = std::min(static_cast<int>(y), image.rows - 2);
  const double ax = x - x0, ay = y - y0;
  const double* r0 = image.ptr<double>(y0);
  const double* r1 = image.ptr<double>(y0 + 1);
  const double top = r0[x0] + ax * (r0[x0 + 1] - r0[x0]);
  const double bottom = r1[x0] + ax * (r1[x0 + 1] - r1[x0]);
  return top + ay * (bottom - top);
}

}  // namespace

std::shared_ptr<const LensWindow> LensWindow::make(const LensConfig& config, Camera camera, const cv::Mat& centres,
                                                   double focal_px, std::uint64_t seed) {
  const auto concerns = [camera](LensSide side) {
    return side == LensSide::Both || side == LensSide::Each || (side == LensSide::Left) == (camera == Camera::Left);
  };
  bool any = false;
  for (const LensFault& f : config.faults) any = any || concerns(f.side);
  if (!any) return nullptr;

  auto window = std::shared_ptr<LensWindow>(new LensWindow());
  const cv::Size image = centres.size();
  double x_lo = 1e9, x_hi = -1e9, y_lo = 1e9, y_hi = -1e9;
  for (int v = 0; v < image.height; ++v) {
    for (int u = 0; u < image.width; ++u) {
      const cv::Vec2d n = centres.at<cv::Vec2d>(v, u);
      x_lo = std::min(x_lo, n[0]), x_hi = std::max(x_hi, n[0]), y_lo = std::min(y_lo, n[1]),
      y_hi = std::max(y_hi, n[1]);
    }
  }
  const double radius = config.defocus * focal_px;  // cells
  const double margin = config.defocus + 3 / focal_px;
  Grid grid;
  grid.f = focal_px;
  grid.origin = cv::Point2d(x_lo - margin, y_lo - margin);
  const cv::Size cells(static_cast<int>(std::ceil((x_hi - x_lo + 2 * margin) * focal_px)) + 1,
                       static_cast<int>(std::ceil((y_hi - y_lo + 2 * margin) * focal_px)) + 1);
  grid.opacity = cv::Mat::zeros(cells, CV_32F);
  grid.glow = cv::Mat::zeros(cells, CV_32F);
  grid.drops = cv::Mat::zeros(cells, CV_32FC3);
  const cv::Rect2d area(x_lo - margin, y_lo - margin, x_hi - x_lo + 2 * margin, y_hi - y_lo + 2 * margin);
  for (std::size_t i = 0; i < config.faults.size(); ++i) {
    const LensFault& fault = config.faults[i];
    if (!concerns(fault.side)) continue;
    // Both: one pattern for the two windows; otherwise each window draws its own.
    const std::uint64_t side = fault.side == LensSide::Both ? 0 : (camera == Camera::Left ? 1 : 2);
    std::mt19937_64 rng(mix(seed ^ mix(0x1E45ull + i) ^ (side << 40)));
    switch (fault.kind) {
      case LensFaultKind::Mud:
      case LensFaultKind::Snow: lay_blob(grid, fault, image, focal_px, rng); break;
      case LensFaultKind::Spray: lay_spray(grid, fault, area, rng); break;
      case LensFaultKind::Drops: lay_drops(grid, fault, area, rng); break;
      case LensFaultKind::Dust:
        window->haze_ = 1 - (1 - window->haze_) * (1 - std::clamp(fault.amount, 0.0, 1.0));
        break;
    }
  }

  // Means over each pixel's disc: the grid convolved with the disc, read at the pixel's centre.
  const cv::Mat kernel = disc_kernel(radius);
  std::vector<cv::Mat> drop_planes;
  cv::split(grid.drops, drop_planes);
  const cv::Mat clear = (1 - grid.opacity).mul(1 - drop_planes[2]);
  drop_planes[2] = drop_planes[2].mul(1 - grid.opacity);  // a bent ray may still be blocked: D (1 - A)
  cv::merge(drop_planes, grid.drops);
  cv::Mat clear_mean, glow_mean, drop_mean;
  cv::filter2D(clear, clear_mean, CV_32F, kernel, cv::Point(-1, -1), 0, cv::BORDER_REPLICATE);
  cv::filter2D(grid.glow, glow_mean, CV_32F, kernel, cv::Point(-1, -1), 0, cv::BORDER_REPLICATE);
  cv::filter2D(drop_planes[2], drop_mean, CV_32F, kernel, cv::Point(-1, -1), 0, cv::BORDER_REPLICATE);
  window->grid_position_.create(image, CV_32FC2);
  window->veil_shape_.create(image, CV_32F);
  for (int v = 0; v < image.height; ++v) {
    for (int u = 0; u < image.width; ++u) {
      const cv::Vec2d n = centres.at<cv::Vec2d>(v, u);
      const cv::Point2d c = grid.cell(n[0], n[1]);
      window->grid_position_.at<cv::Vec2f>(v, u) = cv::Vec2f(static_cast<float>(c.x), static_cast<float>(c.y));
      // The film glows more on the side that faces the open sky behind the vehicle (image bottom).
      window->veil_shape_.at<float>(v, u) = static_cast<float>(1 + 0.4 * n[1] / std::max(y_hi, 1e-6));
    }
  }
  cv::remap(clear_mean, window->transmitted_, window->grid_position_, cv::noArray(), cv::INTER_LINEAR,
            cv::BORDER_REPLICATE);
  cv::remap(glow_mean, window->glow_, window->grid_position_, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  cv::Mat drop_share;
  cv::remap(drop_mean, drop_share, window->grid_position_, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  for (int v = 0; v < image.height; ++v)
    for (int u = 0; u < image.width; ++u)
      if (drop_share.at<float>(v, u) > 1e-6f) window->drop_pixels_.push_back(v * image.width + u);
  if (!window->drop_pixels_.empty()) {
    window->deflection_ = grid.drops;
    // A Vogel spiral: evenly spread samples of the disc.
    for (int k = 0; k < kDiscSamples; ++k) {
      const double r = radius * std::sqrt((k + 0.5) / kDiscSamples), a = k * 2.399963229728653;
      window->disc_.emplace_back(static_cast<float>(r * std::cos(a)), static_cast<float>(r * std::sin(a)));
    }
  }
  return window;
}

void LensWindow::apply(const cv::Mat& radiance, cv::Mat& out) const {
  CV_Assert(radiance.type() == CV_64F && radiance.size() == transmitted_.size());
  out.create(radiance.size(), CV_64F);
  double mean = 0;
  for (int v = 0; v < radiance.rows; ++v) {
    const double* in = radiance.ptr<double>(v);
    const float* t = transmitted_.ptr<float>(v);
    const float* g = glow_.ptr<float>(v);
    double* o = out.ptr<double>(v);
    for (int u = 0; u < radiance.cols; ++u) {
      o[u] = t[u] * in[u] + g[u];
      mean += in[u];
    }
  }
  mean /= static_cast<double>(radiance.total());
  const double share = 1.0 / kDiscSamples;
  for (const int index : drop_pixels_) {
    const int v = index / radiance.cols, u = index % radiance.cols;
    const cv::Vec2f centre = grid_position_.at<cv::Vec2f>(v, u);
    double sum = 0;
    for (const cv::Point2f& s : disc_) {
      const int x = std::clamp(static_cast<int>(std::lround(centre[0] + s.x)), 0, deflection_.cols - 1);
      const int y = std::clamp(static_cast<int>(std::lround(centre[1] + s.y)), 0, deflection_.rows - 1);
      const cv::Vec3f& d = deflection_.at<cv::Vec3f>(y, x);
      if (d[2] > 0) sum += d[2] * bilinear(radiance, u + d[0], v + d[1]);
    }
    out.at<double>(v, u) += share * sum;
  }
  if (haze_ > 0) {
    for (int v = 0; v < out.rows; ++v) {
      double* o = out.ptr<double>(v);
      const float* shape = veil_shape_.ptr<float>(v);
      for (int u = 0; u < out.cols; ++u) o[u] = (1 - haze_) * o[u] + haze_ * mean * shape[u];
    }
  }
}

}  // namespace rutd
