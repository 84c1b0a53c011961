// The vehicle speed decoder (can/vehicle_speed.hpp) against canmatrix: J1939 CCVS and ETC2 frames encoded
// from canmatrix's own j1939.dbc, and random frames of a DBC written here (Intel and Motorola, signed and
// unsigned) encoded and decoded by canmatrix (tests/can/encode_speed_frames.py); and its handling of
// hostile input: spoofed senders, short frames, bursts, implausible jumps, values out of range.
#include <cmath>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "can/candump_log.hpp"
#include "can/dbc_signal.hpp"
#include "can/vehicle_speed.hpp"
#include "test_support.hpp"

namespace rutd {
namespace {

using test::quoted;
using test::run_shell;
constexpr const char* kPython = "/usr/bin/python3";
constexpr std::int64_t kS = 1'000'000'000;

struct Encoded {
  CanFrame frame;
  std::string name;
  double value;
};

// Runs the encoder script; false (after skipping the test) if canmatrix is missing.
std::vector<Encoded> encode(const std::string& args, const std::filesystem::path& out) {
  std::vector<Encoded> frames;
  const int rc = run_shell(std::string(kPython) + " " RUTD_SOURCE_DIR "/tests/can/encode_speed_frames.py " + args +
                           " 2>/dev/null");
  EXPECT_EQ(rc, 0);
  std::ifstream in(out);
  for (std::string line; std::getline(in, line);) {
    const auto a = line.find(';'), b = line.find(';', a + 1);
    const auto f = parse_candump_line(line.substr(0, a));
    EXPECT_TRUE(f.has_value()) << line;
    if (f) frames.push_back({f->first, line.substr(a + 1, b - a - 1), std::stod(line.substr(b + 1))});
  }
  return frames;
}

bool have_canmatrix() {
  return run_shell(std::string(kPython) + " -c 'import canmatrix.formats' >/dev/null 2>&1") == 0;
}

VehicleSpeedConfig permissive() {
  VehicleSpeedConfig c;
  c.max_speed_mm_s = 1e9;
  c.max_accel_mm_s2 = 1e15;
  c.min_interval_ns = 0;
  return c;
}

TEST(VehicleSpeed, DecodesCanmatrixCcvsFramesWithJ1939Ranges) {
  if (!have_canmatrix()) RUTD_SKIP_NEEDS_INSTALLED("canmatrix for /usr/bin/python3 (python3-canmatrix)");
  test::TempDir tmp;
  const auto frames = encode("j1939 " + quoted(tmp.path() / "f.txt"), tmp.path() / "f.txt");
  VehicleSpeedConfig c = permissive();
  c.direction_from_gear = true;
  VehicleSpeedDecoder d(c);
  CanFrame forward = encode_etc2_gear(1, 3);
  d.on_frame(forward, 0);
  int checked = 0;
  std::int64_t t = kS;
  for (const Encoded& e : frames) {
    if (e.name != "CCVS") continue;
    const auto s = d.on_frame(e.frame, t += kS);
    ASSERT_TRUE(s.has_value());
    const auto raw = static_cast<unsigned>(e.value);
    // J1939-71: 0xFB00.. reserved, 0xFE00.. error, 0xFF00.. not available.
    const SpeedState want = raw >= 0xFF00   ? SpeedState::NotAvailable
                            : raw >= 0xFB00 ? SpeedState::Error
                                            : SpeedState::Ok;
    EXPECT_EQ(s->state, want) << "raw " << raw;
    if (want == SpeedState::Ok) {
      EXPECT_NEAR(s->speed_mm_s, raw / 256.0 / 3.6 * 1000, 1e-9) << "raw " << raw;
    }
    ++checked;
  }
  EXPECT_EQ(checked, 52);
  EXPECT_EQ(d.stats().not_available, 2u);
  EXPECT_EQ(d.stats().error_value, 2u);
  EXPECT_EQ(d.stats().out_of_range, 2u);
  // Gears from canmatrix's ETC2: 124 reverse (the speed turns negative), 125 neutral (moving: direction
  // unknown), 126 forward, 0xFF not available.
  const CanFrame moving = encode_ccvs1(3.6, 0);
  auto speed_after = [&](unsigned gear) {
    for (const Encoded& e : frames)
      if (e.name == "ETC2" && static_cast<unsigned>(e.value) == gear) d.on_frame(e.frame, t += kS);
    return *d.on_frame(moving, t += kS);
  };
  const double kmh_3_6 = std::round(3.6 * 256) / 256 / 3.6 * 1000;  // 1/256 km/h steps
  EXPECT_DOUBLE_EQ(speed_after(124).speed_mm_s, -kmh_3_6);
  EXPECT_EQ(speed_after(125).state, SpeedState::NotAvailable);
  EXPECT_DOUBLE_EQ(speed_after(126).speed_mm_s, kmh_3_6);
  EXPECT_EQ(speed_after(0xFF).state, SpeedState::NotAvailable);
}

TEST(VehicleSpeed, ReadsADbcSignalAndDecodesItAsCanmatrixDoes) {
  if (!have_canmatrix()) RUTD_SKIP_NEEDS_INSTALLED("canmatrix for /usr/bin/python3 (python3-canmatrix)");
  test::TempDir tmp;
  const auto dbc = tmp.path() / "vehicle.dbc";
  std::ofstream(dbc) << "VERSION \"\"\n\nNS_ :\n\nBS_:\n\nBU_: ABS rutd\n\n"
                        "BO_ 2365484043 WheelSpeeds: 8 ABS\n"
                        " SG_ VehSpd : 8|16@1+ (0.01,0) [0|250] \"km/h\" rutd\n\n"
                        "BO_ 801 Odo: 8 ABS\n"
                        " SG_ SignedSpeed : 23|16@0- (0.001,0) [-30|30] \"m/s\" rutd\n";
  const auto frames = encode("dbc " + quoted(dbc) + " " + quoted(tmp.path() / "f.txt") + " 5", tmp.path() / "f.txt");
  int checked = 0;
  for (const auto& [message, signal, to_mm_s] :
       {std::tuple{"WheelSpeeds", "VehSpd", 1000 / 3.6}, std::tuple{"Odo", "SignedSpeed", 1000.0}}) {
    VehicleSpeedConfig c = permissive();
    c.signal = load_dbc_speed_signal(dbc.string(), message, signal);
    VehicleSpeedDecoder d(c);
    std::int64_t t = 0;
    for (const Encoded& e : frames) {
      if (e.name != std::string(message) + "." + signal) continue;
      const auto s = d.on_frame(e.frame, t += kS);
      ASSERT_TRUE(s.has_value());
      ASSERT_EQ(s->state, SpeedState::Ok) << e.name;
      EXPECT_NEAR(s->speed_mm_s, e.value * to_mm_s, 1e-6 * std::max(1.0, std::abs(e.value * to_mm_s))) << e.name;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 100);
  EXPECT_THROW(load_dbc_speed_signal(dbc.string(), "Odo", "Nope"), std::invalid_argument);
  EXPECT_THROW(load_dbc_speed_signal(dbc.string(), "Nope", "VehSpd"), std::invalid_argument);
}

TEST(VehicleSpeed, CountsHostileInputAndNeverTurnsItIntoSpeed) {
  VehicleSpeedConfig c;  // the defaults: 150 km/h, 15 m/s^2, 5 ms between frames
  c.source_address = 0x00;
  VehicleSpeedDecoder d(c);
  std::int64_t t = 0;
  const auto ok = [&](double kmh, std::int64_t dt_ms) {
    return d.on_frame(encode_ccvs1(kmh, 0), t += dt_ms * 1'000'000);
  };
  ASSERT_EQ(ok(10, 100)->state, SpeedState::Ok);
  EXPECT_FALSE(ok(10, 1));                                             // 1 ms after the last accepted frame: burst
  EXPECT_FALSE(d.on_frame(encode_ccvs1(200, 0x17), t += 10'000'000));  // spoofed sender
  CanFrame shorter = encode_ccvs1(10, 0);
  shorter.len = 2;
  EXPECT_FALSE(d.on_frame(shorter, t += 10'000'000));  // too short for bytes 1..2
  EXPECT_EQ(ok(149, 100)->state, SpeedState::Error);   // +139 km/h in 0.1 s: implausible
  EXPECT_EQ(ok(160, 1000)->state, SpeedState::Error);  // above 150 km/h
  EXPECT_EQ(ok(20, 1000)->state, SpeedState::Ok);
  CanFrame other = encode_ccvs1(10, 0);
  other.id = 0x18FEF200;
  EXPECT_FALSE(d.on_frame(other, t += 10'000'000));
  EXPECT_EQ(d.on_frame(encode_ccvs1(std::numeric_limits<double>::quiet_NaN(), 0), t += 100'000'000)->state,
            SpeedState::NotAvailable);
  const VehicleSpeedStats& s = d.stats();
  EXPECT_EQ(s.spoofed, 1u);
  EXPECT_EQ(s.wrong_length, 1u);
  EXPECT_EQ(s.burst, 1u);
  EXPECT_EQ(s.implausible, 1u);
  EXPECT_EQ(s.out_of_range, 1u);
  EXPECT_EQ(s.other_id, 1u);
  EXPECT_EQ(s.not_available, 1u);
  EXPECT_EQ(s.ok, 2u);
  EXPECT_EQ(s.frames, 9u);
}

}  // namespace
}  // namespace rutd
