// The synthetic scene's command-line options (daemon/scene_options.hpp) as `rutd synth` parses them: the
// conditions, the cameras' exposure and the faults on the lenses land in the renderer's settings, and a
// bad value is refused with an error that names the option.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "daemon/scene_options.hpp"

namespace rutd {
namespace {

SyntheticRendererConfig parse(const std::string& line) { return parse_scene_line(line); }

TEST(SceneOptions, ConditionsAndCamerasLandInTheRenderersSettings) {
  const SyntheticRendererConfig p = parse(
      "--depth 40 --water-level 12 --water-attenuation 0.005 --wet-fringe 15 --water-colour 0.1 --debris 0.5 "
      "--debris-kind leaves "
      "--ripple 0.05 --ripple-kind rain --sun-elevation 60 --sun-azimuth 180 --underside-height 0 --lens "
      "drops:each:0.2 --lens mud:left:0.3:0.4 --splash 0.2 --splash-camera right --auto-exposure --light 0.2 "
      "--right-response 1.04 --right-delay-ms 2.5");
  const WaterConfig& w = p.conditions.water;
  EXPECT_EQ(w.level_mm, 12);
  EXPECT_EQ(w.attenuation_per_mm, 0.005);
  EXPECT_EQ(w.wet_fringe_mm, 15);
  EXPECT_EQ(w.body_albedo, 0.1);
  EXPECT_EQ(w.debris_cover, 0.5);
  EXPECT_EQ(w.debris, DebrisKind::Leaves);
  EXPECT_EQ(w.ripple, RippleKind::Rain);
  // Elevation 60 degrees, azimuth 180 from the direction of travel: behind the vehicle.
  const cv::Vec3d sun = p.conditions.sky.sun;
  EXPECT_NEAR(sun[0], 0, 1e-12);
  EXPECT_NEAR(sun[1], -0.5, 1e-12);
  EXPECT_NEAR(sun[2], std::sqrt(3.0) / 2, 1e-12);
  EXPECT_EQ(p.conditions.sky.underside_height_mm, 0);
  ASSERT_EQ(p.conditions.lens.faults.size(), 3u);
  EXPECT_EQ(p.conditions.lens.faults[0].kind, LensFaultKind::Drops);
  EXPECT_EQ(p.conditions.lens.faults[0].side, LensSide::Each);
  EXPECT_EQ(p.conditions.lens.faults[1].centre, 0.4);
  EXPECT_EQ(p.conditions.lens.faults[2].kind, LensFaultKind::Mud);  // --splash: mud on one lens
  EXPECT_EQ(p.conditions.lens.faults[2].side, LensSide::Right);
  EXPECT_EQ(p.conditions.lens.faults[2].amount, 0.2);
  EXPECT_TRUE(p.auto_exposure.enabled);
  EXPECT_EQ(p.light, 0.2);
  EXPECT_EQ(p.right_response, 1.04);
  EXPECT_EQ(p.right_delay_ms, 2.5);
  EXPECT_NO_THROW(validate(p));
  // Unset, the sun is the default one.
  EXPECT_EQ(parse("").conditions.sky.sun, SkyConfig{}.sun);
}

TEST(SceneOptions, BadValuesAreRefusedNamingTheOption) {
  const std::pair<const char*, const char*> cases[] = {
      {"--lens mud:x:1", "--lens"},
      {"--lens dust:both:1.5", "--lens"},
      {"--lens fog:left:0.2", "--lens"},
      {"--lens drops:left:0.2:0.5", "--lens"},
      {"--lens mud:left", "--lens"},
      {"--lens mud:left:abc", "--lens"},
      {"--debris 0.3", "--debris"},
      {"--ripple 0.05", "--ripple"},
      {"--water-level 12 --ripple 0.6", "--ripple"},
      {"--water-level 12 --debris-kind sludge", "--debris-kind"},
      {"--depth 50 --water-level 60", "--water-level"},
      {"--water-level 20 --depth-profile 0:30,10:15", "--water-level"},
      {"--water-attenuation -1", "--water-attenuation"},
      {"--water-level 12 --water-surface 30", "--water-surface"},
      {"--water-surface -3", "--water-surface"},
      {"--wet-fringe -2", "--wet-fringe"},
      {"--sun-elevation 1", "--sun-elevation"},
      {"--gain 2 --auto-exposure", "--gain"},
      {"--gain 0.5", "--gain"},
      {"--light 0", "--light"},
      {"--ae-target 1.5", "--ae-target"},
      {"--right-response 2", "--right-response"},
      {"--right-delay-ms 40", "--right-delay-ms"},
      {"--lens-defocus 1", "--lens-defocus"},
  };
  int checked = 0;
  for (const auto& [line, option] : cases) {
    SCOPED_TRACE(line);
    try {
      parse(line);
      ADD_FAILURE() << "accepted";
    } catch (const CLI::Error& e) {
      EXPECT_NE(std::string(e.what()).find(option), std::string::npos) << e.what();
      ++checked;
    }
  }
  EXPECT_EQ(checked, static_cast<int>(std::size(cases)));
}

}  // namespace
}  // namespace rutd
