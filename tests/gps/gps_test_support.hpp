#pragma once
// What the gpsd tests share: the drive logs nmea_drive.py writes and the truth it writes beside them, gpsd
// reports; the services themselves (gpsfake and the gpsd it starts, the fake gpsd) run as ProcessGroups on
// free loopback ports (process_support.hpp).
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "core/track.hpp"
#include "process_support.hpp"
#include "skip_policy.hpp"
#include "test_support.hpp"

namespace rutd::test {

namespace fs = std::filesystem;

inline const std::string kGpsTestDir = std::string(RUTD_SOURCE_DIR) + "/tests/gps";
// NMEA writes 1e-5 minute of arc (1.7e-7 degree); gpsd reports 9 decimals of a degree.
inline constexpr double kNmeaResolutionDeg = 1e-5 / 60.0;

inline bool gpsfake_installed() { return fs::exists("/usr/bin/gpsfake") && fs::exists("/usr/sbin/gpsd"); }

// Lines for fake_gpsd.py's sessions, one a line.
inline void write_lines(const fs::path& file, const std::vector<std::string>& lines) {
  std::ofstream out(file);
  for (const auto& l : lines) out << l << '\n';
}

// A gpsd TPV report (3D fix) as gpsd 3.22 writes it, at `time` (ISO 8601, UTC).
inline std::string tpv(const std::string& time, double lat, double lon) {
  return R"({"class":"TPV","device":"/dev/ttyACM0","mode":3,"time":")" + time + R"(","ept":0.005,"lat":)" +
         std::to_string(lat) + R"(,"lon":)" + std::to_string(lon) +
         R"(,"altHAE":1340.0,"altMSL":1340.0,"alt":1340.0,"track":90.0,"speed":2.0,"eph":1.5})";
}

// One epoch as nmea_drive.py wrote it (the position as written in the log, read back).
struct TruthEpoch {
  int epoch = 0;
  bool fix = false;
  double lat = NAN, lon = NAN, alt = NAN, track = NAN;
};

inline std::vector<TruthEpoch> read_truth(const fs::path& csv) {
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);
  std::vector<TruthEpoch> out;
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::stringstream ss(line);
    for (std::string x; std::getline(ss, x, ',');) f.push_back(x);
    f.resize(8);
    TruthEpoch t;
    t.epoch = std::stoi(f[0]);
    t.fix = f[2] == "1";
    if (t.fix) {
      t.lat = std::stod(f[3]);
      t.lon = std::stod(f[4]);
      t.alt = std::stod(f[5]);
      t.track = std::stod(f[6]);
    }
    out.push_back(t);
  }
  return out;
}

// The epoch whose written position this is (within the log's resolution), or -1.
inline int matching_epoch(const std::vector<TruthEpoch>& truth, double lat, double lon) {
  for (const TruthEpoch& t : truth)
    if (t.fix && std::abs(t.lat - lat) <= kNmeaResolutionDeg && std::abs(t.lon - lon) <= kNmeaResolutionDeg)
      return t.epoch;
  return -1;
}

// Writes a drive log (nmea_drive.py) into dir: drive.nmea and drive_truth.csv.
inline void write_drive(const fs::path& dir, const std::string& extra_args) {
  const std::string cmd = "/usr/bin/python3 " + test::quoted(fs::path(kGpsTestDir) / "nmea_drive.py") + " --out " +
                          test::quoted(dir / "drive.nmea") + " --truth " + test::quoted(dir / "drive_truth.csv") + " " +
                          extra_args;
  ASSERT_EQ(run_shell(cmd), 0) << cmd;
}

}  // namespace rutd::test
