// The scene matrix (daemon/scene_matrix.hpp) holds what issue-level targets are judged on: at least 40
// spoiled scenes (every kind of water in every texture, 5-30 mm deep, roll 0-5 degrees; every lens fault
// on the left, the right and both lenses) and at least 60 clean ones (every texture, manual and auto
// exposure, dim light, rigs and right cameras of another response). Every scene is a valid `rutd synth`
// command line, and the list is the same on every run.
#include <cmath>
#include <map>
#include <regex>
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "daemon/scene_matrix.hpp"
#include "daemon/scene_options.hpp"

namespace rutd {
namespace {

SyntheticRendererConfig parse(const std::string& synth) { return parse_scene_line(synth); }

TEST(SceneMatrix, CoversTheSpoiledAndCleanScenesAndEveryOneIsAValidSynthCommand) {
  const std::vector<MatrixScene> scenes = scene_matrix();
  std::map<std::string, int> groups;
  std::set<std::string> names, water_kind_texture, lens_kind_side, clean_texture_mode, steep_texture_mode;
  int checked = 0, entries = 0;
  for (const MatrixScene& s : scenes) {
    SCOPED_TRACE(s.name + ": " + s.synth);
    EXPECT_TRUE(names.insert(s.name).second) << "duplicate name";
    ++groups[s.group];
    SyntheticRendererConfig p;
    ASSERT_NO_THROW(p = parse(s.synth));
    ASSERT_NO_THROW(validate(p));  // what the renderer would refuse
    const std::string texture(to_string(p.texture));
    const WaterConfig& w = p.conditions.water;
    if (s.kind.rfind("water-", 0) == 0) {
      EXPECT_EQ(s.group, "spoiled");
      EXPECT_GE(w.level_mm, 5);
      EXPECT_LE(w.level_mm, 30);
      EXPECT_LE(std::abs(p.rig.roll_deg), 5);
      EXPECT_EQ(s.expect, std::vector<std::string>{"Water"});
      water_kind_texture.insert(s.kind + "/" + texture);
      if (s.kind == "water-clear") {
        EXPECT_LE(w.attenuation_per_mm, 0.01);
      } else if (s.kind == "water-turbid") {
        EXPECT_GE(w.attenuation_per_mm, 0.15);
      } else if (s.kind == "water-foam" || s.kind == "water-leaves" || s.kind == "water-litter") {
        EXPECT_GE(w.debris_cover, 0.4);
      } else if (s.kind == "water-wind" || s.kind == "water-rain") {
        EXPECT_GT(w.ripple_slope, 0);
      }
    } else if (s.kind.rfind("lens-", 0) == 0) {
      EXPECT_EQ(s.group, "spoiled");
      ASSERT_EQ(p.conditions.lens.faults.size(), 1u);
      lens_kind_side.insert(s.kind);
      EXPECT_FALSE(s.expect.empty());
    } else if (s.kind == "dark") {
      EXPECT_EQ(s.group, "spoiled");
      EXPECT_TRUE(p.auto_exposure.enabled);
      EXPECT_LT(p.light, 0.05);
      EXPECT_EQ(s.expect, std::vector<std::string>{"LowLight"});
    } else if (s.group == "clean") {
      EXPECT_EQ(w.level_mm, 0);
      EXPECT_TRUE(p.conditions.lens.faults.empty());
      EXPECT_TRUE(s.expect.empty());
      clean_texture_mode.insert(texture + "/" + s.kind);
      if (s.kind == "clean-auto-dim") {
        EXPECT_TRUE(p.auto_exposure.enabled);
        EXPECT_LE(p.light, 0.4);
      }
    } else if (s.group == "steep") {
      EXPECT_EQ(w.level_mm, 0);
      EXPECT_TRUE(p.conditions.lens.faults.empty());
      EXPECT_TRUE(s.expect.empty());
      EXPECT_NE(texture, "sand");  // dry sand slumps to its angle of repose
      EXPECT_GE(p.rut.depth_mm, 55);
      // Walls 51-61 degrees: each 0.55-0.8 of the depth across (rounded widths: 1 mm of slack).
      const double wall = (p.rut.width_mm - p.rut.bottom_width_mm) / 2;
      EXPECT_GE(wall, 0.55 * p.rut.depth_mm - 1);
      EXPECT_LE(wall, 0.8 * p.rut.depth_mm + 1);
      steep_texture_mode.insert(texture + "/" + s.kind);
    } else if (s.group == "tread") {
      EXPECT_TRUE(p.rut.tread);
    } else if (s.group == "entry") {
      // Dry on the first two pairs at least, wet from the fifth on, the first wet pair's water under the
      // deepening of one pair.
      ASSERT_EQ(p.depth_profile.size(), 2u);
      const double d0 = p.depth_profile[0].second, rate = (p.depth_profile[1].second - d0) / 7;
      EXPECT_EQ(w.level_mm, 0);
      EXPECT_LT(d0 + rate, w.surface_depth_mm);
      EXPECT_GT(d0 + 4 * rate, w.surface_depth_mm);
      EXPECT_EQ(s.expect, std::vector<std::string>{"Water"});
      ++entries;
    } else {
      EXPECT_EQ(s.group, "skew");
      EXPECT_NE(p.right_delay_ms, 0);
      EXPECT_EQ(s.expect, std::vector<std::string>{"UNSYNCHRONISED"});
    }
    EXPECT_EQ(p.rut.tread, s.group == "tread");
    // The rut, its piles and 40 mm of ground beside each are in both cameras' view on the principal row.
    const double half_view = p.rig.height_mm * std::tan(p.rig.hfov_deg / 2 * 3.141592653589793 / 180);
    const double reach = std::abs(p.rut.lateral_offset_mm) + p.rut.width_mm / 2 + p.rut.pile_width_mm + 40;
    EXPECT_LT(reach, half_view - p.rig.baseline_mm / 2);
    ++checked;
  }
  EXPECT_EQ(checked, static_cast<int>(scenes.size()));
  EXPECT_GE(groups["spoiled"], 40);
  EXPECT_GE(groups["clean"], 60);
  EXPECT_EQ(groups["steep"], 16);
  EXPECT_EQ(steep_texture_mode.size(), 3u * 4u);  // snow, mud and grass in every exposure mode
  EXPECT_EQ(entries, 10);
  EXPECT_EQ(water_kind_texture.size(), 8u * 4u);  // turbid, clear, foam, leaves, litter, glint, wind, rain x 4
  EXPECT_EQ(lens_kind_side.size(), 5u * 3u);      // mud, snow, drops, spray, dust x left, right, both
  EXPECT_EQ(clean_texture_mode.size(), 4u * 4u);  // every texture in every exposure mode
  // The same list on every run: drawn from a fixed seed.
  const std::vector<MatrixScene> again = scene_matrix();
  ASSERT_EQ(again.size(), scenes.size());
  for (std::size_t i = 0; i < scenes.size(); ++i) EXPECT_EQ(again[i].synth, scenes[i].synth);
}

}  // namespace
}  // namespace rutd
