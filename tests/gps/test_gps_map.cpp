// `rutd map` end to end: two drives over the same track (the second 0.5 m beside the first with 0.2 m of
// GPS noise, a deeper rendered rut, and a 60-degree turn away after 8 m), each measured and recorded by
// `rutd run` with a real gpsd fed by gpsfake and the vehicle's speed on CAN (canmatrix-encoded CCVS at the
// pace gpsfake plays the drive, sent into the speed receiver by rutd_faults: no CAN kernel support needed).
// `rutd map` of the two recordings (measured again from their pairs, gps.jsonl and vehicle.log) maps the
// 1 m distance segments with their advisories; of the two runs' measurement CSVs (no speed there), the
// pieces between fixes. Either way it matches the second drive to the first on the stretch in common and
// not after the turn, the sinkage increase equals the rendered one, and the GeoJSON is read by shapely and
// GDAL's ogrinfo (check_map.py), with every point at a position of its drive's NMEA log.
#include <iostream>

#include <gtest/gtest.h>

#include "gps_test_support.hpp"

namespace rutd {
namespace {

using namespace std::chrono_literals;
using test::fs::path;

class GpsMapTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::fs::temp_directory_path() / ("rutd_gps_map_" + std::to_string(::getpid()));
    test::fs::remove_all(dir_);
    test::fs::create_directories(dir_);
  }
  void TearDown() override { test::fs::remove_all(dir_); }

  // Measures one drive: gpsfake plays `nmea_args`' log (0.2 s epochs at 2 m/s, played two sentences 0.05 s
  // apart: 4 m of drive a second) while rutd renders a rut `depth_mm` deep and hears the speed, 14.4 km/h.
  void measure_drive(const std::string& name, const std::string& nmea_args, double depth_mm) {
    const path d = dir_ / name;
    test::fs::create_directories(d);
    test::write_drive(d, nmea_args);
    ASSERT_EQ(test::run_shell("/usr/bin/python3 " RUTD_SOURCE_DIR "/tests/integration/encode_speed_profile.py " +
                              test::quoted(d / "speed.log") + " 50 12 0:14.4,12:14.4 2>/dev/null"),
              0);
    const int port = test::free_loopback_port();
    test::ProcessGroup gpsfake(
        {"gpsfake", "-q", "-n", "-1", "-c", "0.05", "-P", std::to_string(port), (d / "drive.nmea").string()},
        d / "gpsfake.log");
    ASSERT_TRUE(test::wait_for_port(port, 10s)) << test::read_text(d / "gpsfake.log");
    std::ofstream(d / "rutd.yaml") << "source:\n  synthetic:\n    size: 320x240\n    fps: 15\n    depth_mm: "
                                   << depth_mm << "\nsinks:\n  candump: \"\"\n  csv_positions: true\n"
                                   << "gps:\n  enabled: true\n  port: \"" << port << "\"\n  reconnect_min_ms: 50\n";
    const std::string run = "exec " + test::quoted(RUTD_FAULTS_BINARY) + " --speed-from " +
                            test::quoted(d / "speed.log") + " run --config " + test::quoted(d / "rutd.yaml") +
                            " --speed-socketcan vcan0 --frames 90 --csv " + test::quoted(d / "run.csv") + " --record " +
                            test::quoted(d / "rec") + " 2>" + test::quoted(d / "run.log");
    ASSERT_EQ(test::run_shell(run), 0) << test::read_text(d / "run.log");
  }

  // check_map.py's figures for a map of `drives`; fails the test when the readers refuse it.
  std::string map_figures(const std::string& drives, const std::string& out) {
    const std::string truths =
        test::quoted(dir_ / "first" / "drive_truth.csv") + " " + test::quoted(dir_ / "second" / "drive_truth.csv");
    const std::string log = (dir_ / (out + ".log")).string();
    EXPECT_EQ(test::run_rutd("map " + drives + " --out " + test::quoted(dir_ / out), log), 0) << test::read_text(log);
    EXPECT_TRUE(test::fs::exists(dir_ / out / "depth_by_pass.png") &&
                test::fs::file_size(dir_ / out / "depth_by_pass.png") > 1000);
    const path figures = dir_ / (out + ".json");
    const std::string check = "/usr/bin/python3 " + test::quoted(path(test::kGpsTestDir) / "check_map.py") + " " +
                              test::quoted(dir_ / out) + " " + truths + " > " + test::quoted(figures) + " 2>&1";
    EXPECT_EQ(test::run_shell(check), 0) << test::read_text(figures);
    const std::string text = test::read_text(figures);
    std::cout << out << " figures: " << text;
    return text;
  }

  // The stretch in common (truth along the drive up to 7 m, short of the turn at 8 m): matched; after the
  // turn: not; 38 mm rendered on the second drive, 30 mm on the first.
  static void expect_passes(const std::string& figures, double min_before, double min_after) {
    SCOPED_TRACE(figures);
    const double before = test::json_number(figures, "second_pass_before_turn");
    EXPECT_GE(before, min_before);
    EXPECT_GE(test::json_number(figures, "second_pass_before_turn_matched"), before - 1);
    EXPECT_GE(test::json_number(figures, "second_pass_after_turn"), min_after);
    EXPECT_EQ(test::json_number(figures, "second_pass_after_turn_matched"), 0);
    EXPECT_NEAR(test::json_number(figures, "median_increase_mm"), 8.0, 1.0);
  }
  path dir_;
};

TEST_F(GpsMapTest, SecondDriveMatchesTheFirstOnTheCommonStretchWithTheRenderedIncrease) {
  if (!test::gpsfake_installed()) RUTD_SKIP_NEEDS_INSTALLED("gpsd and gpsfake (Debian gpsd, gpsd-clients)");
  if (test::run_shell("/usr/bin/python3 -c 'import shapely' && command -v ogrinfo >/dev/null") != 0)
    RUTD_SKIP_NEEDS_INSTALLED("/usr/bin/python3 with python3-shapely, and gdal-bin (ogrinfo): the GeoJSON's readers");
  if (test::run_shell("/usr/bin/python3 -c 'import canmatrix.formats' >/dev/null 2>&1") != 0)
    RUTD_SKIP_NEEDS_INSTALLED("canmatrix for /usr/bin/python3 (Debian package python3-canmatrix)");
  measure_drive("first", "--epochs 60 --period 0.2 --speed 2", 30.0);
  measure_drive("second",
                "--epochs 60 --period 0.2 --speed 2 --offset-north-m 0.5 --noise-m 0.2 --seed 4 "
                "--diverge-after-m 8 --diverge-deg 60",
                38.0);

  // The recordings, with their vehicle.log: 1 m distance segments, each with its advisory (GO: shallow).
  const std::string segments =
      map_figures(test::quoted(dir_ / "first" / "rec") + " " + test::quoted(dir_ / "second" / "rec"), "map_segments");
  {
    SCOPED_TRACE(segments);
    const double features = test::json_number(segments, "features");
    EXPECT_GE(features, 20);
    EXPECT_EQ(test::json_number(segments, "segments"), features);
    EXPECT_GE(test::json_number(segments, "one_metre"), features - 2) << "1 m segments (a drive's last may be short)";
    // Every segment measured often enough has its advisory (at 15 pairs a second and 4 m/s, nearly all; a
    // sanitizer build measures fewer pairs, so fewer are), bar the first few after the start and the turn.
    EXPECT_GE(test::json_number(segments, "trusted_advisory_known"), test::json_number(segments, "trusted") - 3);
    EXPECT_GT(test::json_number(segments, "advisory_known"), 0);
  }
  expect_passes(segments, 3, 3);

  // The runs' own measurement CSVs, which have positions but no speed: pieces between fixes.
  const std::string fixes = map_figures(
      test::quoted(dir_ / "first" / "run.csv") + " " + test::quoted(dir_ / "second" / "run.csv"), "map_fixes");
  {
    SCOPED_TRACE(fixes);
    EXPECT_GE(test::json_number(fixes, "features"), 40);
    EXPECT_EQ(test::json_number(fixes, "segments"), 0);
    EXPECT_EQ(test::json_number(fixes, "advisory_known"), 0);
  }
  expect_passes(fixes, 10, 5);
}

}  // namespace
}  // namespace rutd
