// The conditions of a synthetic scene on the command line (daemon/scene_options.hpp): water in the rut,
// the sky it reflects, faults on the lenses, grass, a camera turned against its calibration.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <numbers>

#include "daemon/scene_options.hpp"

namespace rutd {
namespace {

constexpr double kDeg = std::numbers::pi / 180;

// KIND:CAMERA:AMOUNT[:CENTRE], e.g. mud:left:0.3:0.4, drops:each:0.2, dust:both:0.4.
LensFault parse_lens_fault(const std::string& text) {
  const auto fail = [&](const std::string& why) {
    throw CLI::ValidationError("--lens",
                               "expected KIND:CAMERA:AMOUNT[:CENTRE] (KIND mud, snow, drops, spray or "
                               "dust; CAMERA left, right, both or each), " +
                                   why + " in '" + text + "'");
  };
  std::vector<std::string> parts;
  for (std::size_t start = 0;;) {
    const std::size_t colon = text.find(':', start);
    parts.push_back(text.substr(start, colon == std::string::npos ? std::string::npos : colon - start));
    if (colon == std::string::npos) break;
    start = colon + 1;
  }
  if (parts.size() < 3 || parts.size() > 4) fail("3 or 4 fields");
  LensFault f;
  if (!parse_lens_fault_kind(parts[0], f.kind)) fail("unknown kind '" + parts[0] + "'");
  if (!parse_lens_side(parts[1], f.side)) fail("unknown camera '" + parts[1] + "'");
  const auto number = [&](const std::string& field, const char* what) {
    double v = 0;
    const auto [end, ec] = std::from_chars(field.data(), field.data() + field.size(), v);
    if (field.empty() || ec != std::errc() || end != field.data() + field.size() || !std::isfinite(v))
      fail(std::string(what) + " '" + field + "' is not a number");
    return v;
  };
  f.amount = number(parts[2], "amount");
  const bool blob = f.kind == LensFaultKind::Mud || f.kind == LensFaultKind::Snow;
  if (!(f.amount > 0) || (!blob && f.amount > 1)) fail("amount must be within (0, 1] (mud and snow: > 0)");
  if (parts.size() == 4) {
    if (!blob) fail("only mud and snow take a CENTRE");
    f.centre = number(parts[3], "centre");
    if (!(f.centre >= 0 && f.centre <= 1)) fail("centre must be within [0, 1]");
  }
  return f;
}

}  // namespace

void add_condition_options(CLI::App& cmd, SceneOptions& o) {
  SceneConditions& c = o.params.conditions;
  WaterConfig& w = c.water;
  const std::string water = "Water in the rut (README: Conditions rutd flags)";
  cmd.add_option("--water-level", w.level_mm,
                 "Water standing in the rut up to this height above its bottom, mm (0: dry); a level surface that "
                 "reflects the sky and the vehicle, refracts and attenuates")
      ->check(CLI::Range(0.0, 500.0))
      ->capture_default_str()
      ->group(water);
  cmd.add_option("--water-surface", w.surface_depth_mm,
                 "A pool the rut runs into: its level surface this far below the ground, mm, whatever the rut's "
                 "depth (--depth-profile); dry on frames where the rut is shallower")
      ->check(CLI::Range(0.0, 500.0))
      ->excludes("--water-level")
      ->capture_default_str()
      ->group(water);
  cmd.add_option(
         "--water-attenuation", w.attenuation_per_mm,
         "Beer-Lambert extinction, 1/mm: 0.001-0.01 clear (the bottom seen), 0.1-1 turbid (hidden but near the shore)")
      ->check(CLI::Range(0.0, 100.0))
      ->capture_default_str()
      ->group(water);
  cmd.add_option("--wet-fringe", w.wet_fringe_mm,
                 "Capillary fringe: the soil wet, darkening towards the waterline, this far above it, mm (fine sand "
                 "and silt: tens of mm)")
      ->check(CLI::Range(0.0, 200.0))
      ->capture_default_str()
      ->group(water);
  cmd.add_option("--water-colour", w.body_albedo,
                 "Body colour: radiance of deep water relative to white (0.05 dark, 0.1-0.3 silt-laden)")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str()
      ->group(water);
  cmd.add_option("--silt", w.silt_contrast, "Relative modulation of the body colour by silt plumes")
      ->check(CLI::Range(0.0, 0.3))
      ->capture_default_str()
      ->group(water);
  cmd.add_option("--debris", w.debris_cover,
                 "Floating debris: a level, textured lid over this fraction of the water (1: all of it)")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str()
      ->group(water);
  cmd.add_option("--debris-kind", o.debris_kind, "What floats: foam, leaves or litter")
      ->check(CLI::IsMember({"foam", "leaves", "litter"}))
      ->capture_default_str()
      ->group(water);
  cmd.add_option("--ripple", w.ripple_slope, "Ripples: rms slope of the water surface (0: still; 0.02-0.1)")
      ->check(CLI::Range(0.0, 0.5))
      ->capture_default_str()
      ->group(water);
  cmd.add_option("--ripple-kind", o.ripple_kind, "What ripples it: wind (travelling waves) or rain (rings)")
      ->check(CLI::IsMember({"wind", "rain"}))
      ->capture_default_str()
      ->group(water);
  cmd.add_option("--water-roughness", w.roughness_deg,
                 "Spread of the surface facets, degrees: widens the sun's glint (still water 0.5-2)")
      ->check(CLI::Range(0.0, 20.0))
      ->capture_default_str()
      ->group(water);

  const std::string sky = "Sky and vehicle (lighting, and what water reflects)";
  cmd.add_option("--sun-elevation", o.sun_elevation_deg, "Sun's elevation, degrees (default 64.4)")
      ->check(CLI::Range(3.0, 90.0))
      ->group(sky);
  cmd.add_option("--sun-azimuth", o.sun_azimuth_deg,
                 "Sun's azimuth from the direction of travel towards the right, degrees (default 54.5; 180: "
                 "behind the vehicle, where its glint can be seen)")
      ->check(CLI::Range(-360.0, 360.0))
      ->group(sky);
  cmd.add_option("--underside-height", c.sky.underside_height_mm,
                 "Vehicle underside above the ground, mm (0: open sky above the rig)")
      ->check(CLI::Range(0.0, 5000.0))
      ->capture_default_str()
      ->group(sky);
  cmd.add_option("--underside-edge", c.sky.underside_edge_mm,
                 "Rear edge of the underside along travel from the rig, mm (negative: behind it)")
      ->check(CLI::Range(-5000.0, 5000.0))
      ->capture_default_str()
      ->group(sky);

  const std::string lens = "Faults on the lenses' windows, seen out of focus";
  cmd.add_option("--lens", o.lens,
                 "KIND:CAMERA:AMOUNT[:CENTRE], repeatable. KIND mud (opaque blob), snow (bright translucent "
                 "blob), drops (water drops: local refraction and blur), spray (specks of mud), dust (a film: "
                 "contrast loss and veiling glare); CAMERA left, right, both (the same pattern on both) or each (a "
                 "pattern of its own on each); AMOUNT: mud and snow the blob's width / image width (>= 1 covers "
                 "the lens), drops and spray the share of the window covered, dust the film's haze (0..1]; "
                 "CENTRE: the blob's centre, fraction of the width")
      ->group(lens);
  cmd.add_option("--lens-defocus", c.lens.defocus,
                 "Radius of the window's disc each pixel sees through, normalised image units (out of focus)")
      ->check(CLI::Range(0.002, 0.2))
      ->capture_default_str()
      ->group(lens);
  cmd.add_option("--splash", o.splash_fraction,
                 "Shorthand for --lens mud:CAMERA:FRACTION:CENTRE: a mud blob this fraction of the image width "
                 "(1: the lens covered)")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str()
      ->group(lens);
  cmd.add_option("--splash-camera", o.splash_camera, "The lens with the blob: left or right")
      ->check(CLI::IsMember({"left", "right"}))
      ->capture_default_str()
      ->group(lens);
  cmd.add_option("--splash-centre", o.splash_centre, "Centre of the blob, fraction of the image width")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str()
      ->group(lens);

  const std::string cond = "Other conditions (README: Conditions rutd flags)";
  cmd.add_option("--grass-height", c.grass_height_mm, "Grass blades up to this tall outside the rut, mm (0: none)")
      ->check(CLI::Range(0.0, 200.0))
      ->capture_default_str()
      ->group(cond);
  cmd.add_option("--grass-spacing", c.grass_spacing_mm, "One blade per square of this side, mm")
      ->check(CLI::Range(1.0, 100.0))
      ->capture_default_str()
      ->group(cond);
  cmd.add_option("--right-pitch-error", c.right_pitch_error_deg,
                 "Right camera turned about its x axis against the written calibration, degrees")
      ->check(CLI::Range(-10.0, 10.0))
      ->capture_default_str()
      ->group(cond);
  cmd.add_option("--right-roll-error", c.right_roll_error_deg,
                 "Right camera turned about its optical axis against the written calibration, degrees")
      ->check(CLI::Range(-10.0, 10.0))
      ->capture_default_str()
      ->group(cond);
}

void resolve_condition_options(const SceneOptions& o, SyntheticRendererConfig& p) {
  SceneConditions& c = p.conditions;
  WaterConfig& w = c.water;
  parse_debris_kind(o.debris_kind, w.debris);  // IsMember above guarantees a known name
  parse_ripple_kind(o.ripple_kind, w.ripple);
  if (w.level_mm > 0) {
    double shallowest = p.depth_profile.empty() ? p.rut.depth_mm : p.depth_profile.front().second;
    for (const auto& knot : p.depth_profile) shallowest = std::min(shallowest, knot.second);
    if (w.level_mm >= shallowest)
      throw CLI::ValidationError("--water-level",
                                 "must be below the rut's depth on every frame (--depth, "
                                 "--depth-profile)");
  } else if (w.surface_depth_mm == 0) {
    if (w.debris_cover > 0) throw CLI::ValidationError("--debris", "needs water (--water-level or --water-surface)");
    if (w.ripple_slope > 0) throw CLI::ValidationError("--ripple", "needs water (--water-level or --water-surface)");
  }
  if (std::isfinite(o.sun_elevation_deg) || std::isfinite(o.sun_azimuth_deg)) {
    // Unset halves keep the default sun's.
    const cv::Vec3d sun = cv::normalize(SkyConfig{}.sun);
    const double elevation = std::isfinite(o.sun_elevation_deg) ? o.sun_elevation_deg * kDeg : std::asin(sun[2]);
    const double azimuth = std::isfinite(o.sun_azimuth_deg) ? o.sun_azimuth_deg * kDeg : std::atan2(sun[0], sun[1]);
    c.sky.sun = cv::Vec3d(std::cos(elevation) * std::sin(azimuth), std::cos(elevation) * std::cos(azimuth),
                          std::sin(elevation));
  }
  c.lens.faults.clear();
  for (const std::string& text : o.lens) c.lens.faults.push_back(parse_lens_fault(text));
  if (o.splash_fraction > 0) {
    LensFault f;
    f.kind = LensFaultKind::Mud;
    f.side = o.splash_camera == "right" ? LensSide::Right : LensSide::Left;
    f.amount = o.splash_fraction;
    f.centre = o.splash_centre;
    c.lens.faults.push_back(f);
  }
}

}  // namespace rutd
