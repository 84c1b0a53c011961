#pragma once
// The optics of standing water in the rut, for the synthetic renderer (synthetic/scene_conditions.hpp:
// WaterConfig, SkyConfig). Private to drivers/synthetic.
#include <cstdint>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "synthetic/scene_conditions.hpp"
#include "synthetic/synthetic_scene.hpp"

namespace rutd {

// Reflectance of a smooth interface for unpolarised light arriving at incidence cos_i (0..1] from a
// medium of index 1 into one of index n: the mean of the Fresnel equations' s and p reflectances; 1
// beyond the critical angle (n < 1).
double fresnel_reflectance(double cos_i, double n) noexcept;

// Snell's law in vector form: `incoming` (unit) refracted at a surface of unit normal `normal` (facing
// the incoming side: normal . incoming < 0), eta = n_incoming / n_outgoing. False at total internal
// reflection; else `out` is the unit refracted direction.
bool refract(const cv::Vec3d& incoming, const cv::Vec3d& normal, double eta, cv::Vec3d& out) noexcept;

// Immutable after construction (builds the textures of debris and silt, and the ripples' waves from the
// seed); radiance() is const, allocation-free and thread-safe.
class WaterOptics {
 public:
  // sun: unit vector towards the sun; ambient: the share of the soil's light that comes from the sky
  // rather than the sun (the renderer's shading).
  WaterOptics(const WaterConfig& water, const SkyConfig& sky, const cv::Vec3d& sun, double ambient, std::uint64_t seed);

  // A view ray that meets the surface before the terrain.
  struct Ray {
    cv::Vec3d origin, dir;  // dir: any length, pointing down
    double t_surface;       // origin + t_surface dir lies on the surface (z = water_z)
    double footprint_mm;    // spacing of neighbouring samples on the surface
    double spread;          // angle between neighbouring samples' rays, radians
    double time_s;          // the exposure's time (ripples move)
    double rig_y;           // world y of the rig midpoint (the vehicle's underside moves with it)
  };
  // Radiance seen along `ray`: floating debris where it lies, else the reflection of the sky or the
  // underside plus the refracted view of the bottom of `terrain` (textured by `soil`, band-limited when
  // band_limit) through the water column.
  double radiance(const RutTerrain& terrain, double water_z, const Ray& ray, const SolidTexture& soil,
                  bool band_limit) const noexcept;

  // The pieces, for the renderer and tests. Surface normal (unit, z > 0) at (x, y) at time t.
  cv::Vec3d normal(double x, double y, double time_s) const noexcept;
  // Radiance arriving along `dir` (unit, going up) at `from`: the underside where it hangs over the
  // ray's path, else the sky and the sun's glint lobe.
  double environment(const cv::Vec3d& from, const cv::Vec3d& dir, double rig_y) const noexcept;
  // Debris: its cover 0..1 at (x, y) (soft-edged over about a millimetre) and its albedo there.
  double debris_alpha(double x, double y, double footprint_mm) const noexcept;
  double debris_albedo(const cv::Vec3d& p, double footprint_mm) const noexcept;
  // Shaded albedo of the soil at bottom point p (terrain gradient g) under `depth` mm of water, the
  // light attenuated on its way down; before the n^2 law and the view path's attenuation.
  double bottom_radiance(const SolidTexture& soil, const cv::Vec3d& p, const cv::Vec2d& g, double depth,
                         double footprint_mm, bool band_limit) const noexcept;

  const WaterConfig& config() const noexcept { return water_; }

 private:
  struct Wave {  // one wind wave: slope amplitude along its direction
    cv::Vec2d direction;
    double k, omega, phase, slope;
  };
  cv::Vec2d slope_wind(double x, double y, double t) const noexcept;
  cv::Vec2d slope_rain(double x, double y, double t) const noexcept;  // unscaled
  double silt(double x, double y) const noexcept;                     // zero mean, unit deviation

  WaterConfig water_;
  SkyConfig sky_;
  cv::Vec3d sun_;        // towards the sun
  cv::Vec3d sun_water_;  // the sun's light refracted into the water (travelling down)
  double sun_transmitted_ = 0;
  double ambient_ = 0;
  double glint_sigma_ = 0;  // radians: the spread of the mirror image (twice the facets' normal spread)
  std::uint64_t seed_;
  std::vector<Wave> waves_;
  double rain_scale_ = 0;  // makes the rings' rms slope water.ripple_slope
  // Debris mask and look, and silt plumes: world-fixed textures (built only when used).
  std::optional<SolidTexture> mask_, look_, silt_;
  double mask_scale_ = 1, look_scale_ = 1, mask_threshold_ = 0, mask_edge_ = 1;
  double silt_mean_ = 0, silt_deviation_ = 1;
};

}  // namespace rutd
