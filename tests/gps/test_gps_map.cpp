// `rutd map` end to end: two drives over the same track (the second 0.5 m beside the first with 0.2 m of
// GPS noise, a deeper rendered rut, and a 60-degree turn away after 8 m), each measured and recorded by
// `rutd run` with a real gpsd fed by gpsfake; `rutd map` of the two recordings (measured again from their
// pairs and gps.jsonl) matches the second drive to the first on the stretch in common and
// not after the turn, the sinkage increase equals the rendered one, and the GeoJSON is read by shapely and
// GDAL's ogrinfo (check_map.py), with every point at a position of the drives' NMEA logs.
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

  // Measures one drive: gpsfake plays `nmea_args`' log while rutd renders a rut `depth_mm` deep.
  void measure_drive(const std::string& name, const std::string& nmea_args, double depth_mm) {
    const path d = dir_ / name;
    test::fs::create_directories(d);
    test::write_drive(d, nmea_args);
    const int port = test::free_loopback_port();
    test::ProcessGroup gpsfake(
        {"gpsfake", "-q", "-n", "-1", "-c", "0.05", "-P", std::to_string(port), (d / "drive.nmea").string()},
        d / "gpsfake.log");
    ASSERT_TRUE(test::wait_for_port(port, 10s)) << test::read_text(d / "gpsfake.log");
    std::ofstream(d / "rutd.yaml") << "source:\n  synthetic:\n    size: 320x240\n    fps: 15\n    depth_mm: "
                                   << depth_mm << "\nsinks:\n  candump: \"\"\n  csv_positions: true\n"
                                   << "gps:\n  enabled: true\n  port: \"" << port << "\"\n  reconnect_min_ms: 50\n";
    ASSERT_EQ(test::run_rutd("run --config " + test::quoted(d / "rutd.yaml") + " --frames 60 --csv " +
                                 test::quoted(d / "run.csv") + " --record " + test::quoted(d / "rec"),
                             (d / "run.log").string()),
              0)
        << test::read_text(d / "run.log");
  }
  path dir_;
};

TEST_F(GpsMapTest, SecondDriveMatchesTheFirstOnTheCommonStretchWithTheRenderedIncrease) {
  if (!test::gpsfake_installed()) RUTD_SKIP_NEEDS_INSTALLED("gpsd and gpsfake (Debian gpsd, gpsd-clients)");
  if (test::run_shell("/usr/bin/python3 -c 'import shapely' && command -v ogrinfo >/dev/null") != 0)
    RUTD_SKIP_NEEDS_INSTALLED("/usr/bin/python3 with python3-shapely, and gdal-bin (ogrinfo): the GeoJSON's readers");
  measure_drive("first", "--epochs 40 --period 0.2 --speed 2", 30.0);
  measure_drive("second",
                "--epochs 40 --period 0.2 --speed 2 --offset-north-m 0.5 --noise-m 0.2 --seed 4 "
                "--diverge-after-m 8 --diverge-deg 60",
                38.0);
  const std::string truths =
      test::quoted(dir_ / "first" / "drive_truth.csv") + " " + test::quoted(dir_ / "second" / "drive_truth.csv");
  const std::string recordings = test::quoted(dir_ / "first" / "rec") + " " + test::quoted(dir_ / "second" / "rec");
  ASSERT_EQ(test::run_rutd("map " + recordings + " --out " + test::quoted(dir_ / "map"), (dir_ / "map.log").string()),
            0)
      << test::read_text(dir_ / "map.log");
  EXPECT_TRUE(test::fs::file_size(dir_ / "map" / "depth_by_pass.png") > 1000);
  const std::string check = "/usr/bin/python3 " + test::quoted(path(test::kGpsTestDir) / "check_map.py") + " " +
                            test::quoted(dir_ / "map") + " " + truths + " > " + test::quoted(dir_ / "check.json") +
                            " 2>&1";
  ASSERT_EQ(test::run_shell(check), 0) << test::read_text(dir_ / "check.json");
  const std::string figures = test::read_text(dir_ / "check.json");
  SCOPED_TRACE(figures);
  std::cout << "map figures: " << figures;
  EXPECT_GE(test::json_number(figures, "features"), 40);
  // The stretch in common (up to 7 m, short of the turn at 8 m): matched; after the turn: not.
  const double before = test::json_number(figures, "second_pass_before_turn");
  EXPECT_GE(before, 10);
  EXPECT_GE(test::json_number(figures, "second_pass_before_turn_matched"), before - 1);
  EXPECT_GE(test::json_number(figures, "second_pass_after_turn"), 5);
  EXPECT_EQ(test::json_number(figures, "second_pass_after_turn_matched"), 0);
  // 38 mm rendered on the second drive, 30 mm on the first.
  EXPECT_NEAR(test::json_number(figures, "median_increase_mm"), 8.0, 1.0);
}

}  // namespace
}  // namespace rutd
