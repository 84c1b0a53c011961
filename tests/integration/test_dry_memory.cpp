// The dry memory (StereoMeasurer::recall_dry, DryMemory): a rule judging one strip by its looks (a level
// span taken for a lid, a waterline the profile stops at, a candidate read both ways, a lid recalled) is
// overruled where the two dry frames a moment before read the bottom steadily at the depth this frame's
// dry reading finds: the "lid" is the bottom they saw. On a clean mud rut (the scene matrix's
// clean-gain-mud-21) frame 2's flat bottom steps at both walls' feet and was refused as hidden by a
// waterline, after which the guard strips refused frames 4-7 too; read as the frames before, all eight are
// published within 1 mm of the renderer's truth. Not with the memory off, after one dry frame alone,
// after a longer gap than memory_s, or without both guard strips finding the bottom dry. And where the rut deepens into
// a pool (a level surface at a fixed depth below the ground, the water deepening as the rut does), the first wet
// frame's lid lies at the last dry frame's depth but the rut deepens 2 mm a frame: the dry frames were not steady, so
// it is refused (without the steadiness test it was published 1.9 mm short). A level rut running into a dip filled to
// its level: the dry frames are steady and the first wet frame's lid lies at their depth, over 1.95 mm of water, but
// the guard strip ahead is in the pool. Where the rut levels off into the pool, every frame is published within 1 mm or
// refused.
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "daemon/scene_options.hpp"
#include "measurement/measurer.hpp"
#include "measurer_configs.hpp"
#include "synthetic/synthetic_renderer.hpp"

namespace rutd {
namespace {

using test::strip_alone;

// The scene matrix's clean-gain-mud-21.
const char* kCleanMud =
    "--texture mud --depth 60.8 --width 299 --bottom-width 179 --pile-left 7.1 --pile-right 17.7 --offset 6 "
    "--baseline 84 --height 463 --hfov 75 --roll 2.9 --pitch -1.2 --noise 1.19 --speed 2122 "
    "--right-response 1.024 --seed 2021 --exposure 1.007 --gain 2.46";

struct Measured {
  RutMeasurement m;
  WaterRule overruled = WaterRule::None;
  double truth_mm = 0.0;
  double water_mm = 0.0;  // the truth's water over the bottom
};

// Frames `indices` in turn by one measurer, frame k captured shift_ns[k] later than the renderer says.
std::vector<Measured> run(const SyntheticRenderer& renderer, const MeasurerConfig& config,
                          const std::vector<std::uint64_t>& indices, const std::vector<std::int64_t>& shift_ns = {}) {
  StereoMeasurer measurer(renderer.calibration(), config);
  std::vector<Measured> out;
  for (std::size_t k = 0; k < indices.size(); ++k) {
    StereoFrame frame;
    renderer.render(indices[k], frame);
    Measured r;
    r.m =
        measurer.measure(frame.left, frame.right, frame.skew_ns, frame.t_ns + (k < shift_ns.size() ? shift_ns[k] : 0));
    r.overruled = measurer.diagnostics().dry_overruled;
    r.truth_mm = renderer.truth(indices[k]).depth_mm;
    r.water_mm = renderer.truth(indices[k]).water_depth_mm;
    out.push_back(r);
  }
  return out;
}

bool ok_within_1mm(const Measured& r) {
  return r.m.status == RutStatus::Ok && (r.m.conditions & kConditionWater) == 0 &&
         std::abs(r.m.depth_mm - r.truth_mm) <= 1.0;
}

bool bottom_hidden(const Measured& r) {
  return r.m.status == RutStatus::BottomNotSeen && (r.m.conditions & kConditionWater) != 0;
}

std::string describe(const Measured& r) {
  return std::string(to_string(r.m.status)) + " " + std::to_string(r.m.depth_mm) + " mm (truth " +
         std::to_string(r.truth_mm) + ", water " + std::to_string(r.water_mm) + ")" +
         ((r.m.conditions & kConditionWater) ? " Water" : "");
}

const std::vector<std::uint64_t> kEightFrames{0, 1, 2, 3, 4, 5, 6, 7};

TEST(DryMemory, AFalseFindingOnACleanRutIsReadAsTheSteadyDryFramesBefore) {
  const SyntheticRenderer renderer(parse_scene_line(kCleanMud));
  MeasurerConfig off;
  off.water.dry_tolerance_mm = 0.0;
  const std::vector<Measured> without = run(renderer, off, {0, 1, 2});
  ASSERT_TRUE(bottom_hidden(without[2])) << describe(without[2]) << ": frame 2 no longer raises the case";

  const std::vector<Measured> with = run(renderer, MeasurerConfig{}, {0, 1, 2});
  EXPECT_TRUE(ok_within_1mm(with[2])) << describe(with[2]);
  EXPECT_EQ(with[2].overruled, WaterRule::WaterlineHides);

  // Frame 2 once cost frames 4-7 too: the guards, asked for water after it, found "water" of their own.
  const std::vector<Measured> all = run(renderer, MeasurerConfig{}, kEightFrames);
  int within = 0;
  for (std::size_t i = 0; i < all.size(); ++i) {
    EXPECT_TRUE(ok_within_1mm(all[i])) << "frame " << i << ": " << describe(all[i]);
    within += ok_within_1mm(all[i]);
  }
  EXPECT_EQ(within, 8);
}

TEST(DryMemory, NeedsTwoSteadyDryFramesAMomentBeforeAndBothGuards) {
  const SyntheticRenderer renderer(parse_scene_line(kCleanMud));
  // One dry frame before: how the rut goes on is not known.
  const std::vector<Measured> one = run(renderer, MeasurerConfig{}, {1, 2});
  EXPECT_TRUE(bottom_hidden(one[1])) << describe(one[1]);
  EXPECT_EQ(one[1].overruled, WaterRule::None);
  // Frame 2 captured 0.6 s after frame 1: longer than memory_s (0.5 s).
  const std::vector<Measured> late = run(renderer, MeasurerConfig{}, {0, 1, 2}, {0, 0, 533'000'000});
  EXPECT_TRUE(bottom_hidden(late[2])) << describe(late[2]);
  // No guard strips to find the bottom dry.
  const std::vector<Measured> alone = run(renderer, strip_alone(), {0, 1, 2});
  EXPECT_TRUE(bottom_hidden(alone[2])) << describe(alone[2]);
  // A frame the memory overruled does not renew it; frame 3, dry by its own looks, does.
  const std::vector<Measured> after = run(renderer, MeasurerConfig{}, {0, 1, 2, 3});
  EXPECT_TRUE(ok_within_1mm(after[3])) << describe(after[3]);
  EXPECT_EQ(after[3].overruled, WaterRule::None);
}

// A mud rut deepening from 40 mm by `rate_mm` a frame (frame 11 at 40 + 11 rate) into a pool whose surface
// lies `surface_mm` below the ground, its shore sharp (no capillary fringe), a lid of `debris` over it.
std::string pool_scene(double rate_mm, double surface_mm, const char* debris) {
  return "--texture mud --depth 40 --depth-profile 0:40,11:" + std::to_string(40 + 11 * rate_mm) + " --water-surface " +
         std::to_string(surface_mm) + " --wet-fringe 0 --debris 0.9 --debris-kind " + debris +
         " --water-attenuation 0.3 --seed 77";
}

// Every frame published within 1 mm of the truth or refused, and every frame with more than
// min_water_mm of water over the bottom refused with Water; returns the wet frames refused so.
int check_pool(const std::vector<Measured>& r, double min_water_mm) {
  int wet_refused = 0;
  for (std::size_t i = 0; i < r.size(); ++i) {
    EXPECT_TRUE(r[i].m.status != RutStatus::Ok || std::abs(r[i].m.depth_mm - r[i].truth_mm) <= 1.0)
        << "frame " << i << ": " << describe(r[i]);
    if (r[i].water_mm > min_water_mm) {
      EXPECT_TRUE(r[i].m.status != RutStatus::Ok && (r[i].m.conditions & kConditionWater) != 0)
          << "frame " << i << ": " << describe(r[i]);
      wet_refused += r[i].m.status != RutStatus::Ok && (r[i].m.conditions & kConditionWater) != 0;
    }
  }
  return wet_refused;
}

TEST(DryMemory, ARutPlungingIntoAPoolIsNotReadAsTheDryFramesBefore) {
  // 2 mm a frame; frame 3 dry at 46 mm, frame 4 under 1.9 mm of water whose lid lies where frame 3's bottom was.
  for (const char* debris : {"foam", "litter"}) {
    SCOPED_TRACE(debris);
    const SyntheticRenderer renderer(parse_scene_line(pool_scene(2.0, 46.1, debris)));
    const std::vector<Measured> r = run(renderer, MeasurerConfig{}, kEightFrames);
    EXPECT_GT(r[4].water_mm, 1.8);
    EXPECT_EQ(r[4].overruled, WaterRule::None);
    EXPECT_EQ(check_pool(r, 1.0), 4);  // frames 4-7
  }
}

TEST(DryMemory, ALevelRutRunningIntoABrimFullPoolIsNotReadAsTheDryFramesBefore) {
  // Level at 40 mm for frames 0-3, then a dip 2 mm deeper a frame, filled to 0.05 mm below the level
  // bottom: frame 4's lid lies where the steady dry frames read the bottom, over 1.95 mm of water. The
  // guard ahead of the strip is in the pool already.
  for (const char* debris : {"foam", "litter"}) {
    SCOPED_TRACE(debris);
    const SyntheticRenderer renderer(parse_scene_line(
        "--texture mud --depth 40 --depth-profile 0:40,3:40,11:56 --water-surface 40.05 --wet-fringe 0 --debris 0.9 "
        "--debris-kind " +
        std::string(debris) + " --water-attenuation 0.3 --seed 78"));
    const std::vector<Measured> r = run(renderer, MeasurerConfig{}, kEightFrames);
    EXPECT_GT(r[4].water_mm, 1.9);
    EXPECT_EQ(check_pool(r, 1.0), 4);  // frames 4-7
  }
}

TEST(DryMemory, ARutLevellingIntoAPoolIsReadWithinAMillimetre) {
  // 0.15 mm a frame: the dry frames are steady, and the water deepens past 1 mm by frame 11.
  const SyntheticRenderer renderer(parse_scene_line(pool_scene(0.15, 40.5, "foam")));
  std::vector<std::uint64_t> frames;
  for (std::uint64_t i = 0; i < 12; ++i) frames.push_back(i);
  const std::vector<Measured> r = run(renderer, MeasurerConfig{}, frames);
  EXPECT_GT(r[11].water_mm, 1.0);
  EXPECT_GE(check_pool(r, 1.0), 1);
}

}  // namespace
}  // namespace rutd
