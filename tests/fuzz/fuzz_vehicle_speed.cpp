// libFuzzer target: the vehicle speed rutd decodes from the CAN bus (can/vehicle_speed.hpp), what the
// receiver hands VehicleSpeedDecoder and `rutd replay` reads back from vehicle.log, and the odometer
// (trafficability/) the samples drive. Input: one byte of configuration (bit 0: a fixed sender address
// 0x00, bit 1: direction from the ETC2 gear, bit 2: a Motorola signed 16-bit signal at bit 23 instead of
// CCVS), then 16-byte records: identifier (4 bytes, little-endian, bit 31 = 29-bit), length (1 byte, 0..8
// used modulo 9), 8 data bytes, time step in microseconds (3 bytes). Checked against the contracts: every
// frame is counted exactly once (a sample, or ignored as foreign, spoofed, short, burst or gear), an Ok
// sample's speed is finite and within max_speed, any other sample's speed is 0, and the odometer's
// distance never decreases and is NaN exactly when its state is not Ok.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "can/vehicle_speed.hpp"
#include "fuzz_check.hpp"
#include "trafficability/odometer.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  rutd::VehicleSpeedConfig config;
  if (data[0] & 1U) config.source_address = 0x00;
  config.direction_from_gear = (data[0] & 2U) != 0;
  if (data[0] & 4U) {
    config.signal.id = 0x321;
    config.signal.id_mask = 0x7FF;
    config.signal.extended = false;
    config.signal.start_bit = 23;
    config.signal.little_endian = false;
    config.signal.is_signed = true;
    config.signal.factor_mm_s = 1.0;
    config.signal.j1939_ranges = false;
  }
  rutd::VehicleSpeedDecoder decoder(config);
  rutd::Odometer odometer;
  std::int64_t t_ns = 0;
  double last_distance = -1;
  std::uint64_t samples = 0;
  for (std::size_t at = 1; at + 16 <= size; at += 16) {
    const std::uint8_t* r = data + at;
    std::uint32_t raw_id = 0;
    std::memcpy(&raw_id, r, 4);
    rutd::CanFrame frame;
    frame.extended = (raw_id & 0x80000000U) != 0;
    frame.id = raw_id & (frame.extended ? 0x1FFFFFFFU : 0x7FFU);
    frame.len = static_cast<std::uint8_t>(r[4] % 9);
    std::memcpy(frame.data.data(), r + 5, frame.len);
    t_ns += static_cast<std::int64_t>(r[13] | (r[14] << 8) | (r[15] << 16)) * 1000;
    const auto sample = decoder.on_frame(frame, t_ns);
    if (sample) {
      ++samples;
      if (sample->state == rutd::SpeedState::Ok) {
        if (!std::isfinite(sample->speed_mm_s) || std::abs(sample->speed_mm_s) > config.max_speed_mm_s)
          rutd::fuzz::fail("an Ok speed out of range", "");
      } else if (sample->speed_mm_s != 0.0) {
        rutd::fuzz::fail("a speed that is not Ok is not 0", "");
      }
      odometer.add(*sample);
    }
    const rutd::VehicleMotion m = odometer.motion_at(t_ns);
    if ((m.state == rutd::SpeedState::Ok) == std::isnan(m.distance_m))
      rutd::fuzz::fail("distance NaN does not match the speed state", "");
    if (m.state == rutd::SpeedState::Ok) {
      if (m.distance_m < last_distance - 1e-9) rutd::fuzz::fail("the distance went backwards", "");
      last_distance = m.distance_m;
    }
  }
  const rutd::VehicleSpeedStats& s = decoder.stats();
  if (s.samples != samples || s.frames != s.samples + s.other_id + s.spoofed + s.gear_frames + s.wrong_length + s.burst)
    rutd::fuzz::fail("frames are not each counted once", "");
  return 0;
}
