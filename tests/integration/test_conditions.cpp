// Conditions that defeat stereo, end to end as a user meets them: `rutd synth` renders the condition
// (README, "Conditions rutd flags"), `rutd replay` measures it and writes the CAN frames, and
// canmatrix decodes them with config/rutd.dbc (tests/can/decode_candump.py). The renderer's truth is the
// soil's: no frame may be published OK with a depth more than 1 mm from it, and the condition must be
// flagged on the frames (the share each case states), in the RutConditions frame.
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "decoded_candump.hpp"
#include "synthetic/truth_csv.hpp"
#include "test_support.hpp"

namespace rutd {
namespace {

struct Case {
  const char* name;
  const char* synth;  // rutd synth options besides the folder and --frames
  int frames;
  const char* flag;         // RutConditions signal that must be raised
  double min_flagged;       // share of frames on which it must be
  bool flag_when_refused;   // ... and on every frame not published OK
  int min_ok = 0;           // frames that must be published OK (within 1 mm, as every OK frame)
  const char* replay = "";  // rutd replay options besides the folder and the outputs
};

std::ostream& operator<<(std::ostream& os, const Case& c) { return os << c.name; }

struct Outcome {
  int frames = 0, ok = 0, flagged = 0;
  double worst_ok_error = 0.0;
};

Outcome run_case(const Case& c) {
  Outcome out;
  const test::TempDir tmp;
  const std::string rec = (tmp.path() / "rec").string();
  const auto log = tmp.path() / "can.log";
  EXPECT_EQ(test::run_rutd("synth " + rec + " --frames " + std::to_string(c.frames) + " " + c.synth), 0);
  EXPECT_EQ(test::run_rutd("replay " + rec + " --out " + (tmp.path() / "m.csv").string() + " --candump " +
                           log.string() + " " + c.replay),
            0);
  bool decoded_ok = false;
  const auto all = test::decode_candump(log, decoded_ok);
  EXPECT_TRUE(decoded_ok) << "decoder reported CRC, counter or format errors";
  const auto m1 = test::frames_of(all, "RutMeasurement1");
  const auto cond = test::frames_of(all, "RutConditions");
  const auto truth = read_truth_csv(rec + "/truth.csv");
  EXPECT_EQ(m1.size(), truth.size());
  EXPECT_EQ(cond.size(), truth.size());
  const std::size_t n = std::min({m1.size(), cond.size(), truth.size()});
  for (std::size_t i = 0; i < n; ++i) {
    ++out.frames;
    const bool ok = m1[i].phys.at("RutM1_Status") == 0;
    const bool flagged = cond[i].phys.at(c.flag) == 1;
    out.flagged += flagged;
    std::printf("%-26s frame %zu  status %-18s  depth %6.1f  truth %6.2f  flags %s%s%s%s%s%s%s%s  u %.2f  vd %.2f\n",
                c.name, i, m1[i].named.at("RutM1_Status").c_str(), m1[i].phys.at("RutDepth"), truth[i].depth_mm,
                cond[i].phys.at("Water") == 1 ? "W" : "-", cond[i].phys.at("LeftLensObstructed") == 1 ? "L" : "-",
                cond[i].phys.at("RightLensObstructed") == 1 ? "R" : "-", cond[i].phys.at("LowLight") == 1 ? "D" : "-",
                cond[i].phys.at("Overexposed") == 1 ? "O" : "-", cond[i].phys.at("Vegetation") == 1 ? "V" : "-",
                cond[i].phys.at("CalibrationDrift") == 1 ? "C" : "-",
                cond[i].phys.at("DepthUncertain") == 1 ? "U" : "-", cond[i].phys.at("DepthUncertainty"),
                cond[i].phys.at("VerticalDisparity"));
    if (ok) {
      ++out.ok;
      const double err = std::abs(m1[i].phys.at("RutDepth") - truth[i].depth_mm);
      out.worst_ok_error = std::max(out.worst_ok_error, err);
      EXPECT_LE(err, 1.0 + 0.05) << c.name << " frame " << i << ": published OK, depth off the soil";
    } else if (c.flag_when_refused) {
      EXPECT_TRUE(flagged) << c.name << " frame " << i << ": refused without " << c.flag;
    }
  }
  return out;
}

class Conditions : public ::testing::TestWithParam<Case> {};

TEST_P(Conditions, NeverOkOffTheSoilAndFlagged) {
  if (!test::have_canmatrix()) RUTD_SKIP_NEEDS_INSTALLED("needs /usr/bin/python3 with canmatrix (python3-canmatrix)");
  const Case& c = GetParam();
  const Outcome o = run_case(c);
  ASSERT_EQ(o.frames, c.frames);
  const double share = double(o.flagged) / o.frames;
  std::printf("TABLE %-26s frames %d  OK %d  worst OK error %.2f mm  %s on %d/%d\n", c.name, o.frames, o.ok,
              o.worst_ok_error, c.flag, o.flagged, o.frames);
  EXPECT_GE(share, c.min_flagged) << c.flag << " raised on " << o.flagged << " of " << o.frames << " frames";
  EXPECT_GE(o.ok, c.min_ok) << "published OK on " << o.ok << " of " << o.frames << " frames";
}

// Water 5-25 mm deep in 30-60 mm ruts, sand and snow, level, roll, rig and seed varied.
const Case kCases[] = {
    {"water_d30_l5_sand", "--depth 30 --water-level 5 --texture sand --seed 31", 8, "Water", 0.9, false},
    {"water_d40_l12_snow_r3", "--depth 40 --water-level 12 --texture snow --roll 3 --seed 32", 8, "Water", 0.9, false},
    {"water_d50_l15_sand_b80", "--depth 50 --water-level 15 --texture sand --baseline 80 --height 300 --seed 33", 8,
     "Water", 0.9, false},
    {"water_d60_l25_snow", "--depth 60 --water-level 25 --texture snow --seed 34", 8, "Water", 0.9, false},
    {"water_d45_l20_sand_r3",
     "--depth 45 --water-level 20 --texture sand --roll 3 --baseline 40 --height 400 --seed 35", 8, "Water", 0.9,
     false},
    {"water_d35_l8_snow_b80", "--depth 35 --water-level 8 --texture snow --baseline 80 --height 300 --seed 36", 8,
     "Water", 0.9, false},
    // ... and in mud off the rig's centre, a narrow snow rut, a dim sand scene (a shore's edge that bends
    // up, a pool filling most of the bottom, less texture everywhere).
    {"water_d50_l20_mud_off30", "--depth 50 --water-level 20 --texture mud --offset 30 --seed 109", 6, "Water", 0.9,
     false},
    {"water_d50_l10_snow_w140", "--depth 50 --water-level 10 --texture snow --width 140 --bottom-width 50 --seed 104",
     6, "Water", 0.9, false},
    {"water_d45_l15_sand_dim", "--depth 45 --water-level 15 --exposure 0.4 --seed 105", 6, "Water", 0.9, false},
    // Litter floating on 21 mm of water in a 51 mm sand rut: a flat lid whose edge is lit unlike one
    // wall only (no pair of waterline steps), read as the bottom 21 mm too shallow before it was refused.
    {"litter_lid_d51_l21_sand",
     "--texture sand --depth 50.8 --width 191 --bottom-width 90 --pile-left 6.0 --pile-right 13.0 --baseline 40 "
     "--height 322 --roll -1.8 --seed 1004 --water-level 21.3 --debris 0.75 --debris-kind litter "
     "--water-attenuation 0.012",
     4, "Water", 0.75, true},
    // Litter on 30 mm of water in a 51 mm snow rut, darker than the snow, its edges no darker than the
    // walls' shade beside them on either side: a level span unlike the flat ground outside the rut with
    // no waterline above it (two of four frames were published OK 29.8 mm shallow).
    {"litter_lid_d51_l30_snow",
     "--texture snow --depth 51.1 --width 152 --bottom-width 70 --pile-left 9.0 --pile-right 0.9 --baseline 91 "
     "--height 289 --roll -2.4 --seed 1020 --water-level 29.8 --debris 0.80 --debris-kind litter "
     "--water-attenuation 0.026",
     4, "Water", 1.0, true},
    // Litter floating on 24 mm of water in a 59 mm sand rut, brighter than the wet walls: a pair of
    // steps at one height that brightens below it, a lid's, not water's, which darkens what is seen
    // through it. Stereo leaked through a gap in the lid to 43 mm; read through the surface as clear
    // water, one frame of four was published OK 13.3 mm shallow.
    {"litter_lid_brightening_sand",
     "--texture sand --depth 59.3 --width 244 --bottom-width 133 --pile-left 4.2 --pile-right 13.6 --baseline 85 "
     "--height 390 --roll -0.1 --seed 1036 --water-level 23.8 --debris 0.74 --debris-kind litter "
     "--water-attenuation 0.010",
     4, "Water", 1.0, true},
    // Foam floating on 5 mm of clear water in a 43 mm snow rut, lit like the snow (no brightness step
    // on either wall, none against the ground) but far more textured than it: the span's texture, which
    // the light scales away, is 3-5 times the walls' and the ground's. All four frames were published OK
    // 5.1 mm shallow, the lid measured as the bottom.
    {"foam_lid_textured_snow",
     "--texture snow --depth 42.9 --width 175 --bottom-width 55 --pile-left 1.4 --pile-right 14.4 --baseline 74 "
     "--height 357 --roll 2.2 --seed 1002 --water-level 5.1 --debris 0.92 --debris-kind foam "
     "--water-attenuation 0.025",
     4, "Water", 1.0, true},
    // Foam on 18 mm of turbid water in a 42 mm sand rut, brighter than both walls and than the flat
    // ground, each by 0.7 times what a single step must reach (under the 1.5 times one step needs, no
    // waterline pair): a bottom brighter all round than any soil there is lit. One frame of four was
    // published OK 17.9 mm shallow.
    {"foam_lid_brighter_all_round_sand",
     "--texture sand --depth 42.3 --width 206 --bottom-width 101 --pile-left 10.0 --pile-right 14.8 --baseline 85 "
     "--height 405 --roll -2.6 --seed 1018 --water-level 17.9 --debris 0.80 --debris-kind foam "
     "--water-attenuation 0.379",
     4, "Water", 1.0, true},
    // Foam covering two thirds of 13 mm of clear water in a 47 mm grass rut: the waterline found on both
    // walls, the profile below it following the foam over 83-100 % of the span, the bottom glimpsed
    // through gaps 0.4-2.4 mm deeper; read through the surface as clear water, two frames of four were
    // published OK 9.7-10.3 mm shallow.
    {"foam_lid_gaps_clear_grass",
     "--texture grass --depth 46.5 --width 164 --bottom-width 75 --pile-left 6.3 --pile-right 8.0 --baseline 93 "
     "--height 405 --roll 3.1 --seed 1309 --water-level 13.5 --debris 0.65 --debris-kind foam "
     "--water-attenuation 0.007",
     4, "Water", 1.0, true},
    // Leaves floating on 26 mm of turbid water in a 64 mm grass rut: each strip (the measured one and its
    // two guards) found the leaves at the water's level once, none twice running, and frame 6 was
    // published OK 25.2 mm shallow, every strip's deepest point on the leaves; two strips' findings at
    // one level now confirm the lid as two frames running do.
    {"leaves_turbid_grass",
     "--texture grass --depth 64.5 --width 212 --bottom-width 75 --pile-left 8.2 --pile-right 12.3 --baseline 48 "
     "--height 427 --roll -4.0 --seed 1035 --water-level 26.3 --debris 0.45 --debris-kind leaves "
     "--water-attenuation 0.566",
     8, "Water", 1.0, true},
    // A clean 18 mm mud rut whose interior fell on the dark blotches of a mud textured at a larger scale
    // than the rut: a pair of weak darkening steps 5 mm below the ground, the whole span between them
    // darker than the walls above by a waterline's threshold, but no darker than the flat ground beside
    // the rut on one side. Read through as clear water, frame 5 was published OK 4.6 mm deep of the
    // truth; under water the span would be darker than the dry ground on both sides.
    {"clean_mud_dark_rut",
     "--texture mud --depth 18.2 --width 151 --bottom-width 66 --pile-left 10.6 --pile-right 4.3 --offset "
     "21 --baseline 100 --height 428 --hfov 60 --roll -2.4 --pitch 6.4 --noise 1.82 --speed 1443 "
     "--right-response 1.035 --seed 2001 --exposure 2.50",
     6, "Water", 0.0, false, 4},
    // Litter floating on 23 mm of turbid water in a 53 mm grass rut, 85 % covered, like the grass in
    // light and texture: where the measured strip falls on litter only, the lid is a level span lit like
    // the soil, and one frame of four was published OK 23.0 mm shallow. A guard strip a quarter of the
    // image away (StripConfig::guards) falls on the water between the litter and refuses it.
    {"litter_lid_strip_misses_grass",
     "--texture grass --depth 52.5 --width 248 --bottom-width 77 --pile-left 0.0 --pile-right 8.3 --baseline 97 "
     "--height 440 --roll -3.8 --seed 1323 --water-level 23.0 --debris 0.85 --debris-kind litter "
     "--water-attenuation 0.193",
     4, "Water", 1.0, true, 0, "--guard-strips 2"},
    // Clear water whose wet walls darken less, against a blotchy mud's or grass's own texture, than a
    // waterline asks (2-3.8 times the ground's spread, against 4), the whole span below them darker by 4
    // times it and more: read through as a waterline, published with Water within 1 mm (were published
    // OK 1.5-2.8 mm shallow, the bottom read as if dry; then refused, read both ways).
    {"clear_faint_waterline_mud",
     "--texture mud --depth 40.8 --width 160 --bottom-width 49 --pile-left 12.7 --pile-right 6.5 --baseline 90 "
     "--height 374 --roll 0.1 --seed 1033 --water-level 11.5 --water-attenuation 0.0026 --water-colour 0.10",
     4, "Water", 1.0, true, 3},
    {"clear_faint_waterline_grass",
     "--texture grass --depth 22.0 --width 157 --bottom-width 68 --pile-left 10.4 --pile-right 7.4 --baseline 47 "
     "--height 313 --roll 2.5 --seed 1017 --water-level 6.9 --water-attenuation 0.0058 --water-colour 0.10",
     4, "Water", 1.0, true, 3},
    // Opaque splash on one lens, 10-50 % of the strip, and a fully covered lens: flagged on every frame,
    // published or not (the splash is there whatever the depth).
    {"splash10_left_sand", "--depth 50 --splash 0.1 --splash-camera left --splash-centre 0.45 --seed 41", 6,
     "LeftLensObstructed", 1.0, true},
    {"splash25_right_snow",
     "--depth 40 --texture snow --splash 0.25 --splash-camera right --splash-centre 0.6 --seed 42", 6,
     "RightLensObstructed", 1.0, true},
    {"splash50_left_snow", "--depth 60 --texture snow --splash 0.5 --splash-camera left --splash-centre 0.5 --seed 43",
     6, "LeftLensObstructed", 1.0, true},
    {"splash35_right_sand_r3", "--depth 30 --roll 3 --splash 0.35 --splash-camera right --splash-centre 0.3 --seed 44",
     6, "RightLensObstructed", 1.0, true},
    {"covered_left_sand", "--depth 50 --splash 1 --splash-camera left --seed 45", 4, "LeftLensObstructed", 1.0, true},
    {"covered_right_snow", "--depth 40 --texture snow --splash 1 --splash-camera right --seed 46", 4,
     "RightLensObstructed", 1.0, true},
    // Exposure.
    {"dark_sand", "--depth 50 --exposure 0.05 --seed 51", 4, "LowLight", 1.0, true},
    {"dark_snow", "--depth 40 --texture snow --exposure 0.04 --seed 52", 4, "LowLight", 1.0, true},
    // Night under auto exposure and gain: the median grey level held at the target, the texture under
    // the noise of gain 16 (judged from the raw images' noise, not the median).
    {"night_auto_sand", "--depth 50 --auto-exposure --light 0.015 --seed 55", 4, "LowLight", 1.0, true},
    {"night_auto_grass", "--depth 40 --texture grass --auto-exposure --light 0.02 --seed 56", 4, "LowLight", 1.0, true},
    {"overexposed_sand", "--depth 50 --exposure 4 --seed 53", 4, "Overexposed", 1.0, true},
    // Clipped patches only (exposure 2.5 and 3 on sand and grass: more of the strip at full scale than the
    // flag's 15 %, the rest textured): the clipped texture goes unmatched and the coverage term counts
    // what it hides, so the depth is published OK, flagged, within 1 mm (measured: 0.10 mm at most;
    // refused BAD_EXPOSURE before).
    {"clipped_sand", "--depth 45 --texture sand --exposure 2.5 --seed 77", 4, "Overexposed", 1.0, true, 3},
    {"clipped_grass", "--depth 45 --texture grass --exposure 3 --seed 78", 4, "Overexposed", 1.0, true, 3},
    {"overexposed_snow", "--depth 30 --texture snow --exposure 2.5 --seed 54", 4, "Overexposed", 1.0, true},
    // Grass blades outside the rut.
    {"grass40_sand", "--depth 50 --grass-height 40 --seed 61", 4, "Vegetation", 0.75, false},
    {"grass25_mud", "--depth 40 --texture mud --grass-height 25 --grass-spacing 5 --seed 62", 4, "Vegetation", 0.75,
     false},
    // The right camera turned against the written calibration.
    {"pitch1_sand", "--depth 50 --right-pitch-error 1 --seed 71", 4, "CalibrationDrift", 1.0, true},
    {"pitch-0.4_snow", "--depth 40 --texture snow --right-pitch-error -0.4 --seed 72", 4, "CalibrationDrift", 1.0,
     true},
    {"roll2_sand", "--depth 45 --right-roll-error 2 --right-pitch-error 0.3 --seed 73", 4, "CalibrationDrift", 1.0,
     true},
};

// Free-running cameras at speed: the right camera exposes a few milliseconds after (or before) the left,
// the ground moves 10-40 mm between the two, and the views disagree as a drifted calibration's would. The
// recording keeps each pair's skew (frames.csv skew_ns) and replay refuses the pairs as UNSYNCHRONISED,
// decoded by canmatrix from the DBC's value table, never as CALIBRATION_DRIFT and with no CalibrationDrift
// or lens bit; with the cameras synchronised the same scene is measured within 1 mm.
TEST(FreeRunningCameras, SkewedPairsAreUnsynchronisedNotCalibrationDrift) {
  if (!test::have_canmatrix()) RUTD_SKIP_NEEDS_INSTALLED("needs /usr/bin/python3 with canmatrix (python3-canmatrix)");
  int checked = 0;
  for (const char* delay : {"4", "-3", "0"}) {
    SCOPED_TRACE(delay);
    const test::TempDir tmp;
    const std::string rec = (tmp.path() / "rec").string();
    const auto log = tmp.path() / "can.log";
    ASSERT_EQ(
        test::run_rutd("synth " + rec + " --frames 3 --depth 45 --speed 5000 --seed 81 --right-delay-ms " + delay), 0);
    ASSERT_EQ(
        test::run_rutd("replay " + rec + " --out " + (tmp.path() / "m.csv").string() + " --candump " + log.string()),
        0);
    bool decoded_ok = false;
    const auto all = test::decode_candump(log, decoded_ok);
    ASSERT_TRUE(decoded_ok);
    const auto m1 = test::frames_of(all, "RutMeasurement1");
    const auto cond = test::frames_of(all, "RutConditions");
    const auto truth = read_truth_csv(rec + "/truth.csv");
    ASSERT_EQ(m1.size(), 3u);
    ASSERT_EQ(cond.size(), 3u);
    for (std::size_t i = 0; i < m1.size(); ++i, ++checked) {
      const std::string status = m1[i].named.at("RutM1_Status");
      for (const char* bit : {"CalibrationDrift", "LeftLensObstructed", "RightLensObstructed"})
        EXPECT_EQ(cond[i].phys.at(bit), 0) << bit << " frame " << i;
      if (std::string(delay) == "0") {
        EXPECT_EQ(status, "OK") << "frame " << i;
        EXPECT_NEAR(m1[i].phys.at("RutDepth"), truth[i].depth_mm, 1.0) << "frame " << i;
      } else {
        EXPECT_EQ(status, "UNSYNCHRONISED") << "frame " << i;
      }
    }
  }
  EXPECT_EQ(checked, 9);
}

// The run's summary names the rule that flagged each pair Water: turbid water (the scene matrix's
// water-turbid-sand-00, opaque at 92 % attenuation) hides the bottom below a waterline on both walls on
// every pair; a dry rut has no pair flagged.
TEST(ReplaySummary, NamesTheRuleThatFlaggedEachPairWater) {
  const test::TempDir tmp;
  const std::string turbid = (tmp.path() / "turbid").string(), dry = (tmp.path() / "dry").string();
  ASSERT_EQ(test::run_rutd("synth " + turbid +
                           " --frames 4 --texture sand --depth 48.5 --width 171 --bottom-width 81 --pile-left 3.0 "
                           "--pile-right 8.7 --baseline 71 --height 299 --roll -4.1 --seed 1000 --water-level 14.6 "
                           "--water-attenuation 0.92 --water-colour 0.13 --silt 0.07"),
            0);
  ASSERT_EQ(test::run_rutd("synth " + dry + " --frames 2 --texture sand --depth 48.5 --seed 1000"), 0);
  const auto err = tmp.path() / "err.txt";
  ASSERT_EQ(test::run_rutd("replay " + turbid + " --out " + (tmp.path() / "t.csv").string(), err.string()), 0);
  const std::string turbid_log = test::read_text(err);
  EXPECT_NE(turbid_log.find("BOTTOM_NOT_SEEN 4; flagged Water by waterline_hides 4;"), std::string::npos) << turbid_log;
  ASSERT_EQ(test::run_rutd("replay " + dry + " --out " + (tmp.path() / "d.csv").string(), err.string()), 0);
  EXPECT_EQ(test::read_text(err).find("flagged Water"), std::string::npos) << test::read_text(err);
  EXPECT_EQ(test::read_text(err).find("read dry"), std::string::npos) << test::read_text(err);
}

// The scene matrix's clean-gain-mud-21, whose frame 2 a waterline's rule takes for water: the steady dry
// frames before overrule it (test_dry_memory.cpp), and the summary says so.
TEST(ReplaySummary, CountsTheFindingsTheDryFramesBeforeOverruled) {
  const test::TempDir tmp;
  const std::string mud = (tmp.path() / "mud").string();
  ASSERT_EQ(test::run_rutd("synth " + mud +
                           " --frames 3 --texture mud --depth 60.8 --width 299 --bottom-width 179 --pile-left 7.1 "
                           "--pile-right 17.7 --offset 6 --baseline 84 --height 463 --hfov 75 --roll 2.9 --pitch -1.2 "
                           "--noise 1.19 --speed 2122 --right-response 1.024 --seed 2021 --exposure 1.007 --gain 2.46"),
            0);
  const auto err = tmp.path() / "err.txt";
  ASSERT_EQ(test::run_rutd("replay " + mud + " --out " + (tmp.path() / "m.csv").string(), err.string()), 0);
  const std::string log = test::read_text(err);
  EXPECT_NE(log.find("3 pairs, 0 failures (OK 3; read dry as the steady frames before, overruling waterline_hides 1"),
            std::string::npos)
      << log;
}

INSTANTIATE_TEST_SUITE_P(Scenes, Conditions, ::testing::ValuesIn(kCases), [](const auto& info) {
  std::string name = info.param.name;
  for (char& ch : name) {
    if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
  }
  return name;
});

}  // namespace
}  // namespace rutd
