// Passes over the same ground (trafficability/passes.hpp) on constructed drives with a known geometry:
// a second drive 0.4 m beside the first with GPS noise matches it segment for segment on the stretch in
// common and nowhere after it turns away; the sinkage increase equals the depths' difference; opposite
// headings, errors smaller than the offset and stretches in common shorter than min_common_m do not match.
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "trafficability/passes.hpp"

namespace rutd {
namespace {

constexpr double kLat0 = -25.7545, kLon0 = 28.2314, kR = 6378137.0;

GeoFix fix_at(double north_m, double east_m, double heading_deg, double error_m) {
  GeoFix f;
  f.mode = GeoFix::Mode::Fix3d;
  f.latitude_deg = kLat0 + north_m / kR * 180.0 / M_PI;
  f.longitude_deg = kLon0 + east_m / (kR * std::cos(kLat0 * M_PI / 180.0)) * 180.0 / M_PI;
  f.heading_deg = heading_deg;
  f.horizontal_error_m = error_m;
  return f;
}

struct DriveSpec {
  double heading_deg = 60.0;
  int segments = 40;
  double north_m = 0.0, east_m = 0.0;  // offset of the whole drive
  double noise_m = 0.0;                // Gaussian, per position
  int turn_after = -1;                 // segment index after which it turns by turn_deg
  double turn_deg = 60.0;
  double error_m = 1.0;
  double depth_mm = 30.0;
  unsigned seed = 1;
};

// 1 m segments along the drive, each with the position at its middle.
std::vector<Segment> drive(const DriveSpec& s) {
  std::mt19937 rng(s.seed);
  std::normal_distribution<double> noise(0.0, s.noise_m > 0 ? s.noise_m : 1.0);
  std::vector<Segment> out;
  double n = s.north_m, e = s.east_m, heading = s.heading_deg;
  for (int i = 0; i < s.segments; ++i) {
    if (i == s.turn_after) heading += s.turn_deg;
    const double h = heading * M_PI / 180.0;
    const double mn = n + 0.5 * std::cos(h), me = e + 0.5 * std::sin(h);
    Segment seg;
    seg.index = static_cast<std::uint64_t>(i);
    seg.start_m = i;
    seg.end_m = i + 1;
    seg.mean_depth_mm = s.depth_mm;
    seg.depth_uncertainty_mm = 0.3;
    const double dn = s.noise_m > 0 ? noise(rng) : 0.0, de = s.noise_m > 0 ? noise(rng) : 0.0;
    seg.position = fix_at(mn + dn, me + de, heading, s.error_m);
    out.push_back(seg);
    n += std::cos(h);
    e += std::sin(h);
  }
  return out;
}

TEST(Passes, SecondDriveBesideTheFirstMatchesOnTheCommonStretchOnly) {
  DriveSpec first;
  const auto a = drive(first);
  DriveSpec second = first;
  second.north_m = 0.4;  // beside the first, within the reported 1 m
  second.noise_m = 0.2;
  second.turn_after = 25;  // then away from it
  second.depth_mm = 38.0;
  second.seed = 7;
  const auto b = drive(second);
  const auto matches = match_pass(a, b);
  std::vector<bool> matched(b.size(), false);
  for (const SegmentMatch& m : matches) {
    matched[m.later] = true;
    EXPECT_LE(m.distance_m, m.allowed_m);
    // The same ground: the earlier segment at the same distance along, give or take one.
    EXPECT_NEAR(static_cast<double>(m.earlier), static_cast<double>(m.later), 1.0) << m.later;
    EXPECT_NEAR(m.sinkage_increase_mm, 8.0, 1e-9);
    EXPECT_NEAR(m.sinkage_increase_uncertainty_mm, std::hypot(0.3, 0.3), 1e-12);
  }
  int common = 0;
  for (int i = 0; i < 25; ++i) common += matched[static_cast<std::size_t>(i)];
  EXPECT_GE(common, 24) << "the stretch in common is not matched";
  // After the turn the tracks part: 60 degrees apart, they are over 1.41 m apart within 2 m.
  for (std::size_t i = 25; i < b.size(); ++i) EXPECT_FALSE(matched[i]) << "segment " << i << " is off the track";
}

TEST(Passes, OppositeHeadingSmallErrorOrShortStretchDoNotMatch) {
  DriveSpec first;
  const auto a = drive(first);
  // The same ground driven the other way.
  DriveSpec back = first;
  back.heading_deg = first.heading_deg + 180.0;
  back.north_m = 40.0 * std::cos(first.heading_deg * M_PI / 180.0);
  back.east_m = 40.0 * std::sin(first.heading_deg * M_PI / 180.0);
  EXPECT_TRUE(match_pass(a, drive(back)).empty());
  // Beside it by more than the errors allow: 2 m off, errors 1 m each (1.41 m combined).
  DriveSpec far = first;
  far.north_m = 2.0;
  EXPECT_TRUE(match_pass(a, drive(far)).empty());
  // The same 2 m offset within errors of 2 m each (2.83 m combined): matched.
  DriveSpec far_but_uncertain = far;
  far_but_uncertain.error_m = 2.0;
  EXPECT_EQ(match_pass(a, drive(far_but_uncertain)).size(), a.size());
  // A drive that touches the first for 2 m only: 20 m beside it, then on it for two segments, then away.
  DriveSpec beside = first;
  beside.north_m = 20.0;
  beside.segments = 10;
  std::vector<Segment> touching = drive(beside);
  touching.insert(touching.begin() + 5, a.begin() + 10, a.begin() + 12);
  for (std::size_t i = 0; i < touching.size(); ++i) {
    touching[i].start_m = static_cast<double>(i);
    touching[i].end_m = static_cast<double>(i + 1);
  }
  EXPECT_TRUE(match_pass(a, touching).empty()) << "2 m in common is below min_common_m (3 m)";
  PassConfig lenient;
  lenient.min_common_m = 2.0;
  EXPECT_EQ(match_pass(a, touching, lenient).size(), 2u);
}

TEST(Passes, PassesAreNumberedOverThreeDrives) {
  DriveSpec first;
  DriveSpec second = first;
  second.north_m = 0.3;
  second.noise_m = 0.2;
  second.seed = 3;
  second.depth_mm = 36.0;
  second.segments = 20;  // covers the first half only
  DriveSpec third = first;
  third.north_m = -0.3;
  third.noise_m = 0.2;
  third.seed = 5;
  third.depth_mm = 40.0;
  std::vector<std::vector<Segment>> drives{drive(first), drive(second), drive(third)};
  const PassNumbering n = number_passes(drives);
  for (const Segment& s : drives[0]) EXPECT_EQ(s.pass, 0u);
  for (const Segment& s : drives[1]) EXPECT_EQ(s.pass, 1u);
  int third_pass = 0, second_pass = 0;
  for (std::size_t i = 0; i < drives[2].size(); ++i) {
    const std::uint32_t p = drives[2][i].pass;
    EXPECT_TRUE(p == 1 || p == 2) << i;
    third_pass += p == 2;
    second_pass += p == 1;
  }
  EXPECT_GE(third_pass, 18);   // the first half: driven three times
  EXPECT_GE(second_pass, 18);  // the second half: twice
  // The increase is against the latest drive over that ground: 4 mm over the second, 10 mm over the first.
  for (std::size_t k = 0; k < n.matches[2].size(); ++k) {
    const double expected = n.covering[2][k] == 1 ? 4.0 : 10.0;
    EXPECT_NEAR(n.matches[2][k].sinkage_increase_mm, expected, 1e-9);
  }
}

}  // namespace
}  // namespace rutd
