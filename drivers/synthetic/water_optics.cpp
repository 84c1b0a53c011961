// The optics of standing water for the synthetic renderer (water_optics.hpp).
#include "water_optics.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

#include "synthetic/synthetic_renderer.hpp"

namespace rutd {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180;
// Capillary-gravity waves: omega^2 = g k + (sigma / rho) k^3 (mm, s).
constexpr double kGravity = 9810;           // mm/s^2
constexpr double kSurfaceTension = 7.28e4;  // sigma / rho of water, mm^3/s^2
// Rain rings: wave packets spreading at the slowest speed of capillary-gravity waves (231 mm/s, at a
// wavelength of 17 mm), fading as they spread.
constexpr double kRingSpeed = 231;
constexpr double kRingWavelength = 17;
constexpr double kRingWidth = 6;      // mm, the packet's half-width
constexpr double kRingDecay = 0.15;   // s
constexpr double kRingMaxAge = 0.45;  // s: older rings are too faint to matter (e^-3)
constexpr double kRainCell = 40;      // mm: drops are drawn per cell of this side
// Light that reaches the bottom from the sky: transmittance of a flat surface for diffuse light, and its
// mean path per depth in the water (inside the cone of refraction).
constexpr double kDiffuseTransmittance = 0.934;
constexpr double kDiffuseMeanCosine = 0.9;
// Light the bottom reflects up is partly reflected back down by the surface (its reflectance for diffuse
// light from below, mostly total internal reflection outside the cone of refraction), lighting the
// bottom again.
constexpr double kInternalReflectance = 0.48;

std::uint64_t mix(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

double unit(std::uint64_t h) { return static_cast<double>(h >> 11) * 0x1.0p-53; }

double smoothstep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3 - 2 * x);
}

// Mean and standard deviation of a texture's albedo over the ground plane at the given scale.
void texture_statistics(const SolidTexture& texture, double scale, std::uint64_t seed, std::vector<double>& values,
                        double& mean, double& deviation) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> across(-2000.0, 2000.0);
  values.resize(8192);
  double sum = 0, sum2 = 0;
  for (double& v : values) {
    v = texture.albedo(cv::Vec3d(across(rng), across(rng), 0) / scale, 1.0 / scale);
    sum += v, sum2 += v * v;
  }
  mean = sum / values.size();
  deviation = std::sqrt(std::max(sum2 / values.size() - mean * mean, 1e-12));
}

}  // namespace

double fresnel_reflectance(double cos_i, double n) noexcept {
  cos_i = std::clamp(cos_i, 0.0, 1.0);
  const double sin_t2 = (1 - cos_i * cos_i) / (n * n);
  if (sin_t2 >= 1) return 1.0;
  const double cos_t = std::sqrt(1 - sin_t2);
  const double rs = (cos_i - n * cos_t) / (cos_i + n * cos_t);
  const double rp = (n * cos_i - cos_t) / (n * cos_i + cos_t);
  return 0.5 * (rs * rs + rp * rp);
}

bool refract(const cv::Vec3d& v, const cv::Vec3d& n, double eta, cv::Vec3d& out) noexcept {
  const double cos_i = -n.dot(v);
  const double k = 1 - eta * eta * (1 - cos_i * cos_i);
  if (k < 0) return false;
  out = eta * v + (eta * cos_i - std::sqrt(k)) * n;
  return true;
}

WaterOptics::WaterOptics(const WaterConfig& water, const SkyConfig& sky, const cv::Vec3d& sun, double ambient,
                         std::uint64_t seed)
    : water_(water), sky_(sky), sun_(sun), ambient_(ambient), seed_(seed) {
  const double n = water_.refractive_index;
  if (!refract(-sun_, cv::Vec3d(0, 0, 1), 1 / n, sun_water_)) sun_water_ = cv::Vec3d(0, 0, -1);
  sun_transmitted_ = 1 - fresnel_reflectance(sun_[2], n);
  glint_sigma_ = 2 * water_.roughness_deg * kDeg;
  std::mt19937_64 rng(mix(seed ^ 0x57A7E2ull));
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  if (water_.ripple_slope > 0 && water_.ripple == RippleKind::Wind) {
    // Four waves about the wind's direction; equal slope amplitudes whose mean square makes the rms.
    constexpr int kWaves = 4;
    for (int i = 0; i < kWaves; ++i) {
      const double azimuth = (water_.wind_azimuth_deg + 70 * (u01(rng) - 0.5)) * kDeg;
      const double wavelength = 10 + 30 * u01(rng);
      Wave w;
      w.direction = cv::Vec2d(std::sin(azimuth), std::cos(azimuth));
      w.k = 2 * kPi / wavelength;
      w.omega = std::sqrt(kGravity * w.k + kSurfaceTension * w.k * w.k * w.k);
      w.phase = 2 * kPi * u01(rng);
      w.slope = water_.ripple_slope * std::sqrt(2.0 / kWaves);
      waves_.push_back(w);
    }
  }
  if (water_.ripple_slope > 0 && water_.ripple == RippleKind::Rain) {
    // Scale the rings to the requested rms slope, measured over the surface and a second of rain.
    double sum2 = 0;
    constexpr int kSamples = 3000;
    for (int i = 0; i < kSamples; ++i) {
      const cv::Vec2d s = slope_rain(2000 * u01(rng), 2000 * u01(rng), 1 + u01(rng));
      sum2 += s.dot(s);
    }
    rain_scale_ = sum2 > 0 ? water_.ripple_slope / std::sqrt(sum2 / kSamples) : 0.0;
  }
  std::vector<double> values;
  if (water_.debris_cover > 0) {
    // Mask: the blotches of a mud texture seen at a larger scale, thresholded at the quantile that covers
    // the requested share of the surface. Look: foam's bubbles (snow's grain, more contrast), leaves'
    // veins (grass strands), litter's paper and plastic (sand's grain, coarser and brighter).
    const Texture look = water_.debris == DebrisKind::Foam     ? Texture::Snow
                         : water_.debris == DebrisKind::Leaves ? Texture::Grass
                                                               : Texture::Sand;
    mask_scale_ = water_.debris == DebrisKind::Foam ? 2.5 : water_.debris == DebrisKind::Leaves ? 4.0 : 7.0;
    look_scale_ = water_.debris == DebrisKind::Foam ? 1.0 : water_.debris == DebrisKind::Leaves ? 1.5 : 2.5;
    mask_.emplace(Texture::Mud, mix(seed ^ 0xDEB715ull));
    look_.emplace(look, mix(seed ^ 0x100Cull));
    double mean = 0, deviation = 1;
    texture_statistics(*mask_, mask_scale_, mix(seed ^ 3), values, mean, deviation);
    const auto at = values.begin() + static_cast<long>(std::clamp(1 - water_.debris_cover, 0.0, 1.0) *
                                                       static_cast<double>(values.size() - 1));
    std::nth_element(values.begin(), at, values.end());
    mask_threshold_ = *at;
    mask_edge_ = 0.1 * deviation;
  }
  if (water_.silt_contrast > 0) {
    silt_.emplace(Texture::Mud, mix(seed ^ 0x5117ull));
    texture_statistics(*silt_, 4.0, mix(seed ^ 5), values, silt_mean_, silt_deviation_);
  }
}

cv::Vec2d WaterOptics::slope_wind(double x, double y, double t) const noexcept {
  cv::Vec2d s(0, 0);
  for (const Wave& w : waves_) {
    const double phase = w.k * (w.direction[0] * x + w.direction[1] * y) - w.omega * t + w.phase;
    s += w.slope * std::cos(phase) * w.direction;
  }
  return s;
}

cv::Vec2d WaterOptics::slope_rain(double x, double y, double t) const noexcept {
  // Drops fall in each cell at times (j + u_j) / rate, at a random place in the cell; each spreads a
  // ring whose packet of radial slope travels out at kRingSpeed, fading with age and spreading.
  const double rate = water_.rain_rate_per_m2_s * kRainCell * kRainCell * 1e-6;  // drops per second per cell
  const int reach = static_cast<int>(std::ceil(kRingSpeed * kRingMaxAge / kRainCell)) + 1;
  const int ci = static_cast<int>(std::floor(x / kRainCell)), cj = static_cast<int>(std::floor(y / kRainCell));
  const double k = 2 * kPi / kRingWavelength;
  const auto first = static_cast<std::int64_t>(std::floor((t - kRingMaxAge) * rate));
  const auto last = static_cast<std::int64_t>(std::floor(t * rate));
  cv::Vec2d s(0, 0);
  for (int i = ci - reach; i <= ci + reach; ++i) {
    for (int j = cj - reach; j <= cj + reach; ++j) {
      const std::uint64_t cell = mix(seed_ ^ mix((static_cast<std::uint64_t>(static_cast<std::uint32_t>(i)) << 32) |
                                                 static_cast<std::uint32_t>(j)));
      for (std::int64_t d = first; d <= last + 1; ++d) {
        const std::uint64_t h = mix(cell ^ static_cast<std::uint64_t>(d));
        const double age = t - (static_cast<double>(d) + unit(h)) / rate;
        if (age < 0 || age > kRingMaxAge) continue;
        const double dx = x - (i + unit(mix(h ^ 1))) * kRainCell, dy = y - (j + unit(mix(h ^ 2))) * kRainCell;
        const double r = std::sqrt(dx * dx + dy * dy);
        const double off = r - kRingSpeed * age;
        if (std::abs(off) > 3 * kRingWidth || r < 1e-6) continue;
        const double a = std::exp(-age / kRingDecay - off * off / (2 * kRingWidth * kRingWidth)) /
                         std::sqrt(1 + r / 10) * std::cos(k * off);
        s += a / r * cv::Vec2d(dx, dy);
      }
    }
  }
  return s;
}

cv::Vec3d WaterOptics::normal(double x, double y, double time_s) const noexcept {
  if (!(water_.ripple_slope > 0)) return {0, 0, 1};
  const cv::Vec2d s =
      water_.ripple == RippleKind::Wind ? slope_wind(x, y, time_s) : rain_scale_ * slope_rain(x, y, time_s);
  return cv::normalize(cv::Vec3d(-s[0], -s[1], 1));
}

double WaterOptics::environment(const cv::Vec3d& from, const cv::Vec3d& dir, double rig_y) const noexcept {
  const double up = std::max(dir[2], 0.0);
  if (sky_.underside_height_mm > 0 && up > 1e-9) {
    const double t = (sky_.underside_height_mm - from[2]) / up;
    const double y = from[1] + t * dir[1] - rig_y;  // along the vehicle, from the rig
    if (t > 0 && y > sky_.underside_edge_mm) {
      // Chassis members across the vehicle every 260 mm, 40 mm wide, lighter than the underside's grime.
      const double c = 0.5 * (1 + std::cos(2 * kPi * y / 260));
      return sky_.underside_radiance * (1 + 1.5 * std::pow(c, 12));
    }
  }
  const double below = 1 - up;
  double radiance = sky_.zenith + (sky_.horizon - sky_.zenith) * below * below;
  // The sun's mirror image spread by the facets into a Gaussian lobe of glint_sigma_ that carries the
  // sun's irradiance: E / (2 pi sigma^2) exp(-angle^2 / (2 sigma^2)), with angle^2 / 2 ~ 1 - cos.
  const double cos_angle = dir.dot(sun_);
  const double sigma2 = glint_sigma_ * glint_sigma_;
  if (sigma2 > 0 && 1 - cos_angle < 12 * sigma2) {
    const double sun_irradiance = (1 - ambient_) * kPi;  // a white diffuse surface facing it: 1 - ambient
    radiance += sun_irradiance / (2 * kPi * sigma2) * std::exp(-(1 - cos_angle) / sigma2);
  }
  return radiance;
}

double WaterOptics::debris_alpha(double x, double y, double footprint_mm) const noexcept {
  if (!mask_) return 0;
  if (water_.debris_cover >= 1) return 1;
  const double m = mask_->albedo(cv::Vec3d(x, y, 0) / mask_scale_, footprint_mm / mask_scale_);
  return smoothstep((m - mask_threshold_) / mask_edge_ + 0.5);
}

double WaterOptics::debris_albedo(const cv::Vec3d& p, double footprint_mm) const noexcept {
  const double a = look_->albedo(cv::Vec3d(p[0], p[1], 0) / look_scale_, footprint_mm / look_scale_);
  switch (water_.debris) {
    case DebrisKind::Foam: return std::clamp(0.8 + 3.5 * (a - 0.85), 0.3, 0.98);
    case DebrisKind::Leaves: return 0.08 + 0.8 * a;
    case DebrisKind::Litter: return std::clamp(0.1 + 1.1 * a, 0.02, 0.95);
  }
  return a;
}

double WaterOptics::silt(double x, double y) const noexcept {
  if (!silt_) return 0;
  return std::clamp((silt_->albedo(cv::Vec3d(x, y, 0) / 4.0, 0.25) - silt_mean_) / silt_deviation_, -3.0, 3.0);
}

double WaterOptics::bottom_radiance(const SolidTexture& soil, const cv::Vec3d& p, const cv::Vec2d& g, double depth,
                                    double footprint_mm, bool band_limit) const noexcept {
  const double c = water_.attenuation_per_mm;
  const cv::Vec3d normal = cv::normalize(cv::Vec3d(-g[0], -g[1], 1));
  // The sun's beam in the water: its flux per area across the beam is E (1 - R) cos(air) / cos(water).
  const double cos_water = -sun_water_[2];
  const double facing = std::max(0.0, -normal.dot(sun_water_));
  const double sun =
      (1 - ambient_) * sun_transmitted_ * sun_[2] / cos_water * facing * std::exp(-c * depth / cos_water);
  const double sky = ambient_ * kDiffuseTransmittance * std::exp(-c * depth / kDiffuseMeanCosine);
  const double albedo = water_.wet_albedo_factor * (band_limit ? soil.albedo(p, footprint_mm) : soil.albedo(p));
  const double again = albedo * kInternalReflectance * std::exp(-2 * c * depth / kDiffuseMeanCosine);
  return albedo * (sun + sky) / (1 - again);
}

double WaterOptics::radiance(const RutTerrain& terrain, double water_z, const Ray& ray, const SolidTexture& soil,
                             bool band_limit) const noexcept {
  const cv::Vec3d p = ray.origin + ray.t_surface * ray.dir;
  const double alpha = debris_alpha(p[0], p[1], ray.footprint_mm);
  const double lid_light = ambient_ + (1 - ambient_) * sun_[2];  // a horizontal lid in the sun
  const double lid = alpha > 0 ? debris_albedo(p, ray.footprint_mm) * lid_light : 0.0;
  if (alpha >= 1) return lid;

  const double n = water_.refractive_index;
  const cv::Vec3d v = cv::normalize(ray.dir);
  cv::Vec3d normal = this->normal(p[0], p[1], ray.time_s);
  double cos_i = -v.dot(normal);
  if (cos_i < 1e-3) {  // a ripple's flank facing away from this camera: seen at grazing incidence
    normal = cv::normalize(normal + (1e-3 - cos_i) * -v);
    cos_i = -v.dot(normal);
  }
  const double reflectance = fresnel_reflectance(cos_i, n);
  const cv::Vec3d reflected = v + 2 * cos_i * normal;
  const double mirror = environment(p, reflected, ray.rig_y);

  // The water column: its body colour (modulated by silt), through which the bottom shows with the
  // transmittance of the refracted path; the bottom's own light was attenuated on the way down.
  const double body = water_.body_albedo * (1 + water_.silt_contrast * silt(p[0], p[1])) *
                      (ambient_ * kDiffuseTransmittance + (1 - ambient_) * sun_[2] * sun_transmitted_);
  double column = body;
  cv::Vec3d t_dir;
  if (refract(v, normal, 1 / n, t_dir)) {
    const double t = cast_ray(terrain, p, t_dir);
    if (t > 0) {
      const cv::Vec3d bottom = p + t * t_dir;
      const cv::Vec2d g = terrain.gradient_fast(bottom[0], bottom[1]);
      const cv::Vec3d bottom_normal = cv::normalize(cv::Vec3d(-g[0], -g[1], 1));
      const double footprint =
          (ray.t_surface * cv::norm(ray.dir) + t / n) * ray.spread / std::max(0.3, -t_dir.dot(bottom_normal));
      const double lit = bottom_radiance(soil, bottom, g, water_z - bottom[2], footprint, band_limit);
      column = body + (lit - body) * std::exp(-water_.attenuation_per_mm * t);
    }
  }
  const double water = reflectance * mirror + (1 - reflectance) * column / (n * n);
  return alpha * lid + (1 - alpha) * water;
}

}  // namespace rutd
