#pragma once
// Turns measurements and sensor health into CAN frames (DESIGN.md §6). Pure code: no I/O, no
// allocation; a sink (SocketCAN, candump log) sends what it returns. config/rutd.dbc describes the
// frames bit for bit; keep the two in step.
//
// Identifiers. By default 29-bit J1939 identifiers, broadcast Proprietary B PGNs (PDU2, PF 0xFF):
//   id = priority << 26 | PGN << 8 | source address      (data page and extended data page 0)
//   RutMeasurement1  PGN 0xFF50  -> 0x18FF50A0 with priority 6 and source address 0xA0
//   RutMeasurement2  PGN 0xFF51  -> 0x18FF51A0
//   RutSensorStatus  PGN 0xFF52  -> 0x18FF52A0
//   RutConditions    PGN 0xFF53  -> 0x18FF53A0
//   RutSegment       PGN 0xFF54  -> 0x18FF54A0
//   RutSegmentStats  PGN 0xFF55  -> 0x18FF55A0
//   RutMotion        PGN 0xFF56  -> 0x18FF56A0
//   RutUplinkStatus  PGN 0xFF57  -> 0x18FF57A0
//   RutSoftwareVersion PGN 0xFF5F -> 0x18FF5FA0
// or, with `extended = false`, the 11-bit identifiers of CanIdConfig (0x350, 0x351, 0x352, 0x353, 0x354,
// 0x355, 0x356, 0x357, 0x35F).
//
// Payload, every frame 8 bytes, signals little-endian (Intel), unsigned, physical = raw * factor +
// offset. Protection in the AUTOSAR E2E profile 1 layout:
//   byte 0          CRC-8/SAE-J1850 (can/crc8.hpp: init 0xFF, xor-out 0xFF) over the two Data ID
//                   bytes (low byte first, then high byte) followed by payload bytes 1..7
//   byte 1 bits 0-3 rolling counter 0..14, then back to 0 (15 is never sent, as in profile 1). Both
//                   measurement frames of one measurement carry the same value; the status frame
//                   and the version frame have their own counters.
//   Data IDs        RutMeasurement1 0xFF50, RutMeasurement2 0xFF51, RutSensorStatus 0xFF52,
//                   RutConditions 0xFF53, RutSegment 0xFF54, RutSegmentStats 0xFF55, RutMotion 0xFF56,
//                   RutUplinkStatus 0xFF57,
//                   RutSoftwareVersion 0xFF5F. They are
//                   fixed per message (not derived from the configured identifiers) so a receiver's
//                   check does not depend on the addressing. Unlike a strict profile 1 CRC (which
//                   starts from 0x00 and ends without xor), the catalogue parameters above are used.
//
//   RutMeasurement1  byte 1 bits 4-7  status (RutStatus number; 15 = unknown)
//                    bits 16..27   depth     0.1 mm    0..400 mm
//                    bits 28..39   width     0.25 mm   0..1000 mm
//                    bits 40..47   quality   0.4 %     0..100 %
//                    bits 48..63   area      10 mm^2   0..655340 mm^2
//   RutMeasurement2  byte 1 bits 4-7  status (as above)
//                    bits 16..27   left pile   0.1 mm   0..200 mm
//                    bits 28..39   right pile  0.1 mm   0..200 mm
//                    bits 40..51   ground slope 0.02 deg, offset -30 deg: -30..+30 deg
//                    bits 52..63   rut centre X 0.5 mm, offset -1000 mm: -1000..+1000 mm
//   RutConditions    byte 1 bits 4-7  status (as above); same counter as the measurement's frames, sent
//                                  right after them, whatever the status
//                    bits 16..23   condition flags, one bit each in RutCondition's order: water / flat
//                                  patch, left lens obstructed, right lens obstructed, low light,
//                                  overexposed, vegetation, calibration drift, depth uncertain
//                    bits 24..35   depth uncertainty   0.01 mm   0..40.94 mm
//                    bits 36..47   vertical disparity  0.01 px, offset -20 px: -20..+20.94 px
//                    bits 48..55   left lens obstructed   0.4 %   0..100 % of the strip's blocks
//                    bits 56..63   right lens obstructed  0.4 %   0..100 %
//   RutMotion        the vehicle's motion and position at the measurement's capture time (PublishedFrame::
//                    motion and ::position), so a receiver knows per measurement whether it lies on the
//                    track: same counter as the measurement's frames, sent right after RutConditions, only
//                    by a daemon with a speed or a positioning source (CanSink::enable_motion)
//                    byte 1 bits 4-7  speed state (SpeedState number: 0 OK, 1 NOT_AVAILABLE, 2 ERROR,
//                                  3 STALE, 4 NO_SOURCE): anything but 0 is "speed unknown"
//                    bits 16..31   vehicle speed  0.01 km/h, offset -320 km/h: -320..+335.34 km/h, negative
//                                  while reversing; not available unless the speed state is OK
//                    bits 32..55   track distance  0.01 m  0..167772.14 m of new ground since the start
//                                  (VehicleMotion::distance_m); not available while it is unknown
//                    bits 56..59   position fix: 1 no fix in force (gpsd absent or silent, no fix, or
//                                  the fix stale), 2 2D, 3 3D; 15 no positioning source (GeoFix::Mode
//                                  None); 0 is not sent
//                    bits 60..63   reserved, all ones
//                    Worked example: moving forward at 7.2 km/h, 12.34 m along the track, a 3D fix, counter
//                    0: speed (7.2 + 320) / 0.01 = 32720 = 0x7FD0, distance 1234 = 0x0004D2; bytes 1..7 =
//                    00 D0 7F D2 04 00 F3; CRC over 56 FF 00 D0 7F D2 04 00 F3 = 0x9A. In candump:
//                    18FF56A0#9A00D07FD20400F3.
//   RutUplinkStatus  the fleet uplink (SensorHealth::uplink), sent right after every RutSensorStatus when an
//                    uplink is configured; own counter
//                    byte 1 bits 4-7  link: 0 down, 1 up
//                    bits 16..39   queued messages (waiting for the broker's acknowledgement) 0..16777214
//                    bits 40..55   oldest unsent message's age  1 s  0..65534 s
//                    bit 56        send or connection errors in the last status period
//                    bit 57        queue write errors (disk full) in the last status period
//                    bit 58        messages dropped (beyond the queue's bound, or not queued) in it
//                    bits 59..63   reserved, all ones
//                    Worked example: link down, 1234 queued, the oldest 75 s old, send errors, counter 0:
//                    byte 1 0x00; bytes 2..4 D2 04 00; bytes 5..6 4B 00; byte 7 0xF9 (bit 56 set, 57 and 58
//                    clear, 59..63 ones); CRC over 57 FF 00 D2 04 00 4B 00 F9 = 0x9D. In candump:
//                    18FF57A0#9D00D204004B00F9.
//   RutSensorStatus  byte 1 bits 4-7  status of the latest measurement (SensorHealth::last_status)
//                    bits 16..23   health flags, one bit each in SensorHealth's order: no camera,
//                                  stale frames, calibration invalid, low texture, frame drops,
//                                  CAN transmit drops, bus off, recording error
//                    bits 24..39   frame rate  0.01 Hz   0..655.34 Hz
//                    bits 40..63   dropped frames (count since start) 0..16777214
//   RutSegment       one closed segment of the track (core/track.hpp, trafficability/): sent when it closes
//                    byte 1 bits 4-7  advisory (Advisory number: 0 UNKNOWN, 1 GO, 2 CAUTION, 3 NO_GO)
//                    bits 16..35   segment end    0.01 m    0..10485.74 m along the track
//                    bits 36..47   mean depth     0.1 mm    0..409.4 mm (over its Ok measurements)
//                    bits 48..59   P95 depth      0.1 mm    0..409.4 mm
//                    bits 60..63   worst status (RutStatus number; 15 = no measurement on it)
//   RutSegmentStats  sent right after RutSegment with the same counter; byte 1 bits 4-7 the advisory
//                    bits 16..27   max depth      0.1 mm    0..409.4 mm
//                    bits 28..35   refused        0.4 %     0..100 % of its measurements not Ok
//                    bits 36..47   frames         1         0..4094 measurements placed on it
//                    bits 48..63   soil strength  0.1 (the configured units, kPa)  0..6553.4
//                    Worked example: segment 12 (12..13 m), advisory CAUTION, mean 85.0, P95 93.4 mm, worst
//                    OK, counter 0: RutSegment bytes 1..7 = 20 14 05 20 35 A6 03 (end 13.00 m: 1300 =
//                    0x00514; mean 850 = 0x352; P95 934 = 0x3A6; worst 0) after its CRC in byte 0.
//   RutSoftwareVersion  what software runs (core/software_version.hpp); the status frames' companion, sent
//                    with the first status frame and then once a second; own counter
//                    byte 1 bits 4-7  package revision 0..14 (the Debian revision: 0.1.0-1 -> 1)
//                    bits 16..23   version major 0..254
//                    bits 24..31   version minor 0..254
//                    bits 32..39   version patch 0..254
//                    bit 40        modified: built from a checkout with changes not committed
//                    bit 41        commit unknown: not built from a git checkout (the commit is all ones)
//                    bits 42..43   0
//                    bits 44..63   the git commit's first five hex digits as a number, most significant
//                                  digit first: commit a5905c3... -> 0xA5905
//                    Worked example: version 0.1.0-1 from commit a5905c3 with no changes, counter 0:
//                    byte 1 0x10 (revision 1, counter 0); bytes 2..4 00 01 00; byte 5 0x50 (flags clear,
//                    bits 44..47 the commit's low digit 5); byte 6 0x90, byte 7 0xA5 (the rest of 0xA5905);
//                    CRC over 5F FF 10 00 01 00 50 90 A5 = 0x3B. In candump: 18FF5FA0#3B100001005090A5.
// Values outside a signal's range saturate to its end (quality in 0..1 maps to 0..100 %). A value that
// is not available is sent as all ones in the signal's bits (the J1939 convention): every measurement
// field when status != Ok, and any non-finite field; a frame rate that is not finite.
#include <array>
#include <cstdint>
#include <string>

#include "can/can_frame.hpp"
#include "core/rut_measurement.hpp"
#include "core/sensor_health.hpp"
#include "core/software_version.hpp"
#include "core/track.hpp"

namespace rutd {

struct CanIdConfig {
  bool extended = true;                     // 29-bit J1939 identifiers; false: the 11-bit identifiers below
  std::uint8_t source_address = 0xA0;       // J1939 source address, 0x00..0xFD
  std::uint8_t priority = 6;                // J1939 priority, 0 (highest) .. 7
  std::uint32_t measurement1_pgn = 0xFF50;  // PDU2 PGNs (PF >= 0xF0), 0..0x3FFFF
  std::uint32_t measurement2_pgn = 0xFF51;
  std::uint32_t status_pgn = 0xFF52;
  std::uint32_t conditions_pgn = 0xFF53;
  std::uint32_t segment_pgn = 0xFF54;
  std::uint32_t segment_stats_pgn = 0xFF55;
  std::uint32_t motion_pgn = 0xFF56;
  std::uint32_t uplink_pgn = 0xFF57;
  std::uint32_t version_pgn = 0xFF5F;
  std::uint32_t measurement1_id_11bit = 0x350;  // 0..0x7FF
  std::uint32_t measurement2_id_11bit = 0x351;
  std::uint32_t status_id_11bit = 0x352;
  std::uint32_t conditions_id_11bit = 0x353;
  std::uint32_t segment_id_11bit = 0x354;
  std::uint32_t segment_stats_id_11bit = 0x355;
  std::uint32_t motion_id_11bit = 0x356;
  std::uint32_t uplink_id_11bit = 0x357;
  std::uint32_t version_id_11bit = 0x35F;
};

// Empty if `ids` is usable, else what is wrong, naming the field (for the configuration loader).
std::string check_can_id_config(const CanIdConfig& ids);

// The 29-bit J1939 identifier for a PGN: priority << 26 | pgn << 8 | source address.
constexpr std::uint32_t j1939_id(std::uint8_t priority, std::uint32_t pgn, std::uint8_t source_address) {
  return (static_cast<std::uint32_t>(priority) << 26) | (pgn << 8) | source_address;
}

// E2E Data IDs (see above).
inline constexpr std::uint16_t kMeasurement1DataId = 0xFF50;
inline constexpr std::uint16_t kMeasurement2DataId = 0xFF51;
inline constexpr std::uint16_t kStatusDataId = 0xFF52;
inline constexpr std::uint16_t kConditionsDataId = 0xFF53;
inline constexpr std::uint16_t kSegmentDataId = 0xFF54;
inline constexpr std::uint16_t kSegmentStatsDataId = 0xFF55;
inline constexpr std::uint16_t kMotionDataId = 0xFF56;
inline constexpr std::uint16_t kUplinkDataId = 0xFF57;
inline constexpr std::uint16_t kVersionDataId = 0xFF5F;

class CanEncoder {  // not thread-safe: one publisher thread owns it. Keeps the rolling counters.
 public:
  // Throws std::invalid_argument with check_can_id_config's message if `ids` is not usable.
  explicit CanEncoder(CanIdConfig ids = {});

  // Fills out[0] (RutMeasurement1) and out[1] (RutMeasurement2) for one measurement and returns the
  // number of frames filled (2). Advances the measurement counter.
  int encode_measurement(const RutMeasurement& m, std::array<CanFrame, 2>& out) noexcept;

  // The RutConditions frame of the measurement last passed to encode_measurement (its counter value):
  // what the frame checks saw, whatever the status. Send it right after that measurement's frames.
  CanFrame encode_conditions(const RutMeasurement& m) const noexcept;

  // The RutMotion frame of the measurement last passed to encode_measurement (its counter value): the
  // vehicle's motion and the position fix in force at its capture time.
  CanFrame encode_motion(const VehicleMotion& motion, const GeoFix& position) const noexcept;

  // The RutUplinkStatus frame. Advances its own counter.
  CanFrame encode_uplink(const UplinkState& u) noexcept;

  // The RutSensorStatus frame. Advances the status counter.
  CanFrame encode_status(const SensorHealth& h) noexcept;

  // RutSegment (out[0]) and RutSegmentStats (out[1]) of a closed segment; returns 2. Advances the segment
  // counter.
  int encode_segment(const Segment& s, std::array<CanFrame, 2>& out) noexcept;

  // The RutSoftwareVersion frame. Advances its own counter.
  CanFrame encode_version(const SoftwareVersion& v) noexcept;

  const CanIdConfig& ids() const noexcept { return ids_; }

 private:
  CanFrame make_frame(std::uint32_t pgn, std::uint32_t id_11bit) const noexcept;

  CanIdConfig ids_;
  std::uint8_t measurement_counter_ = 0;
  std::uint8_t last_measurement_counter_ = 0;
  std::uint8_t status_counter_ = 0;
  std::uint8_t version_counter_ = 0;
  std::uint8_t segment_counter_ = 0;
  std::uint8_t uplink_counter_ = 0;
};

}  // namespace rutd
