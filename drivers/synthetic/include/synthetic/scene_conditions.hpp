#pragma once
// What a synthetic scene adds to a clean rut seen in daylight (synthetic/synthetic_renderer.hpp), as
// optics rather than pasted patches: water standing in the rut (a level surface that reflects the sky
// and the vehicle above it, refracts each camera's rays by Snell's law and attenuates by Beer-Lambert),
// floating debris, ripples and sun glints; faults on the cameras' protective windows seen out of focus
// (mud, snow, water drops, spray, a dust film); grass; a camera turned against its calibration. None
// changes the ground truth of the soil (RutTruth): a measurement must report the soil's rut or refuse.
//
// World frame and units as synthetic/synthetic_scene.hpp: millimetres, x lateral, y along travel, z up.
// Radiances are relative to a white diffuse surface facing the sun in daylight (1).
#include <cstdint>
#include <string_view>
#include <vector>

#include <opencv2/core.hpp>

namespace rutd {

enum class Camera { Left, Right };

enum class DebrisKind { Foam, Leaves, Litter };
enum class RippleKind { Wind, Rain };
enum class LensFaultKind { Mud, Snow, Drops, Spray, Dust };
// Both: the same pattern at the same place on both windows (one splash that reached both lenses alike,
// which a comparison of the two views cannot see); Each: a pattern of its own on each window.
enum class LensSide { Left, Right, Both, Each };

// Names as the command line spells them ("foam", "rain", "mud", "both", ...), in lower case; false for
// anything else.
bool parse_debris_kind(std::string_view name, DebrisKind& out);
bool parse_ripple_kind(std::string_view name, RippleKind& out);
bool parse_lens_fault_kind(std::string_view name, LensFaultKind& out);
bool parse_lens_side(std::string_view name, LensSide& out);

// Water standing in the rut: a level surface at level_mm above the rut's bottom, filling the rut
// wherever the terrain lies below it. Seen from a camera, each ray that reaches the surface before the
// terrain is split by the exact Fresnel equations (unpolarised) into a reflected part, which sees the sky
// or the vehicle's underside (SkyConfig), and a transmitted part refracted by Snell's law that crosses
// the water to the bottom. Along that path (s mm) light keeps exp(-c s) (Beer-Lambert, c =
// attenuation_per_mm) and the water adds its body colour for the rest; the light that reaches the
// bottom was attenuated on its way down too. Radiance leaving the water is divided by n^2 (the n-squared
// law of radiance across an interface). Submerged soil is wet, hence darker.
struct WaterConfig {
  double level_mm = 0;  // > 0: water this high above the rut bottom, below the rut's depth
  // > 0 (level_mm 0): the surface lies this far below the undisturbed ground whatever the rut's depth on
  // a frame (RutConfig::depth_profile): a pool the rut runs into, dry on frames where the rut is
  // shallower (its bottom damp over the capillary fringe), its water deepening as the rut does.
  double surface_depth_mm = 0;
  double refractive_index = 1.333;  // fresh water in visible light
  // Beer-Lambert extinction coefficient c, 1/mm. Clear rain water 0.001-0.01 (the bottom seen through
  // 20 mm keeps 80-98 % of its contrast); silt-laden rut water 0.1-1 (the bottom vanishes within a few
  // millimetres of the shore; the default is muddy water).
  double attenuation_per_mm = 1.0;
  // Body colour: radiance of infinitely deep water relative to a white diffuse surface in the same light
  // (0.05 dark peaty water, 0.1-0.3 brown silt-laden water).
  double body_albedo = 0.15;
  // Relative modulation of the body colour by suspended silt: world-fixed plumes about 20 mm across.
  double silt_contrast = 0.05;
  // Floating debris: a level, textured lid at the water level over this fraction (0..1) of the surface.
  double debris_cover = 0;
  DebrisKind debris = DebrisKind::Foam;
  // Ripples: rms slope of the surface (0 = still; light wind or rain 0.02-0.1). The surface stays level
  // on average: only its normal is perturbed, by capillary-gravity waves travelling along
  // wind_azimuth_deg (wind) or by rings spreading from drops falling at rain_rate_per_m2_s (rain).
  double ripple_slope = 0;
  RippleKind ripple = RippleKind::Wind;
  double wind_azimuth_deg = 20;      // direction of travel of wind waves, from world +y towards +x
  double rain_rate_per_m2_s = 1500;  // drops per square metre and second (heavy rain)
  // Micro-roughness: standard deviation of the facets' normals, degrees, which spreads the sun's mirror
  // image into a glint lobe (still water 0.5-2; 0: no glint, a perfect mirror's sun is a point).
  double roughness_deg = 1.5;
  // Wet soil: under water, and fading over a capillary fringe wet_fringe_mm above the waterline, the
  // soil's albedo is multiplied by wet_albedo_factor (water fills the pores: wet sand is darker).
  double wet_albedo_factor = 0.7;
  double wet_fringe_mm = 4;
};

// What lights the scene and what the water reflects. The sun lights the soil (Lambert, plus a fixed
// ambient share from the sky) and its mirror image in the water is the glint. The sky's radiance rises
// from `zenith` overhead to `horizon` at the horizon. The vehicle's underside is a dark horizontal plane
// underside_height_mm above the ground over y > rig y + underside_edge_mm (the vehicle body ahead of
// its rear edge, moving with the rig), with chassis members across it; underside_height_mm = 0: none.
struct SkyConfig {
  cv::Vec3d sun{0.35, 0.25, 0.9};  // towards the sun, world frame, any length, z > 0
  double zenith = 0.35;
  double horizon = 0.65;
  double underside_height_mm = 650;
  double underside_edge_mm = -120;
  double underside_radiance = 0.04;
};

// One fault on a camera's protective window. The window lies a few millimetres in front of the lens, far
// out of focus: each pixel sees the scene through a disc of the window (LensConfig::defocus), so
// whatever lies there blocks, scatters or refracts part of that pixel's light.
struct LensFault {
  LensFaultKind kind = LensFaultKind::Mud;
  LensSide side = LensSide::Left;
  // Mud, Snow: the blob's width as a fraction of the image width (>= 1: the window covered whole);
  // Drops, Spray: the fraction of the window's area covered by drops or specks of mud; Dust: the film's
  // haze, the fraction of the light it scatters (0..1).
  double amount = 0.2;
  double centre = 0.5;  // Mud, Snow: the blob's centre, fraction of the image width, on the middle row
};

struct LensConfig {
  // Radius of the disc of the window each pixel sees through, in normalised image coordinates
  // (aperture radius / window distance; 0.03: a blur about 12 px in radius at 640 px and 75 degrees).
  double defocus = 0.03;
  std::vector<LensFault> faults;
};

struct SceneConditions {
  WaterConfig water;
  SkyConfig sky;
  LensConfig lens;
  // > 0: grass blades up to this tall (mm) standing on the ground outside the rut opening, one per
  // grass_spacing_mm square cell, each leaning and shaded by its own random draw (seed).
  double grass_height_mm = 0;
  double grass_spacing_mm = 6;
  // The right camera rotated against the calibration the renderer writes (degrees, about its own x axis,
  // i.e. pitch, which moves rows, and its z axis, roll): a calibration that no longer fits.
  double right_pitch_error_deg = 0;
  double right_roll_error_deg = 0;
};

// Throws std::invalid_argument naming the field (e.g. "water.level_mm") for impossible values.
// `min_depth_mm`: the shallowest the rut gets on any frame (the water must stay below the ground).
void validate(const SceneConditions& conditions, double min_depth_mm);

}  // namespace rutd
