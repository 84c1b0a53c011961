// The waterline's memory (WaterlineConfig::memory_s): clear water 8 mm deep in a 24 mm mud rut, whose wet
// walls darken, against the blotchy mud, more than a candidate waterline's threshold on every frame but
// a confirmed one's on half of them. Frames that confirm their waterline are read through the surface
// and published within 1 mm of the truth; the others, alone, are read both ways and refused UNCERTAIN
// (dry, the depth is 2 mm short). Measured right after a frame that confirmed its waterline at the same
// level, a candidate is that water's waterline and is read through: within 1 mm of the renderer's truth,
// flagged Water. Not after a longer gap than memory_s, not with the memory off, and not after a frame
// that only recalled its waterline (a chain would carry one chance confirmation on for ever).
// And where a frame shows no steps at all a moment after one that confirmed a waterline (19 mm of clear
// water on snow), it is read both ways at that level: never the dry depth, 4.8 mm short, published OK.
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "daemon/scene_options.hpp"
#include "measurement/measurer.hpp"
#include "synthetic/synthetic_renderer.hpp"

namespace rutd {
namespace {

// The scene matrix's water-clear-mud-01.
const char* kClearWaterOnMud =
    "--texture mud --depth 23.7 --width 251 --bottom-width 136 --pile-left 8.9 --pile-right 8.6 --baseline 69 "
    "--height 368 --roll -3.8 --seed 1001 --water-level 8.2 --water-attenuation 0.0036 --water-colour 0.10";

struct Measured {
  RutMeasurement m;
  double truth_mm = 0.0;
};

// Measures frame `index` of the scene, as captured `shift_ns` later than the renderer says.
Measured measure(StereoMeasurer& measurer, const SyntheticRenderer& renderer, std::uint64_t index,
                 std::int64_t shift_ns = 0) {
  StereoFrame frame;
  renderer.render(index, frame);
  Measured out;
  out.m = measurer.measure(frame.left, frame.right, frame.skew_ns, frame.t_ns + shift_ns);
  out.truth_mm = renderer.truth(index).depth_mm;
  return out;
}

bool read_through(const Measured& r) {
  return r.m.status == RutStatus::Ok && (r.m.conditions & kConditionWater) != 0 &&
         std::abs(r.m.depth_mm - r.truth_mm) <= 1.0;
}

bool refused_uncertain_with_water(const Measured& r) {
  return r.m.status == RutStatus::Uncertain && (r.m.conditions & kConditionWater) != 0;
}

TEST(WaterlineMemory, ACandidateAtTheLevelTheLastFrameConfirmedIsReadThrough) {
  const SyntheticRenderer renderer(parse_scene_line(kClearWaterOnMud));
  const StereoCalibration& cal = renderer.calibration();
  // Frame 4 confirms its waterline; frames 5 and 7, alone, only have a candidate at its level.
  for (const std::uint64_t i : {5U, 7U}) {
    StereoMeasurer alone(cal, MeasurerConfig{});
    const Measured r = measure(alone, renderer, i);
    ASSERT_TRUE(refused_uncertain_with_water(r))
        << "frame " << i << " alone: " << to_string(r.m.status) << " " << r.m.depth_mm << " mm, truth " << r.truth_mm
        << ": the scene no longer has a candidate waterline to test";
    EXPECT_GT(std::abs(r.m.depth_mm - r.truth_mm), 1.0) << "frame " << i << ": the dry reading";
  }
  {
    StereoMeasurer m(cal, MeasurerConfig{});
    const Measured confirmed = measure(m, renderer, 4);
    ASSERT_TRUE(read_through(confirmed)) << to_string(confirmed.m.status) << " " << confirmed.m.depth_mm << " mm";
    const Measured next = measure(m, renderer, 5);
    EXPECT_TRUE(read_through(next)) << to_string(next.m.status) << " " << next.m.depth_mm << " mm, truth "
                                    << next.truth_mm;
    EXPECT_LE(next.m.depth_uncertainty_mm, MeasurerConfig{}.rut.max_depth_uncertainty_mm);
    // Frame 5 recalled its waterline, it did not confirm it: frame 7 next is read both ways again.
    const Measured after_recall = measure(m, renderer, 7);
    EXPECT_TRUE(refused_uncertain_with_water(after_recall))
        << to_string(after_recall.m.status) << " " << after_recall.m.depth_mm << " mm";
  }
  {  // 0.6 s between the two captures: longer than memory_s (0.5 s).
    StereoMeasurer m(cal, MeasurerConfig{});
    ASSERT_TRUE(read_through(measure(m, renderer, 4)));
    const Measured late = measure(m, renderer, 5, 600'000'000);
    EXPECT_TRUE(refused_uncertain_with_water(late)) << to_string(late.m.status) << " " << late.m.depth_mm << " mm";
  }
  {  // The memory off.
    MeasurerConfig off;
    off.water.memory_s = 0.0;
    StereoMeasurer m(cal, off);
    ASSERT_TRUE(read_through(measure(m, renderer, 4)));
    const Measured next = measure(m, renderer, 5);
    EXPECT_TRUE(refused_uncertain_with_water(next)) << to_string(next.m.status) << " " << next.m.depth_mm << " mm";
  }
}

// The scene matrix's water-clear-snow-09, its eight frames in turn as the matrix measures them: frame 6
// confirms its waterline and is read through; frame 7 shows no steps, and without the memory its dry
// reading is published OK off the truth.
TEST(WaterlineMemory, AFrameWithoutStepsRightAfterAWaterlineIsReadBothWays) {
  const SyntheticRenderer renderer(parse_scene_line(
      "--texture snow --depth 43.4 --width 252 --bottom-width 87 --pile-left 10.1 --pile-right 10.5 --baseline 68 "
      "--height 428 --roll 0.1 --seed 1009 --water-level 19.4 --water-attenuation 0.0030 --water-colour 0.08"));
  const auto run = [&](double memory_s) {
    MeasurerConfig config;
    config.water.memory_s = memory_s;
    StereoMeasurer m(renderer.calibration(), config);
    std::vector<Measured> out;
    for (std::uint64_t i = 0; i < 8; ++i) out.push_back(measure(m, renderer, i));
    return out;
  };
  const std::vector<Measured> without = run(0.0);
  ASSERT_TRUE(read_through(without[6])) << to_string(without[6].m.status) << " " << without[6].m.depth_mm << " mm";
  ASSERT_EQ(without[7].m.status, RutStatus::Ok) << "the scene no longer tests the case";
  ASSERT_EQ(without[7].m.conditions & kConditionWater, 0U);
  ASSERT_GT(std::abs(without[7].m.depth_mm - without[7].truth_mm), 1.0)
      << "frame 7 is no longer read dry off the truth";
  const std::vector<Measured> with = run(MeasurerConfig{}.water.memory_s);
  EXPECT_TRUE(read_through(with[6]));
  EXPECT_TRUE(refused_uncertain_with_water(with[7]))
      << to_string(with[7].m.status) << " " << with[7].m.depth_mm << " mm";
}

}  // namespace
}  // namespace rutd
