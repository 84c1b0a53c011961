// The waterline (rut/waterline.hpp): found from brightness steps on constructed profiles, and the
// refraction correction against an independent forward model (Fermat's principle solved by bisection).
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "rut/extract.hpp"
#include "rut/waterline.hpp"
#include "test_rut_profile.hpp"

namespace rutd {
namespace {

using namespace test;

constexpr double kN = 1.333;

bool depth_found_for_test(RutStatus status) {
  return status == RutStatus::Ok || status == RutStatus::Uncertain || status == RutStatus::Vegetation;
}

struct Scene {
  RutShape shape;
  View view;
  CrossSection section;
  RutWorkspace ws;
  RutMeasurement m;
  Scene() {
    view.ground_z = 400.0;
    shape.depth = 40.0;
    section = make_section(shape, view, -220.0, 441, 1.0, 0.05, 3);
    m = extract_rut(section, RutConfig{}, ws);
  }
  // Brightness per bin: soil of grey level 100 with a log-normal texture of `texture` (log sd), times
  // `below` where the terrain lies deeper than `level` under the ground on the side(s) asked for.
  std::vector<double> brightness(double level, double below, double texture, bool left = true, bool right = true,
                                 double right_level = kNaN) const {
    std::mt19937 rng(7);
    std::normal_distribution<double> noise(0.0, texture);
    std::vector<double> b;
    for (std::size_t i = 0; i < section.z_mm.size(); ++i) {
      const double x = section.x0_mm + section.dx_mm * double(i);
      const double depth = z_at_x(shape, view, x) - view.ground_z;
      const double l = x < 0 ? level : std::isnan(right_level) ? level : right_level;
      const bool wet = depth > l && ((x < 0 && left) || (x >= 0 && right));
      b.push_back(100.0 * std::exp(noise(rng)) * (wet ? below : 1.0));
    }
    return b;
  }
};

TEST(Waterline, FoundWhereBothWallsDarkenAtOneHeight) {
  Scene s;
  ASSERT_EQ(s.m.status, RutStatus::Ok);
  WaterlineWorkspace ws;
  const Waterline w = find_waterline(s.section, s.brightness(25.0, 0.6, 0.05), s.ws.geometry, WaterlineConfig{}, ws);
  ASSERT_TRUE(w.found);
  EXPECT_NEAR(w.level_mm, 25.0, 1.0);
  EXPECT_LT(w.left_step, 0.0);
  EXPECT_LT(w.right_step, 0.0);
  EXPECT_LT(w.left_x_mm, 0.0);
  EXPECT_GT(w.right_x_mm, 0.0);
  // The span under it is darker than the dry flat ground on both sides as well...
  EXPECT_NEAR(w.submerged_ground_step, std::log(0.6), 0.1);
  // ... unless the ground is as dark (a soil blotched on a larger scale than the rut).
  std::vector<double> dark_ground = s.brightness(25.0, 0.6, 0.05);
  for (std::size_t i = 0; i < dark_ground.size(); ++i) {
    const double x = s.section.x0_mm + s.section.dx_mm * double(i);
    if (x < s.ws.geometry.left_x_mm || x > s.ws.geometry.right_x_mm) dark_ground[i] *= 0.6;
  }
  const Waterline blotched = find_waterline(s.section, dark_ground, s.ws.geometry, WaterlineConfig{}, ws);
  ASSERT_TRUE(blotched.found);
  EXPECT_NEAR(blotched.submerged_step, w.submerged_step, 1e-9);
  EXPECT_NEAR(blotched.submerged_ground_step, 0.0, 0.1);
  // A lid brighter than the soil: the same rule, the other sense.
  const Waterline lid = find_waterline(s.section, s.brightness(25.0, 1.6, 0.05), s.ws.geometry, WaterlineConfig{}, ws);
  ASSERT_TRUE(lid.found);
  EXPECT_GT(lid.left_step, 0.0);
}

TEST(Waterline, NotFoundOnOneWallOnly) {  // a shadow or a wet patch on one wall is no level surface
  Scene s;
  WaterlineWorkspace ws;
  EXPECT_FALSE(
      find_waterline(s.section, s.brightness(25.0, 0.6, 0.05, true, false), s.ws.geometry, WaterlineConfig{}, ws)
          .found);
}

TEST(Waterline, NotFoundAtTwoHeights) {  // a surface is level: steps 10 mm apart are two other edges
  Scene s;
  WaterlineWorkspace ws;
  EXPECT_FALSE(
      find_waterline(s.section, s.brightness(15.0, 0.6, 0.05, true, true, 25.0), s.ws.geometry, WaterlineConfig{}, ws)
          .found);
}

TEST(Waterline, NotFoundForABandThatDoesNotPersistBelow) {  // a dark stripe at one height is no surface
  Scene s;
  WaterlineWorkspace ws;
  std::vector<double> b = s.brightness(25.0, 0.6, 0.05);
  const std::vector<double> dry = s.brightness(25.0, 1.0, 0.05);
  for (std::size_t i = 0; i < b.size(); ++i) {
    const double depth = z_at_x(s.shape, s.view, s.section.x0_mm + double(i)) - s.view.ground_z;
    if (depth > 29.0) b[i] = dry[i];  // dark only between 25 and 29 mm below the ground
  }
  EXPECT_FALSE(find_waterline(s.section, b, s.ws.geometry, WaterlineConfig{}, ws).found);
}

TEST(Waterline, NotFoundWhereTheSoilVariesAsMuch) {
  Scene s;
  WaterlineWorkspace ws;
  // The soil's own texture at the window's scale as strong as the step: no evidence of a surface.
  EXPECT_FALSE(find_waterline(s.section, s.brightness(25.0, 0.8, 0.35), s.ws.geometry, WaterlineConfig{}, ws).found);
  // No step at all.
  EXPECT_FALSE(find_waterline(s.section, s.brightness(25.0, 1.0, 0.05), s.ws.geometry, WaterlineConfig{}, ws).found);
}

// A floating lid at `level` below the ground: the section stops there (a flat, level span as smooth as
// the matcher's noise), of uniform brightness, `lid_left` / `lid_right` times the soil's on each half
// of the scene (the soil on one side in shade, say).
struct LidScene {
  Scene base;
  CrossSection section;
  RutWorkspace ws;
  RutMeasurement m;
  std::vector<double> brightness;
  LidScene(double level, double lid_left, double lid_right, double lid_noise = 0.0) {
    std::mt19937 rng(11);
    std::normal_distribution<double> noise(0.0, 1.0);
    section = base.section;
    brightness = base.brightness(level, 1.0, 0.05);
    for (std::size_t i = 0; i < section.z_mm.size(); ++i) {
      const double x = section.x0_mm + section.dx_mm * double(i);
      if (z_at_x(base.shape, base.view, x) - base.view.ground_z <= level) {
        brightness[i] /= x < 0 ? lid_left : lid_right;
        continue;
      }
      section.z_mm[i] = base.view.ground_z + level + 0.05 * noise(rng) + lid_noise * noise(rng);
    }
    m = extract_rut(section, RutConfig{}, ws);
  }
};

TEST(WaterlineLid, FoundWithAStepOnOneWallOnly) {  // foam on snow: as bright as the snow on one wall
  LidScene s(25.0, 1.0, 1.5);
  ASSERT_TRUE(depth_found_for_test(s.m.status));
  WaterlineWorkspace ws;
  // The pair of steps find_waterline needs is not there...
  EXPECT_FALSE(find_waterline(s.section, s.brightness, s.ws.geometry, WaterlineConfig{}, ws).found);
  // ...the level span lit unlike one wall is.
  const LevelSpan lid = find_level_span(s.section, s.brightness, {}, s.ws.geometry, WaterlineConfig{}, ws);
  ASSERT_TRUE(lid.found);
  EXPECT_NEAR(lid.level_mm, 25.0, 0.2);
  EXPECT_NEAR(lid.left_step, 0.0, 0.1);
  EXPECT_NEAR(lid.right_step, std::log(1.5), 0.15);
  EXPECT_NEAR(lid.tilt, 0.0, 0.01);
  // The lid spans the rut where the truth lies deeper than the level: about 2 x 68.7 mm wide here.
  const double half = 50.0 + 50.0 * std::acos(2.0 * 25.0 / 40.0 - 1.0) / kPi;
  EXPECT_NEAR(lid.right_x_mm - lid.left_x_mm, 2.0 * half, 4.0);
  // A darker lid (wet litter) the same.
  EXPECT_TRUE(find_level_span(LidScene(25.0, 0.6, 1.0).section, LidScene(25.0, 0.6, 1.0).brightness, {},
                              LidScene(25.0, 0.6, 1.0).ws.geometry, WaterlineConfig{}, ws)
                  .found);
}

TEST(WaterlineLid, NotFoundOnARutBottomLitLikeItsWalls) {
  Scene s;  // the rut's own flat bottom, level and smooth, soil brightness throughout
  WaterlineWorkspace ws;
  const LevelSpan span =
      find_level_span(s.section, s.brightness(25.0, 1.0, 0.05), {}, s.ws.geometry, WaterlineConfig{}, ws);
  EXPECT_FALSE(span.found);
  EXPECT_NEAR(span.level_mm, 40.0, 0.3);  // the span delimited is the bottom
  EXPECT_LT(std::max(std::abs(span.left_step), std::abs(span.right_step)), span.step_threshold);
}

TEST(WaterlineLid, UnlikeTheGroundWhereItsEdgesStepTooLittle) {  // litter on snow, the walls in shade
  // A lid 1.35 times darker than the soil everywhere: log -0.30 against the walls, under the 1.5 x 0.22
  // a single step needs, and the same against the flat ground, over the 1.1 x 0.22 that asks.
  LidScene s(25.0, 1.0 / 1.35, 1.0 / 1.35);
  ASSERT_TRUE(depth_found_for_test(s.m.status));
  WaterlineWorkspace ws;
  const LevelSpan lid = find_level_span(s.section, s.brightness, {}, s.ws.geometry, WaterlineConfig{}, ws);
  EXPECT_FALSE(lid.found);
  EXPECT_NEAR(lid.ground_step, -std::log(1.35), 0.05);
  EXPECT_TRUE(lid.unlike_ground);
  // Without the brightness, nothing is judged (the workspace still holds this call's).
  const LevelSpan blind = find_level_span(s.section, {}, {}, s.ws.geometry, WaterlineConfig{}, ws);
  EXPECT_EQ(blind.ground_step, 0.0);
  EXPECT_FALSE(blind.found);
  EXPECT_FALSE(blind.unlike_ground);
  // As bright as the ground: a rut's own bottom, however level and smooth.
  Scene bottom;
  const LevelSpan own = find_level_span(bottom.section, bottom.brightness(25.0, 1.0, 0.05), {}, bottom.ws.geometry,
                                        WaterlineConfig{}, ws);
  EXPECT_NEAR(own.ground_step, 0.0, 0.05);
  EXPECT_FALSE(own.unlike_ground);
  // 1.2 times darker: log -0.18, under the factor.
  LidScene faint(25.0, 1.0 / 1.2, 1.0 / 1.2);
  // Darker than the ground on one side, brighter than on the other: a soil blotched on a larger scale.
  LidScene blotched(25.0, 1.0 / 1.5, 1.5);
  const LevelSpan two =
      find_level_span(blotched.section, blotched.brightness, {}, blotched.ws.geometry, WaterlineConfig{}, ws);
  EXPECT_EQ(two.ground_step, 0.0);
  EXPECT_FALSE(two.unlike_ground);
  EXPECT_FALSE(
      find_level_span(faint.section, faint.brightness, {}, faint.ws.geometry, WaterlineConfig{}, ws).unlike_ground);
}

TEST(WaterlineLid, NotFoundOnABottomRougherThanTheGround) {  // clods lit unlike the walls
  LidScene s(25.0, 1.0, 1.5, 0.3);
  WaterlineWorkspace ws;
  const LevelSpan span = find_level_span(s.section, s.brightness, {}, s.ws.geometry, WaterlineConfig{}, ws);
  EXPECT_GT(span.roughness_mm, 4.0 * span.ground_roughness_mm);
  EXPECT_FALSE(span.found);
  // Floating debris, bumpier than still water and the ground, is a lid all the same...
  LidScene debris(25.0, 1.0, 1.5, 0.1);
  const LevelSpan bumpy =
      find_level_span(debris.section, debris.brightness, {}, debris.ws.geometry, WaterlineConfig{}, ws);
  EXPECT_GT(bumpy.roughness_mm, 1.5 * bumpy.ground_roughness_mm);
  EXPECT_TRUE(bumpy.found);
  // ... as is a smooth lid.
  LidScene smooth(25.0, 1.0, 1.5, 0.0);
  EXPECT_TRUE(find_level_span(smooth.section, smooth.brightness, {}, smooth.ws.geometry, WaterlineConfig{}, ws).found);
}

// A lid brighter all round (WaterlineConfig::lid_bright_factor): log 0.18 over the walls and the ground on
// both sides, under what one step (1.5 x 0.22) or the ground alone (1.1 x 0.22) needs, over 0.5 x 0.22.
TEST(WaterlineLid, BrighterThanBothWallsAndTheGroundIsNotSoil) {
  LidScene s(25.0, 1.2, 1.2);
  ASSERT_TRUE(depth_found_for_test(s.m.status));
  WaterlineWorkspace ws;
  const auto span = [&](const LidScene& scene, const std::vector<double>& brightness, const WaterlineConfig& c) {
    return find_level_span(scene.section, brightness, {}, scene.ws.geometry, c, ws);
  };
  const LevelSpan lid = span(s, s.brightness, WaterlineConfig{});
  EXPECT_FALSE(lid.found);
  EXPECT_FALSE(lid.unlike_ground);
  EXPECT_NEAR(lid.left_step, std::log(1.2), 0.05);
  EXPECT_NEAR(lid.right_step, std::log(1.2), 0.05);
  EXPECT_NEAR(lid.ground_step, std::log(1.2), 0.05);
  EXPECT_TRUE(lid.brighter_all_round);
  WaterlineConfig off;
  off.lid_bright_factor = 0.0;
  EXPECT_FALSE(span(s, s.brightness, off).brighter_all_round);
  // Darker all round: the rut's own shade, not judged.
  LidScene dark(25.0, 1.0 / 1.2, 1.0 / 1.2);
  EXPECT_FALSE(span(dark, dark.brightness, WaterlineConfig{}).brighter_all_round);
  // Brighter than one side only.
  LidScene one(25.0, 1.2, 1.0);
  EXPECT_FALSE(span(one, one.brightness, WaterlineConfig{}).brighter_all_round);
  // Brighter than the ground but lit like its walls: soil cut down to a paler layer, walls and bottom.
  std::vector<double> paler = s.brightness;
  const RutGeometry& g = s.ws.geometry;
  int walls = 0;
  for (std::size_t i = 0; i < paler.size(); ++i) {
    const double x = s.section.x0_mm + s.section.dx_mm * double(i);
    const double depth = z_at_x(s.base.shape, s.base.view, x) - s.base.view.ground_z;
    if (x > g.left_x_mm && x < g.right_x_mm && depth > 2.0 && depth <= 25.0) {
      paler[i] *= 1.2;
      ++walls;
    }
  }
  ASSERT_GT(walls, 20);
  const LevelSpan cut = span(s, paler, WaterlineConfig{});
  EXPECT_NEAR(cut.left_step, 0.0, 0.05);
  EXPECT_FALSE(cut.brighter_all_round);
  // Brighter by log 0.05: within the soil's own variation.
  LidScene faint(25.0, 1.05, 1.05);
  EXPECT_FALSE(span(faint, faint.brightness, WaterlineConfig{}).brighter_all_round);
}

// Foam on snow: lit like the soil (no brightness step anywhere), but another material. Texture per bin
// (WaterlineConfig::lid_texture_step): the soil's 0.05 with a log-normal scatter of 0.1, the lid's
// `factor` times that.
TEST(WaterlineLid, OfAnotherMaterialWhereItsTextureIsUnlikeTheSoilsAllRound) {
  LidScene s(25.0, 1.0, 1.0);
  ASSERT_TRUE(depth_found_for_test(s.m.status));
  WaterlineWorkspace ws;
  const auto texture = [&](double factor) {
    std::vector<double> t = s.base.brightness(25.0, factor, 0.1);
    for (double& v : t) v *= 0.05 / 100.0;
    return t;
  };
  const auto span = [&](const std::vector<double>& t) {
    return find_level_span(s.section, s.brightness, t, s.ws.geometry, WaterlineConfig{}, ws);
  };
  const LevelSpan foam = span(texture(3.0));
  EXPECT_FALSE(foam.found);  // no brightness cue...
  EXPECT_FALSE(foam.unlike_ground);
  EXPECT_TRUE(foam.other_material);  // ...the texture's
  EXPECT_NEAR(foam.texture_left_step, std::log(3.0), 0.15);
  EXPECT_NEAR(foam.texture_right_step, std::log(3.0), 0.15);
  EXPECT_NEAR(foam.texture_ground_step, std::log(3.0), 0.15);
  EXPECT_TRUE(span(texture(1.0 / 3.0)).other_material);  // a smoother lid (still water with a film)
  // A steep wall matched for two bins beside the lid, lost below (DIC): those two will do.
  std::vector<double> steep = texture(3.0);
  for (std::size_t i = 0; i < steep.size(); ++i) {
    const double x = s.section.x0_mm + s.section.dx_mm * double(i);
    if (x > foam.right_x_mm + 2.5 && x < foam.right_x_mm + 20.0) steep[i] = kNaN;
  }
  const LevelSpan lost = span(steep);
  EXPECT_NEAR(lost.texture_right_step, std::log(3.0), 0.25);
  EXPECT_TRUE(lost.other_material);
  // 2 times: log 0.69, under the 0.8 asked (a rut bottom compacted by the tyre).
  EXPECT_FALSE(span(texture(2.0)).other_material);
  EXPECT_FALSE(span(texture(1.0)).other_material);
  // Unlike the walls but like the ground beyond them on both sides: a rut's bottom of the ground's soil
  // between walls of another (a rut cut through a top layer).
  const RutGeometry& g = s.ws.geometry;
  std::vector<double> like_ground = texture(3.0);
  for (std::size_t i = 0; i < like_ground.size(); ++i) {
    const double x = s.section.x0_mm + s.section.dx_mm * double(i);
    if (x < g.left_x_mm - 5.0 || x > g.right_x_mm + 5.0) like_ground[i] *= 3.0;
  }
  const LevelSpan layer = span(like_ground);
  EXPECT_NEAR(layer.texture_ground_step, 0.0, 0.15);
  EXPECT_FALSE(layer.other_material);
  // Unlike one wall only: the other side's soil is the lid's.
  std::vector<double> one_wall = texture(3.0);
  for (std::size_t i = 0; i < one_wall.size(); ++i) {
    const double x = s.section.x0_mm + s.section.dx_mm * double(i);
    const double depth = z_at_x(s.base.shape, s.base.view, x) - s.base.view.ground_z;
    if (x < 0.0 && depth <= 25.0) one_wall[i] *= 3.0;
  }
  EXPECT_FALSE(span(one_wall).other_material);
  // Without the texture, nothing is judged; with the rule off, neither.
  const LevelSpan blind = span({});
  EXPECT_TRUE(std::isnan(blind.texture_left_step));
  EXPECT_FALSE(blind.other_material);
  WaterlineConfig off;
  off.lid_texture_step = 0.0;
  EXPECT_FALSE(find_level_span(s.section, s.brightness, texture(3.0), s.ws.geometry, off, ws).other_material);
}

// Forward model: the point of the X-Z plane where a camera at (cx, 0) sees the bottom point p through a
// level surface at Z = surface (Fermat: the surface point where sin(i) = n sin(r), by bisection).
cv::Point2d surface_point(double cx, cv::Point2d p, double surface) {
  double lo = std::min(cx, p.x), hi = std::max(cx, p.x);
  const auto f = [&](double sx) {
    const double s1 = (sx - cx) / std::hypot(sx - cx, surface);
    const double s2 = (p.x - sx) / std::hypot(p.x - sx, p.y - surface);
    return s1 - kN * s2;
  };
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (f(mid) < 0.0 ? lo : hi) = mid;
  }
  return {0.5 * (lo + hi), surface};
}

// Where a stereo pair (baseline b) triangulates p seen through the surface: the straight lines from
// each camera through its surface point, intersected.
cv::Point2d apparent_point(cv::Point2d p, double b, double surface) {
  const cv::Point2d sl = surface_point(0.0, p, surface), sr = surface_point(b, p, surface);
  // (0,0) + t sl = (b,0) + u (sr - (b,0)): solve for t.
  const double ax = sl.x, az = sl.y, bx = sr.x - b, bz = sr.y;
  const double t = (b * bz) / (ax * bz - az * bx);
  return {t * ax, t * az};
}

// The share of the submerged span seen below the surface (WaterlineConfig::min_share_seen_below), on a
// section 10 mm below a level ground at Z 400 between waterlines at X -50 and 50 (101 bins).
TEST(Waterline, ShareSeenBelowCountsTheBinsDeeperThanTheSurface) {
  RutGeometry g;
  g.has_line = true;
  g.line_c = 400.0;
  Waterline line;
  line.found = true;
  line.level_mm = 10.0;
  line.left_x_mm = -50.0;
  line.right_x_mm = 50.0;
  const auto section = [](auto depth) {
    CrossSection s;
    s.x0_mm = -80.0;
    for (int i = 0; i <= 160; ++i) {
      s.z_mm.push_back(400.0 + depth(-80.0 + i));
      s.count.push_back(1);
    }
    return s;
  };
  // Clear water: the bottom seen 8 mm below the surface from X -40 to 40, walls of slope 0.8 up to the
  // waterlines; deeper than 1 mm below the surface where |X| <= 48 (97 bins).
  const CrossSection clear =
      section([](double x) { return std::abs(x) <= 40.0 ? 18.0 : 10.0 + 0.8 * (50.0 - std::abs(x)); });
  EXPECT_NEAR(share_seen_below(clear, g, line, 1.0), 97.0 / 101.0, 1e-9);
  EXPECT_NEAR(share_seen_below(clear, g, line, 9.0), 0.0, 1e-9);  // 8 mm deep is not deeper than 9
  // A lid with one gap 10 bins wide (X 0-9) where the matcher reaches 2 mm deeper.
  const CrossSection lid = section([](double x) { return x >= 0.0 && x <= 9.0 ? 12.0 : 10.0; });
  EXPECT_NEAR(share_seen_below(lid, g, line, 1.0), 10.0 / 101.0, 1e-9);
  EXPECT_EQ(share_seen_below(lid, g, line, 2.5), 0.0);  // the margin counts: 2 mm is not deeper than 2.5
  // Unmatched bins count neither way: the lid's bins outside the gap lost, the share is the gap's.
  CrossSection holes = lid;
  for (int i = 30; i <= 130; ++i)
    if (i < 80 || i > 89) holes.z_mm[static_cast<std::size_t>(i)] = kNaN;
  EXPECT_NEAR(share_seen_below(holes, g, line, 1.0), 1.0, 1e-9);
  // A ground line tilted by 0.1: depths are perpendicular to it.
  RutGeometry tilted = g;
  tilted.line_m = 0.1;
  const double norm = std::sqrt(1.01);
  CrossSection t = lid;
  for (int i = 0; i <= 160; ++i) {
    const double x = -80.0 + i;
    t.z_mm[static_cast<std::size_t>(i)] = 400.0 + 0.1 * x + norm * (x >= 0.0 && x <= 9.0 ? 12.0 : 10.0);
  }
  EXPECT_NEAR(share_seen_below(t, tilted, line, 1.0), 10.0 / 101.0, 1e-9);
  g.has_line = false;
  EXPECT_EQ(share_seen_below(clear, g, line, 1.0), 0.0);
}

TEST(Waterline, RefractionRecoversTheBottomRayByRay) {
  const double ground = 400.0, level = 12.0, baseline = 70.0;
  RutGeometry g;
  g.has_line = true;
  g.line_m = 0.0;
  g.line_c = ground;
  // True bottom: a wall descending from the surface (x = -60) to 30 mm of water at x = -20, then flat.
  const auto bottom = [&](double x) { return ground + level + std::clamp((x + 60.0) * 0.75, 0.0, 30.0); };
  std::vector<cv::Point2d> seen;
  for (double x = -100.0; x <= 100.0; x += 0.02) {
    const cv::Point2d p(x, bottom(x));
    seen.push_back(p.y > ground + level ? apparent_point(p, baseline, ground + level) : p);
  }
  CrossSection apparent;
  apparent.x0_mm = -80.0;
  apparent.dx_mm = 1.0;
  for (int i = 0; i <= 160; ++i) {
    const double x = -80.0 + i;
    std::size_t k = 0;
    while (k + 2 < seen.size() && seen[k + 1].x < x) ++k;
    const double t = (x - seen[k].x) / (seen[k + 1].x - seen[k].x);
    apparent.z_mm.push_back(seen[k].y + t * (seen[k + 1].y - seen[k].y));
    apparent.count.push_back(1);
  }
  // The apparent bottom is about 1/n as deep below the surface: 30 mm reads as 22.5 mm.
  EXPECT_NEAR(apparent.z_mm[110] - (ground + level), 30.0 / kN, 0.5);
  CrossSection corrected;
  WaterlineWorkspace ws;
  refract_section(apparent, g, level, kN, baseline, 0.0, corrected, ws);
  ASSERT_EQ(corrected.z_mm.size(), apparent.z_mm.size());
  int checked = 0;
  for (int i = 0; i <= 160; ++i) {
    const double x = -80.0 + i;
    ASSERT_FALSE(std::isnan(corrected.z_mm[static_cast<std::size_t>(i)])) << x;
    EXPECT_NEAR(corrected.z_mm[static_cast<std::size_t>(i)], bottom(x), 0.01) << "x " << x;
    ++checked;
  }
  EXPECT_EQ(checked, 161);
  // Another index gives another bottom: the correction depends on n as the model says.
  refract_section(apparent, g, level, 1.0, baseline, 0.0, corrected, ws);
  EXPECT_NEAR(corrected.z_mm[110], apparent.z_mm[110], 1e-9);
}

}  // namespace
}  // namespace rutd
