// trafficability/: the odometer, segments, rut damage, soil strength and the advisory, against hand-derived
// values and against an independent reference in Python (tests/unit/trafficability_reference.py, written
// from the definitions in the headers) on randomised drives with stops, reversing, speed loss and
// refused frames.
#include <cmath>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "core/input_error.hpp"
#include "recording/segment_csv_sink.hpp"
#include "test_support.hpp"
#include "trafficability/odometer.hpp"
#include "trafficability/segment_tracker.hpp"

namespace rutd {
namespace {

constexpr std::int64_t kMs = 1'000'000;

SpeedSample ok_speed(std::int64_t t_ms, double mm_s) { return {t_ms * kMs, SpeedState::Ok, mm_s}; }

RutMeasurement ok_depth(double depth, double u = 1.0) {
  RutMeasurement m;
  m.status = RutStatus::Ok;
  m.depth_mm = depth;
  m.width_mm = 300;
  m.area_mm2 = depth * 200;
  m.depth_uncertainty_mm = u;
  return m;
}

TEST(Odometer, IntegratesAConstantSpeedAndHoldsAtRestAndWhileReversing) {
  Odometer o;
  EXPECT_EQ(o.motion_at(0).state, SpeedState::NoSource);
  EXPECT_TRUE(std::isnan(o.motion_at(0).distance_m));
  for (int i = 0; i <= 10; ++i) o.add(ok_speed(i * 100, 2000));  // 2 m/s for 1 s
  EXPECT_NEAR(o.motion_at(1000 * kMs).distance_m, 2.0, 1e-12);
  EXPECT_NEAR(o.motion_at(1050 * kMs).distance_m, 2.0, 1e-12);  // not extrapolated past the last sample
  // Ramp down to 0 over 0.2 s (trapezoid: 0.15 + 0.05 m), stand for 1 s: no new distance.
  o.add(ok_speed(1100, 1000));
  o.add(ok_speed(1200, 0));
  for (int i = 3; i <= 12; ++i) o.add(ok_speed(1000 + i * 100, 0));
  EXPECT_NEAR(o.motion_at(2200 * kMs).distance_m, 2.2, 1e-12);
  // Reverse 1 m (−1 m/s for 1 s, plus the two ramps of 0.05 m each), then forward again: the distance
  // holds until the vehicle is past its furthest point.
  o.add(ok_speed(2300, -1000));
  for (int i = 1; i <= 10; ++i) o.add(ok_speed(2300 + i * 100, -1000));
  o.add(ok_speed(3400, 0));
  EXPECT_NEAR(o.motion_at(3400 * kMs).distance_m, 2.2, 1e-12);
  EXPECT_NEAR(o.stats().reversed_m, 1.1, 1e-12);
  for (int i = 1; i <= 20; ++i) o.add(ok_speed(3400 + i * 100, 1000));  // +0.05 + 1.9 m
  EXPECT_NEAR(o.motion_at(5400 * kMs).distance_m, 2.2 - 1.1 + 1.95, 1e-9);
  EXPECT_DOUBLE_EQ(o.motion_at(5400 * kMs).speed_mm_s, 1000);
}

TEST(Odometer, StaleOrInvalidSpeedGivesNoDistanceAndIsNotIntegratedAcross) {
  Odometer o({.max_age_ns = 300 * kMs});
  o.add(ok_speed(0, 1000));
  o.add(ok_speed(100, 1000));
  EXPECT_EQ(o.motion_at(400 * kMs).state, SpeedState::Ok);
  const VehicleMotion stale = o.motion_at(401 * kMs);
  EXPECT_EQ(stale.state, SpeedState::Stale);
  EXPECT_TRUE(std::isnan(stale.distance_m));
  EXPECT_EQ(stale.speed_mm_s, 0.0);
  // Speed again after 2 s of silence: the 2 m driven meanwhile are not guessed.
  o.add(ok_speed(2100, 1000));
  EXPECT_NEAR(o.motion_at(2100 * kMs).distance_m, 0.1, 1e-12);
  EXPECT_EQ(o.stats().gaps, 1u);
  o.add({2200 * kMs, SpeedState::NotAvailable, 0});
  EXPECT_EQ(o.motion_at(2200 * kMs).state, SpeedState::NotAvailable);
  o.add({2300 * kMs, SpeedState::Error, 0});
  EXPECT_EQ(o.motion_at(2300 * kMs).state, SpeedState::Error);
  o.add(ok_speed(2400, 1000));
  o.add(ok_speed(2500, 1000));
  EXPECT_NEAR(o.motion_at(2500 * kMs).distance_m, 0.2, 1e-12);  // only 2400..2500 integrated
  o.add(ok_speed(2450, 5000));                                  // out of order: ignored
  EXPECT_EQ(o.stats().out_of_order, 1u);
  EXPECT_EQ(o.stats().gaps, 2u);
}

TEST(SoilStrength, InterpolatesAndCarriesTheUncertaintyBySlope) {
  const std::vector<SoilStrengthPoint> t{{0, 900}, {50, 500}, {150, 200}};
  const SoilStrength a = soil_strength_at(t, 25, 2);
  EXPECT_DOUBLE_EQ(a.value, 700);
  EXPECT_DOUBLE_EQ(a.uncertainty, 16);  // 8 kPa/mm * 2 mm
  const SoilStrength b = soil_strength_at(t, 100, 3);
  EXPECT_DOUBLE_EQ(b.value, 350);
  EXPECT_DOUBLE_EQ(b.uncertainty, 9);  // 3 kPa/mm * 3 mm
  const SoilStrength c = soil_strength_at(t, 200, 1);
  EXPECT_DOUBLE_EQ(c.value, 200);
  EXPECT_TRUE(c.clamped);
  SoilStrengthConfig bad;
  bad.table = {{0, 100}, {10, 200}};
  bad.source = "x";
  EXPECT_NE(check_soil_strength_config(bad, "t.soil").find("t.soil.table[1]"), std::string::npos);
}

// Hand-derived: 1 m segments at 1 m/s, 10 frames a metre. Depths 50 (GO), 120 (CAUTION) for one metre,
// then 50 again: the advisory stays CAUTION for the 3 m of hysteresis; a refused metre is UNKNOWN.
// A drive due north at 1 m/s, 30 measurements a second, each with the fix in force at its capture (5 fixes
// a second, so up to 0.2 m old): every segment is located within that of its own middle, whenever it
// closes; the segments driven without a fix (metres 3 and 4: the receiver lost it) have none, and the
// segment CSV writes the position (9 decimals) or leaves its columns empty.
TEST(SegmentTracker, EachSegmentIsLocatedAtItsMiddle) {
  constexpr double kLat0 = 61.5, kMetresPerDegree = 111'320.0, kSpeed = 1.0;
  SegmentTracker tracker(SegmentConfig{});
  std::vector<Segment> out;
  GeoFix fix;
  for (int i = 0; i < 240; ++i) {  // 8 s, 8 m
    const std::int64_t t = i * 1000 * kMs / 30;
    if (t % (200 * kMs) < 1000 * kMs / 30) {  // a new fix every 0.2 s, where the vehicle is then
      const double at_m = kSpeed * static_cast<double>(t) * 1e-9;
      fix = GeoFix{};
      fix.t_ns = t;
      fix.mode = at_m >= 3 && at_m < 5 ? GeoFix::Mode::NoFix : GeoFix::Mode::Fix3d;
      fix.latitude_deg = kLat0 + at_m / kMetresPerDegree;
      fix.longitude_deg = 24.0;
      fix.horizontal_error_m = 1.5;
      fix.heading_deg = 0.0;
    }
    const VehicleMotion v{SpeedState::Ok, kSpeed * 1000, kSpeed * static_cast<double>(t) * 1e-9 + 0.001};
    for (std::size_t n = tracker.add(t, ok_depth(40), v, fix), k = 0; k < n; ++k) out.push_back(tracker.closed(k));
  }
  for (std::size_t n = tracker.finish(), k = 0; k < n; ++k) out.push_back(tracker.closed(k));
  ASSERT_EQ(out.size(), 8u);
  int located = 0;
  for (const Segment& s : out) {
    const std::string at = "segment " + std::to_string(s.index);
    if (s.index == 3 || s.index == 4) {
      EXPECT_FALSE(s.position.valid()) << at;
      EXPECT_NE(format_segment_row(s).find(",GO,,,,"), std::string::npos) << format_segment_row(s);
      continue;
    }
    ASSERT_TRUE(s.position.valid()) << at;
    const double middle = (s.start_m + s.end_m) / 2, where = (s.position.latitude_deg - kLat0) * kMetresPerDegree;
    EXPECT_LE(where, middle + 0.04) << at;        // a fix taken before the measurement nearest the middle
    EXPECT_GE(where, middle - 0.2 - 0.04) << at;  // and at most one fix period before it
    EXPECT_NE(format_segment_row(s).find(fmt::format(",GO,{:.9f},24.000000000,1.50,0.0", s.position.latitude_deg)),
              std::string::npos)
        << format_segment_row(s);
    ++located;
  }
  EXPECT_EQ(located, 6);
}

// The segment CSV read back (`rutd map` reads it): every field as written, to the file's decimals; a
// segment without a fix has none; bad rows are refused naming the file, the line and the column.
TEST(SegmentCsv, ReadsBackWhatTheSinkWroteAndNamesTheBadField) {
  const test::TempDir tmp;
  const std::string path = (tmp.path() / "segments.csv").string();
  Segment located;
  located.index = 7;
  located.start_m = 7;
  located.end_m = 8;
  located.t_start_ns = 1'000'000'123;
  located.t_end_ns = 1'400'000'456;
  located.frames = 12;
  located.refused = 2;
  located.mean_depth_mm = 41.234;
  located.max_depth_mm = 44.5;
  located.p95_depth_mm = 44.1;
  located.depth_uncertainty_mm = 0.31;
  located.worst_status = RutStatus::Uncertain;
  located.advisory = Advisory::Caution;
  located.soil_strength = 512.34;
  located.position.mode = GeoFix::Mode::Fix3d;
  located.position.latitude_deg = 61.123456789;
  located.position.longitude_deg = -24.5;
  located.position.horizontal_error_m = 1.25;
  located.position.heading_deg = 359.9;
  Segment bare;  // no measurement, no fix
  bare.index = 8;
  bare.start_m = 8;
  bare.end_m = 9;
  {
    SegmentCsvSink sink(path, "test");
    sink.publish_segment(located);
    sink.publish_segment(bare);
  }
  const std::vector<Segment> back = read_segment_csv(path);
  ASSERT_EQ(back.size(), 2u);
  const Segment& a = back[0];
  EXPECT_EQ(a.index, 7u);
  EXPECT_EQ(a.t_start_ns, located.t_start_ns);
  EXPECT_EQ(a.t_end_ns, located.t_end_ns);
  EXPECT_EQ(a.frames, 12u);
  EXPECT_EQ(a.refused, 2u);
  EXPECT_NEAR(a.mean_depth_mm, 41.23, 1e-9);
  EXPECT_NEAR(a.soil_strength, 512.3, 1e-9);
  EXPECT_EQ(a.worst_status, RutStatus::Uncertain);
  EXPECT_EQ(a.advisory, Advisory::Caution);
  EXPECT_TRUE(a.position.valid());
  EXPECT_EQ(a.position.latitude_deg, 61.123456789);
  EXPECT_EQ(a.position.longitude_deg, -24.5);
  EXPECT_EQ(a.position.heading_deg, 359.9);
  const Segment& b = back[1];
  EXPECT_FALSE(b.position.valid());
  EXPECT_TRUE(std::isnan(b.mean_depth_mm));
  EXPECT_EQ(b.worst_status, RutStatus::NoMeasurement);
  EXPECT_EQ(b.advisory, Advisory::Unknown);

  const std::string text = test::read_text(path);
  auto refused = [&](const std::string& from, const std::string& to) {
    std::string bad = text;
    bad.replace(bad.find(from), from.size(), to);
    std::ofstream(path) << bad;
    try {
      read_segment_csv(path);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_EQ(refused(",CAUTION,", ",MAYBE,"), path + ": line 2, advisory: unknown advisory 'MAYBE'");
  EXPECT_EQ(refused(",UNCERTAIN,", ",FINE,"), path + ": line 2, worst_status: unknown status 'FINE'");
  EXPECT_EQ(refused(",41.23,", ",4x,"), path + ": line 2, mean_depth_mm: not a number: '4x'");
  EXPECT_EQ(refused("8,8.000,9.000", "8,8.000"), path + ": line 3, row: 20 fields, expected 21");
  EXPECT_EQ(refused("index,", "nothing,"),
            path + ": line 1: not a segment CSV header; expected " + std::string(kSegmentCsvHeader));
}

TEST(SegmentTracker, AdvisoryRisesAtOnceFallsAfterTheHysteresisAndIsUnknownWhenUntrusted) {
  SegmentConfig c;
  c.advisory.caution_depth_mm = 80;
  c.advisory.no_go_depth_mm = 150;
  c.advisory.hysteresis_m = 3;
  SegmentTracker tracker(c);
  std::vector<Segment> out;
  for (int i = 0; i < 100; ++i) {
    const double d = 0.05 + 0.1 * i;  // metre 0..9
    const int metre = i / 10;
    RutMeasurement m = ok_depth(metre == 2 ? 120 : 50);
    if (metre == 7) m.status = RutStatus::LensObstructed;
    VehicleMotion v{SpeedState::Ok, 1000, d};
    for (std::size_t n = tracker.add(i * 100 * kMs, m, v), k = 0; k < n; ++k) out.push_back(tracker.closed(k));
  }
  for (std::size_t n = tracker.finish(), k = 0; k < n; ++k) out.push_back(tracker.closed(k));
  ASSERT_EQ(out.size(), 10u);
  const Advisory want[] = {Advisory::Go,      Advisory::Go, Advisory::Caution, Advisory::Caution, Advisory::Caution,
                           Advisory::Caution, Advisory::Go, Advisory::Unknown, Advisory::Caution, Advisory::Caution};
  for (int i = 0; i < 10; ++i) {
    EXPECT_EQ(out[i].advisory, want[i]) << "segment " << i << " reported " << to_string(out[i].advisory);
    EXPECT_EQ(out[i].frames, 10u);
  }
  EXPECT_EQ(out[7].refused, 10u);
  EXPECT_EQ(out[7].worst_status, RutStatus::LensObstructed);
  EXPECT_DOUBLE_EQ(out[2].mean_depth_mm, 120);
  // Speed lost inside metre 9 of another run: that segment is UNKNOWN, never GO.
  SegmentTracker t2(c);
  for (int i = 0; i < 20; ++i) t2.add(i * kMs, ok_depth(10), {SpeedState::Ok, 1000, 0.05 * i});
  t2.add(21 * kMs, ok_depth(10), {SpeedState::Stale, 0, std::numeric_limits<double>::quiet_NaN()});
  ASSERT_EQ(t2.finish(), 1u);
  EXPECT_EQ(t2.closed(0).advisory, Advisory::Unknown);
  EXPECT_EQ(t2.stats().no_motion, 1u);
}

TEST(RutDamage, CountsStretchesAtLeastTheMinimumLength) {
  // Frames every 0.25 m; depths > 100 mm on [1.0, 2.0) (4 frames: 1 m, counts) and on [3.0, 3.5)
  // (2 frames: 0.5 m, does not); a refused frame at 5.0 covers 0.25 m unmeasured.
  RutDamage damage({{"mineral", 100, 1.0, 1.0}});
  for (int i = 0; i <= 32; ++i) {
    const double d = 0.25 * i;
    RutMeasurement m = ok_depth((d >= 1.0 && d < 2.0) || (d >= 3.0 && d < 3.5) ? 130 : 40);
    if (i == 20) m.status = RutStatus::BottomNotSeen;
    damage.add(d, m);
  }
  const RutDamageFigures f = damage.figures(0);
  EXPECT_DOUBLE_EQ(f.rutted_m, 1.0);
  EXPECT_EQ(f.stretches, 1u);
  EXPECT_DOUBLE_EQ(f.unmeasured_m, 0.25);
  EXPECT_DOUBLE_EQ(f.measured_m, 7.75);
  EXPECT_DOUBLE_EQ(f.share(), 1.0 / 7.75);
}

// A randomised drive, the same inputs through trafficability/ and through the Python reference.
struct Drive {
  std::vector<SpeedSample> speed;
  struct Frame {
    std::int64_t t_ns;
    RutMeasurement m;
  };
  std::vector<Frame> frames;
};

Drive random_drive(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0, 1);
  Drive d;
  // Speed at 50 Hz (20 ms) with jitter: phases of driving, stopping, reversing, loss of signal.
  double v = 0, target = 1500;
  std::int64_t t = 0;
  for (int i = 0; i < 1500; ++i) {
    t += 20 * kMs + static_cast<std::int64_t>(unit(rng) * 2 * kMs);
    if (i % 150 == 0) {
      const double r = unit(rng);
      target = r < 0.15 ? 0 : r < 0.3 ? -800 : 500 + 2500 * unit(rng);
    }
    v += std::clamp(target - v, -60.0, 60.0);  // 3 m/s^2
    if (i >= 700 && i < 740) continue;         // 0.8 s without speed frames: stale
    SpeedState s = SpeedState::Ok;
    if (i >= 900 && i < 910) s = SpeedState::NotAvailable;
    if (i == 1000) s = SpeedState::Error;
    d.speed.push_back({t, s, s == SpeedState::Ok ? v : 0.0});
  }
  // Frames at 30 Hz; a depth that varies along the way, some refusals and NoRut.
  for (std::int64_t ft = 5 * kMs; ft < t; ft += 33'333'333) {
    Drive::Frame f{ft, ok_depth(60 + 70 * std::sin(ft * 1e-9) + 20 * unit(rng), 0.5 + 2 * unit(rng))};
    const double r = unit(rng);
    if (r < 0.08) f.m.status = static_cast<RutStatus>(2 + static_cast<int>(unit(rng) * 10));
    else if (r < 0.12) f.m.status = RutStatus::NoRut;
    d.frames.push_back(f);
  }
  return d;
}

std::vector<std::vector<double>> read_csv_numbers(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::string line;
  std::getline(in, line);  // header
  std::vector<std::vector<double>> rows;
  while (std::getline(in, line)) {
    std::vector<double> row;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) row.push_back(cell == "nan" ? std::nan("") : std::stod(cell));
    rows.push_back(row);
  }
  return rows;
}

void expect_same(double want, double got, const std::string& what) {
  if (std::isnan(want)) {
    EXPECT_TRUE(std::isnan(got)) << what << ": want NaN, got " << got;
  } else {
    EXPECT_NEAR(got, want, 1e-9 * std::max(1.0, std::abs(want))) << what;
  }
}

TEST(Trafficability, RandomDrivesMatchTheIndependentReference) {
  if (test::run_shell("/usr/bin/python3 -c 'import statistics' 2>/dev/null") != 0) {
    RUTD_SKIP_NEEDS_INSTALLED("/usr/bin/python3 (the reference computation)");
  }
  SegmentConfig c;
  c.length_m = 1.0;
  c.advisory = {.caution_depth_mm = 80,
                .no_go_depth_mm = 120,
                .hysteresis_m = 2.5,
                .max_untrusted_fraction = 0.3,
                .min_trusted_frames = 3,
                .coverage_factor = 2};
  c.soil.table = {{0, 1200}, {40, 800}, {100, 450}, {200, 300}};
  c.soil.source = "test";
  c.soil.limit_one_pass = 500;
  c.soil.limit_fifty_passes = 700;
  c.damage = {{"a", 100, 1.0, 1.0}, {"b", 60, 0.5, 1.0}};
  const OdometerConfig oc{.max_age_ns = 300 * kMs};
  std::size_t segments_checked = 0;
  int unknown = 0, nogo = 0, go = 0;
  for (unsigned seed : {1u, 2u, 3u}) {
    const Drive drive = random_drive(seed);
    test::TempDir dir;
    {
      std::ofstream cfg(dir.path() / "config.csv");
      cfg.precision(17);
      cfg << "length_m," << c.length_m << "\nmax_age_ns," << oc.max_age_ns
          << "\ncaution_depth_mm,80\nno_go_depth_mm,120"
          << "\nhysteresis_m,2.5\nmax_untrusted_fraction,0.3\nmin_trusted_frames,3\ncoverage_factor,2"
          << "\nsoil_table,0:1200 40:800 100:450 200:300\nlimit_one_pass,500\nlimit_fifty_passes,700"
          << "\ndamage,100:1.0 60:0.5\n";
      std::ofstream s(dir.path() / "speed.csv");
      s.precision(17);
      s << "t_ns,state,speed_mm_s\n";
      for (const SpeedSample& x : drive.speed)
        s << x.t_ns << ',' << static_cast<int>(x.state) << ',' << x.speed_mm_s << '\n';
      std::ofstream f(dir.path() / "frames.csv");
      f.precision(17);
      f << "t_ns,status,depth_mm,width_mm,area_mm2,u_mm\n";
      for (const auto& x : drive.frames)
        f << x.t_ns << ',' << static_cast<int>(x.m.status) << ',' << x.m.depth_mm << ',' << x.m.width_mm << ','
          << x.m.area_mm2 << ',' << x.m.depth_uncertainty_mm << '\n';
    }
    ASSERT_EQ(test::run_shell("/usr/bin/python3 " RUTD_SOURCE_DIR "/tests/unit/trafficability_reference.py " +
                              test::quoted(dir.path())),
              0);
    // The same through the library: samples received up to each frame's time, then the frame.
    Odometer odometer(oc);
    SegmentTracker tracker(c);
    std::vector<Segment> segments;
    std::size_t si = 0;
    for (const auto& f : drive.frames) {
      while (si < drive.speed.size() && drive.speed[si].t_ns <= f.t_ns) odometer.add(drive.speed[si++]);
      const std::size_t n = tracker.add(f.t_ns, f.m, odometer.motion_at(f.t_ns));
      for (std::size_t k = 0; k < n; ++k) segments.push_back(tracker.closed(k));
    }
    for (std::size_t n = tracker.finish(), k = 0; k < n; ++k) segments.push_back(tracker.closed(k));

    const auto want = read_csv_numbers(dir.path() / "segments_ref.csv");
    ASSERT_EQ(segments.size(), want.size()) << "seed " << seed;
    for (std::size_t i = 0; i < want.size(); ++i) {
      const Segment& s = segments[i];
      const auto& w = want[i];
      const std::string at = "seed " + std::to_string(seed) + " segment " + std::to_string(i);
      EXPECT_EQ(s.index, static_cast<std::uint64_t>(w[0])) << at;
      expect_same(w[1], s.start_m, at + " start");
      expect_same(w[2], s.end_m, at + " end");
      EXPECT_EQ(s.frames, static_cast<std::uint32_t>(w[3])) << at;
      EXPECT_EQ(s.refused, static_cast<std::uint32_t>(w[4])) << at;
      expect_same(w[5], s.mean_depth_mm, at + " mean");
      expect_same(w[6], s.max_depth_mm, at + " max");
      expect_same(w[7], s.p95_depth_mm, at + " p95");
      expect_same(w[8], s.mean_width_mm, at + " width");
      expect_same(w[9], s.mean_area_mm2, at + " area");
      expect_same(w[10], s.depth_uncertainty_mm, at + " u");
      expect_same(w[11], s.soil_strength, at + " strength");
      expect_same(w[12], s.soil_strength_uncertainty, at + " strength u");
      EXPECT_EQ(static_cast<int>(s.worst_status), static_cast<int>(w[13])) << at;
      EXPECT_EQ(static_cast<int>(s.advisory), static_cast<int>(w[14])) << at;
      unknown += s.advisory == Advisory::Unknown;
      nogo += s.advisory == Advisory::NoGo;
      go += s.advisory == Advisory::Go;
      ++segments_checked;
    }
    const auto damage = read_csv_numbers(dir.path() / "damage_ref.csv");
    ASSERT_EQ(damage.size(), 2u);
    for (std::size_t r = 0; r < 2; ++r) {
      const RutDamageFigures f = tracker.damage().figures(r);
      expect_same(damage[r][1], f.rutted_m, "rutted");
      expect_same(damage[r][2], f.measured_m, "measured");
      expect_same(damage[r][3], f.unmeasured_m, "unmeasured");
      EXPECT_EQ(f.stretches, static_cast<std::uint32_t>(damage[r][4]));
    }
  }
  // The drives exercise every kind of segment.
  EXPECT_GT(segments_checked, 60u);
  EXPECT_GT(unknown, 0);
  EXPECT_GT(nogo, 0);
  EXPECT_GT(go, 0);
}

}  // namespace
}  // namespace rutd
