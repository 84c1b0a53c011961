#pragma once
// The vehicle's speed from CAN frames: the wire format, the decoder that turns received frames into
// speed samples (core/track.hpp: SpeedSample) and what it counts of hostile input. Pure: no I/O; the
// receiver (can/vehicle_speed_receiver.hpp) and `rutd replay` (from a recording's vehicle.log) feed it
// the same frames with their receive times, so both get the same samples.
//
// Default: J1939 Cruise Control/Vehicle Speed 1 (CCVS1, PGN 65265 = 0xFEF1), any priority, any source
// address unless one is configured. Wheel-based vehicle speed (SPN 84) is bytes 2..3 (start bit 8, 16 bits,
// little-endian), 1/256 km/h per bit, 0 .. 250.996 km/h. J1939-71's ranges of a 2-byte parameter:
//   0x0000..0xFAFF  valid              0xFB00..0xFDFF  reserved (counted out of range, an Error sample)
//   0xFE00..0xFEFF  error indicator    0xFF00..0xFFFF  not available
// Worked example: 18FEF100#FF0019FFFFFFFFFF is CCVS1 from source address 0x00 (the engine) with priority 6;
// bytes 2..3 are 00 19 -> raw 0x1900 = 6400 -> 25.0 km/h = 6944.4 mm/s. 18FEF100#FF00FFFF... is "not
// available"; 18FEF100#FF00FE12... an error.
//
// Direction (optional): CCVS1 carries no direction, so a reversing vehicle's speed is positive. With
// `direction_from_gear`, J1939 Electronic Transmission Controller 2 (ETC2, PGN 61445 = 0xF005) gives it:
// transmission current gear (SPN 523) is byte 4, offset -125 (raw 0..124: a reverse gear, 125: neutral,
// 126..250: forward, 251: park; 0xFE error, 0xFF not available). Until a gear is known a moving vehicle's
// speed is NotAvailable, never assumed forward. Example: 0CF00503#FFFFFF7CFFFFFFFF is gear -1 (reverse).
//
// Or a signal named in a DBC file (trafficability.speed.dbc): its layout (start bit, length, byte order,
// sign, factor, offset, unit km/h, m/s, mm/s or mph) from the file; J1939's ranges apply when it says so
// (j1939_ranges), else every raw value is valid.
//
// Hostile input, each counted, none a sample: a frame of the right PGN from another source address than
// the one configured (spoofed), a frame shorter than the signal needs (wrong length), one sooner than
// min_interval after the last accepted one from the sender (burst: a flood of copies cannot outvote the
// real sender). Made an Error sample (distance stops, never guessed): a value out of the valid range or
// above max_speed, and a change faster than max_accel from the previous value.
#include <cstdint>
#include <optional>
#include <string>

#include "can/can_frame.hpp"
#include "core/track.hpp"

namespace rutd {

// Where the speed is in a frame, and its scale.
struct SpeedSignalLayout {
  std::uint32_t id = 0x00FEF100;       // identifier with the bits under id_mask
  std::uint32_t id_mask = 0x03FFFF00;  // J1939: the PGN bits (data page, PF, PS); priority and address free
  bool extended = true;
  int start_bit = 8;  // DBC convention: little-endian start = least significant bit; big-endian = MSB
  int length = 16;    // 1..32 bits
  bool little_endian = true;
  bool is_signed = false;
  double factor_mm_s = 1000.0 / 3.6 / 256.0;  // physical = raw * factor + offset, in mm/s
  double offset_mm_s = 0;
  bool j1939_ranges = true;  // the reserved, error and not-available ranges of J1939-71
  std::string name = "CCVS1 wheel-based vehicle speed (SPN 84)";
};

struct VehicleSpeedConfig {
  SpeedSignalLayout signal;
  int source_address = -1;  // J1939 sender of the speed to accept (0x00..0xFD); -1: any. ETC2: any sender
  bool direction_from_gear = false;
  double max_speed_mm_s = 150.0 / 3.6 * 1000;  // 150 km/h: above is out of range
  double max_accel_mm_s2 = 15000;              // about 1.5 g: a faster change is implausible
  std::int64_t min_interval_ns = 5'000'000;    // frames from the sender closer than this: burst
};

// Empty if usable, else what is wrong naming the field under `key`.
std::string check_vehicle_speed_config(const VehicleSpeedConfig& c, const std::string& key);

// The ETC2 identifier bits and mask (priority and source address free).
inline constexpr std::uint32_t kEtc2Id = 0x00F00500;
inline constexpr std::uint32_t kJ1939PgnMask = 0x03FFFF00;

struct VehicleSpeedStats {
  std::uint64_t frames = 0;             // offered to the decoder
  std::uint64_t samples = 0;            // speed samples produced (any state)
  std::uint64_t ok = 0;                 // of those, Ok
  std::uint64_t not_available = 0;      // "not available" values
  std::uint64_t error_value = 0;        // error indicator values
  std::uint64_t out_of_range = 0;       // reserved values, above max_speed
  std::uint64_t implausible = 0;        // faster change than max_accel
  std::uint64_t wrong_length = 0;       // too short for the signal
  std::uint64_t spoofed = 0;            // the right message from another sender
  std::uint64_t burst = 0;              // sooner than min_interval after the last accepted frame
  std::uint64_t other_id = 0;           // neither the speed nor the gear message (a filter let it through)
  std::uint64_t gear_frames = 0;        // ETC2 frames used for the direction
  std::uint64_t direction_unknown = 0;  // moving with no known direction (NotAvailable samples)
};

// A signal's raw value from a frame's payload (DBC bit numbering), or nothing if the frame is too short.
std::optional<std::uint64_t> extract_signal_raw(const CanFrame& frame, int start_bit, int length,
                                                bool little_endian) noexcept;

// The frames a vehicle sends, for `rutd synth` (a recording's vehicle.log from a speed profile) and
// tests. CCVS1 with the speed's magnitude (rounded to 1/256 km/h, saturated at 250.99 km/h; NaN: not
// available) and the other fields not available (all ones); ETC2 with the current gear (-1 reverse, 0
// neutral, +1 forward, others as given) and the rest not available. Priority 6 and 3 as J1939 recommends.
CanFrame encode_ccvs1(double speed_kmh, std::uint8_t source_address) noexcept;
CanFrame encode_etc2_gear(int gear, std::uint8_t source_address) noexcept;

class VehicleSpeedDecoder {  // not thread-safe: one thread feeds it. No allocation.
 public:
  explicit VehicleSpeedDecoder(VehicleSpeedConfig config);  // throws std::invalid_argument
  // One received frame at t_ns; a speed sample if it carried one.
  std::optional<SpeedSample> on_frame(const CanFrame& frame, std::int64_t t_ns) noexcept;
  const VehicleSpeedStats& stats() const noexcept { return stats_; }
  const VehicleSpeedConfig& config() const noexcept { return config_; }
  // Whether a frame's identifier is the speed message, the gear message (ignoring the sender).
  bool is_speed_id(const CanFrame& frame) const noexcept;
  bool is_gear_id(const CanFrame& frame) const noexcept;

 private:
  SpeedSample make(std::int64_t t_ns, SpeedState state, double speed_mm_s) noexcept;
  VehicleSpeedConfig config_;
  VehicleSpeedStats stats_;
  bool have_accepted_ = false;
  std::int64_t last_accepted_ns_ = 0;
  bool have_value_ = false;
  double last_value_mm_s_ = 0;
  std::int64_t last_value_ns_ = 0;
  int gear_ = 0;  // -1 reverse, 0 unknown/neutral/park, +1 forward
  bool gear_known_ = false;
};

}  // namespace rutd
