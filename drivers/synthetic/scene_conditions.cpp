// Names and checks of the synthetic scene's conditions (synthetic/scene_conditions.hpp).
#include "synthetic/scene_conditions.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace rutd {
namespace {

void require(bool ok, const std::string& field, const std::string& what) {
  if (!ok) throw std::invalid_argument("synthetic: " + field + ": " + what);
}

template <class E, std::size_t N>
bool lookup(std::string_view name, const std::pair<std::string_view, E> (&table)[N], E& out) {
  for (const auto& [text, value] : table) {
    if (name == text) {
      out = value;
      return true;
    }
  }
  return false;
}

}  // namespace

bool parse_debris_kind(std::string_view name, DebrisKind& out) {
  static constexpr std::pair<std::string_view, DebrisKind> kNames[] = {
      {"foam", DebrisKind::Foam}, {"leaves", DebrisKind::Leaves}, {"litter", DebrisKind::Litter}};
  return lookup(name, kNames, out);
}

bool parse_ripple_kind(std::string_view name, RippleKind& out) {
  static constexpr std::pair<std::string_view, RippleKind> kNames[] = {{"wind", RippleKind::Wind},
                                                                       {"rain", RippleKind::Rain}};
  return lookup(name, kNames, out);
}

bool parse_lens_fault_kind(std::string_view name, LensFaultKind& out) {
  static constexpr std::pair<std::string_view, LensFaultKind> kNames[] = {{"mud", LensFaultKind::Mud},
                                                                          {"snow", LensFaultKind::Snow},
                                                                          {"drops", LensFaultKind::Drops},
                                                                          {"spray", LensFaultKind::Spray},
                                                                          {"dust", LensFaultKind::Dust}};
  return lookup(name, kNames, out);
}

bool parse_lens_side(std::string_view name, LensSide& out) {
  static constexpr std::pair<std::string_view, LensSide> kNames[] = {
      {"left", LensSide::Left}, {"right", LensSide::Right}, {"both", LensSide::Both}, {"each", LensSide::Each}};
  return lookup(name, kNames, out);
}

void validate(const SceneConditions& c, double min_depth_mm) {
  const WaterConfig& w = c.water;
  for (double v : {w.level_mm, w.surface_depth_mm, w.refractive_index, w.attenuation_per_mm, w.body_albedo,
                   w.silt_contrast, w.debris_cover, w.ripple_slope, w.wind_azimuth_deg, w.rain_rate_per_m2_s,
                   w.roughness_deg, w.wet_albedo_factor, w.wet_fringe_mm}) {
    require(std::isfinite(v), "water", "every value must be finite");
  }
  require(w.level_mm >= 0, "water.level_mm", "must be >= 0");
  if (w.level_mm > 0)
    require(w.level_mm < min_depth_mm, "water.level_mm", "must be below the rut's depth on every frame");
  require(w.surface_depth_mm >= 0, "water.surface_depth_mm", "must be >= 0");
  require(w.level_mm == 0 || w.surface_depth_mm == 0, "water.surface_depth_mm", "cannot be set with water.level_mm");
  require(w.refractive_index >= 1 && w.refractive_index <= 2, "water.refractive_index", "must be within [1, 2]");
  require(w.attenuation_per_mm >= 0, "water.attenuation_per_mm", "must be >= 0");
  require(w.body_albedo >= 0 && w.body_albedo <= 1, "water.body_albedo", "must be within [0, 1]");
  require(w.silt_contrast >= 0 && w.silt_contrast <= 0.3, "water.silt_contrast", "must be within [0, 0.3]");
  require(w.debris_cover >= 0 && w.debris_cover <= 1, "water.debris_cover", "must be within [0, 1]");
  require(w.ripple_slope >= 0 && w.ripple_slope <= 0.5, "water.ripple_slope", "must be within [0, 0.5]");
  require(w.rain_rate_per_m2_s > 0, "water.rain_rate_per_m2_s", "must be > 0");
  require(w.roughness_deg >= 0 && w.roughness_deg <= 20, "water.roughness_deg", "must be within [0, 20]");
  require(w.wet_albedo_factor > 0 && w.wet_albedo_factor <= 1, "water.wet_albedo_factor", "must be within (0, 1]");
  require(w.wet_fringe_mm >= 0, "water.wet_fringe_mm", "must be >= 0");

  const SkyConfig& s = c.sky;
  for (double v : {s.sun[0], s.sun[1], s.sun[2], s.zenith, s.horizon, s.underside_height_mm, s.underside_edge_mm,
                   s.underside_radiance}) {
    require(std::isfinite(v), "sky", "every value must be finite");
  }
  require(s.sun[2] > 0.05 * cv::norm(s.sun), "sky.sun", "the sun must stand at least 3 degrees above the horizon");
  require(s.zenith >= 0 && s.horizon >= 0, "sky.zenith/horizon", "must be >= 0");
  require(s.underside_height_mm >= 0, "sky.underside_height_mm", "must be >= 0 (0: no underside)");
  require(s.underside_radiance >= 0, "sky.underside_radiance", "must be >= 0");

  require(std::isfinite(c.lens.defocus) && c.lens.defocus >= 0.002 && c.lens.defocus <= 0.2, "lens.defocus",
          "must be within [0.002, 0.2]");
  for (std::size_t i = 0; i < c.lens.faults.size(); ++i) {
    const LensFault& f = c.lens.faults[i];
    const std::string field = "lens.faults[" + std::to_string(i) + "]";
    require(std::isfinite(f.amount) && f.amount > 0, field + ".amount", "must be > 0");
    require(f.kind == LensFaultKind::Mud || f.kind == LensFaultKind::Snow || f.amount <= 1, field + ".amount",
            "must be within (0, 1] for drops, spray and dust");
    require(std::isfinite(f.centre) && f.centre >= 0 && f.centre <= 1, field + ".centre", "must be within [0, 1]");
  }
  for (double v : {c.grass_height_mm, c.grass_spacing_mm, c.right_pitch_error_deg, c.right_roll_error_deg}) {
    require(std::isfinite(v), "conditions", "every value must be finite");
  }
  require(c.grass_height_mm >= 0 && c.grass_height_mm <= 200, "grass_height_mm", "must be within [0, 200]");
  require(c.grass_spacing_mm >= 1, "grass_spacing_mm", "must be >= 1");
  require(std::abs(c.right_pitch_error_deg) <= 10 && std::abs(c.right_roll_error_deg) <= 10, "right_*_error_deg",
          "must be within [-10, 10]");
}

}  // namespace rutd
