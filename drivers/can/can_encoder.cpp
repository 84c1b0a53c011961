#include "can/can_encoder.hpp"

#include <algorithm>
#include <cmath>
#include <span>
#include <stdexcept>
#include <utility>

#include "can/crc8.hpp"

namespace rutd {
namespace {

constexpr std::uint8_t kFrameLen = 8;
constexpr std::uint8_t kCounterModulo = 15;  // counter runs 0..14 (E2E profile 1)
constexpr std::uint8_t kUnknownStatus = 0x0F;

// One unsigned little-endian signal: physical = raw * factor + offset, valid physical range [min, max].
struct Signal {
  int start_bit;
  int bits;
  double factor;
  double offset;
  double min;
  double max;
};

constexpr Signal kDepth{16, 12, 0.1, 0.0, 0.0, 400.0};
constexpr Signal kWidth{28, 12, 0.25, 0.0, 0.0, 1000.0};
constexpr Signal kQuality{40, 8, 0.4, 0.0, 0.0, 100.0};
constexpr Signal kArea{48, 16, 10.0, 0.0, 0.0, 655340.0};
constexpr Signal kLeftPile{16, 12, 0.1, 0.0, 0.0, 200.0};
constexpr Signal kRightPile{28, 12, 0.1, 0.0, 0.0, 200.0};
constexpr Signal kSlope{40, 12, 0.02, -30.0, -30.0, 30.0};
constexpr Signal kCenterX{52, 12, 0.5, -1000.0, -1000.0, 1000.0};
constexpr Signal kFrameRate{24, 16, 0.01, 0.0, 0.0, 655.34};
constexpr int kConditionsStartBit = 16;
constexpr Signal kUncertainty{24, 12, 0.01, 0.0, 0.0, 40.94};
constexpr Signal kVerticalDisparity{36, 12, 0.01, -20.0, -20.0, 20.94};
constexpr Signal kLeftObstructed{48, 8, 0.4, 0.0, 0.0, 100.0};
constexpr Signal kRightObstructed{56, 8, 0.4, 0.0, 0.0, 100.0};
constexpr Signal kSegmentEnd{16, 20, 0.01, 0.0, 0.0, 10485.74};
constexpr Signal kSegmentMean{36, 12, 0.1, 0.0, 0.0, 409.4};
constexpr Signal kSegmentP95{48, 12, 0.1, 0.0, 0.0, 409.4};
constexpr int kSegmentWorstStartBit = 60;
constexpr Signal kSegmentMax{16, 12, 0.1, 0.0, 0.0, 409.4};
constexpr Signal kSegmentRefused{28, 8, 0.4, 0.0, 0.0, 100.0};
constexpr Signal kSegmentFrames{36, 12, 1.0, 0.0, 0.0, 4094.0};
constexpr Signal kSegmentStrength{48, 16, 0.1, 0.0, 0.0, 6553.4};
constexpr Signal kMotionSpeed{16, 16, 0.01, -320.0, -320.0, 335.34};  // km/h
constexpr Signal kMotionDistance{32, 24, 0.01, 0.0, 0.0, 167772.14};  // m
constexpr int kMotionFixStartBit = 56;
constexpr int kMotionReservedStartBit = 60;
constexpr int kUplinkQueuedStartBit = 16;
constexpr int kUplinkQueuedBits = 24;
constexpr Signal kUplinkOldest{40, 16, 1.0, 0.0, 0.0, 65534.0};  // s
constexpr int kUplinkFlagsStartBit = 56;
constexpr int kFlagsStartBit = 16;
constexpr int kDroppedStartBit = 40;
constexpr int kDroppedBits = 24;
constexpr int kVersionMajorStartBit = 16;  // then minor, patch: 8 bits each
constexpr int kVersionModifiedBit = 40;
constexpr int kVersionCommitUnknownBit = 41;
constexpr int kVersionCommitStartBit = 44;
constexpr int kVersionCommitBits = 20;

constexpr std::uint64_t all_ones(int bits) { return (std::uint64_t{1} << bits) - 1; }

void put_bits(std::array<std::uint8_t, 8>& data, int start_bit, int bits, std::uint64_t raw) noexcept {
  for (int i = 0; i < bits; ++i) {
    const int bit = start_bit + i;
    const auto mask = static_cast<std::uint8_t>(1U << (bit % 8));
    if ((raw >> i) & 1U) {
      data[static_cast<std::size_t>(bit / 8)] |= mask;
    } else {
      data[static_cast<std::size_t>(bit / 8)] &= static_cast<std::uint8_t>(~mask);
    }
  }
}

// Raw value for a physical one: saturated to [min, max], rounded to the nearest step; all ones when
// the value is not available (not finite, or `available` false).
std::uint64_t to_raw(const Signal& s, double value, bool available) noexcept {
  if (!available || !std::isfinite(value)) return all_ones(s.bits);
  const double clamped = std::fmin(std::fmax(value, s.min), s.max);
  const auto raw = static_cast<std::uint64_t>(std::llround((clamped - s.offset) / s.factor));
  return std::min(raw, all_ones(s.bits) - 1);  // never collide with "not available"
}

void put(std::array<std::uint8_t, 8>& data, const Signal& s, double value, bool available) noexcept {
  put_bits(data, s.start_bit, s.bits, to_raw(s, value, available));
}

std::uint8_t status_nibble(RutStatus status) noexcept {
  const auto v = static_cast<std::uint8_t>(status);
  return v < kRutStatusCount ? v : kUnknownStatus;
}

// Writes the counter and the upper nibble (a status, or the version frame's revision) into byte 1, then
// the CRC into byte 0 (see the header for the layout).
void protect(CanFrame& frame, std::uint16_t data_id, std::uint8_t counter, std::uint8_t nibble) noexcept {
  frame.data[1] = static_cast<std::uint8_t>(((nibble & 0x0FU) << 4) | (counter & 0x0FU));
  const std::array<std::uint8_t, 2> id_bytes{static_cast<std::uint8_t>(data_id & 0xFFU),
                                             static_cast<std::uint8_t>(data_id >> 8)};
  const std::uint8_t crc = crc8_sae_j1850(id_bytes);
  frame.data[0] = crc8_sae_j1850_update(crc, std::span<const std::uint8_t>(frame.data).subspan(1, kFrameLen - 1));
}

std::uint8_t next_counter(std::uint8_t counter) noexcept {
  return static_cast<std::uint8_t>((counter + 1) % kCounterModulo);
}

}  // namespace

std::string check_can_id_config(const CanIdConfig& ids) {
  if (ids.priority > 7) return "priority: must be 0..7";
  if (ids.source_address > 0xFD) return "source_address: 0xFE and 0xFF are not source addresses";
  const std::pair<const char*, std::uint32_t> pgns[] = {{"measurement1_pgn", ids.measurement1_pgn},
                                                        {"measurement2_pgn", ids.measurement2_pgn},
                                                        {"status_pgn", ids.status_pgn},
                                                        {"conditions_pgn", ids.conditions_pgn},
                                                        {"segment_pgn", ids.segment_pgn},
                                                        {"segment_stats_pgn", ids.segment_stats_pgn},
                                                        {"motion_pgn", ids.motion_pgn},
                                                        {"uplink_pgn", ids.uplink_pgn},
                                                        {"version_pgn", ids.version_pgn}};
  for (const auto& [name, pgn] : pgns) {
    if (pgn > 0x3FFFF) return std::string(name) + ": PGN must be 0..0x3FFFF";
    if (((pgn >> 8) & 0xFFU) < 0xF0) return std::string(name) + ": must be a broadcast (PDU2, PF >= 0xF0) PGN";
  }
  const std::pair<const char*, std::uint32_t> ids11[] = {{"measurement1_id_11bit", ids.measurement1_id_11bit},
                                                         {"measurement2_id_11bit", ids.measurement2_id_11bit},
                                                         {"status_id_11bit", ids.status_id_11bit},
                                                         {"conditions_id_11bit", ids.conditions_id_11bit},
                                                         {"segment_id_11bit", ids.segment_id_11bit},
                                                         {"segment_stats_id_11bit", ids.segment_stats_id_11bit},
                                                         {"motion_id_11bit", ids.motion_id_11bit},
                                                         {"uplink_id_11bit", ids.uplink_id_11bit},
                                                         {"version_id_11bit", ids.version_id_11bit}};
  for (const auto& [name, id] : ids11) {
    if (id > 0x7FF) return std::string(name) + ": must be 0..0x7FF";
  }
  return {};
}

CanEncoder::CanEncoder(CanIdConfig ids) : ids_(ids) {
  if (const std::string error = check_can_id_config(ids_); !error.empty()) throw std::invalid_argument(error);
}

CanFrame CanEncoder::make_frame(std::uint32_t pgn, std::uint32_t id_11bit) const noexcept {
  CanFrame frame;
  frame.extended = ids_.extended;
  frame.id = ids_.extended ? j1939_id(ids_.priority, pgn, ids_.source_address) : id_11bit;
  frame.len = kFrameLen;
  return frame;
}

int CanEncoder::encode_measurement(const RutMeasurement& m, std::array<CanFrame, 2>& out) noexcept {
  const bool ok = m.status == RutStatus::Ok;

  CanFrame& first = out[0];
  first = make_frame(ids_.measurement1_pgn, ids_.measurement1_id_11bit);
  put(first.data, kDepth, m.depth_mm, ok);
  put(first.data, kWidth, m.width_mm, ok);
  put(first.data, kQuality, m.quality * 100.0, ok);
  put(first.data, kArea, m.area_mm2, ok);
  protect(first, kMeasurement1DataId, measurement_counter_, status_nibble(m.status));

  CanFrame& second = out[1];
  second = make_frame(ids_.measurement2_pgn, ids_.measurement2_id_11bit);
  put(second.data, kLeftPile, m.left_pile_mm, ok);
  put(second.data, kRightPile, m.right_pile_mm, ok);
  put(second.data, kSlope, m.ground_slope_deg, ok);
  put(second.data, kCenterX, m.center_x_mm, ok);
  protect(second, kMeasurement2DataId, measurement_counter_, status_nibble(m.status));

  last_measurement_counter_ = measurement_counter_;
  measurement_counter_ = next_counter(measurement_counter_);
  return 2;
}

CanFrame CanEncoder::encode_conditions(const RutMeasurement& m) const noexcept {
  CanFrame frame = make_frame(ids_.conditions_pgn, ids_.conditions_id_11bit);
  put_bits(frame.data, kConditionsStartBit, 8, m.conditions);
  put(frame.data, kUncertainty, m.depth_uncertainty_mm, true);
  put(frame.data, kVerticalDisparity, m.vertical_disparity_px, true);
  put(frame.data, kLeftObstructed, m.obstructed_left * 100.0, true);
  put(frame.data, kRightObstructed, m.obstructed_right * 100.0, true);
  protect(frame, kConditionsDataId, last_measurement_counter_, status_nibble(m.status));
  return frame;
}

CanFrame CanEncoder::encode_motion(const VehicleMotion& motion, const GeoFix& position) const noexcept {
  CanFrame frame = make_frame(ids_.motion_pgn, ids_.motion_id_11bit);
  const bool moving_known = motion.state == SpeedState::Ok;
  put(frame.data, kMotionSpeed, motion.speed_mm_s * 3.6e-3, moving_known);
  put(frame.data, kMotionDistance, motion.distance_m, true);
  const auto mode = static_cast<std::uint8_t>(position.mode);
  put_bits(frame.data, kMotionFixStartBit, 4, mode >= 1 && mode <= 3 ? mode : kUnknownStatus);
  put_bits(frame.data, kMotionReservedStartBit, 4, all_ones(4));
  const auto state = static_cast<std::uint8_t>(motion.state);
  protect(frame, kMotionDataId, last_measurement_counter_, state <= 4 ? state : kUnknownStatus);
  return frame;
}

CanFrame CanEncoder::encode_uplink(const UplinkState& u) noexcept {
  CanFrame frame = make_frame(ids_.uplink_pgn, ids_.uplink_id_11bit);
  put_bits(frame.data, kUplinkQueuedStartBit, kUplinkQueuedBits,
           std::min<std::uint64_t>(u.queued, all_ones(kUplinkQueuedBits) - 1));
  put(frame.data, kUplinkOldest, u.oldest_unsent_s, true);
  const bool flags[] = {u.send_errors, u.queue_error, u.dropped};
  for (int i = 0; i < 3; ++i) put_bits(frame.data, kUplinkFlagsStartBit + i, 1, flags[i] ? 1U : 0U);
  put_bits(frame.data, kUplinkFlagsStartBit + 3, 5, all_ones(5));
  protect(frame, kUplinkDataId, uplink_counter_, u.link_up ? 1 : 0);
  uplink_counter_ = next_counter(uplink_counter_);
  return frame;
}

CanFrame CanEncoder::encode_status(const SensorHealth& h) noexcept {
  CanFrame frame = make_frame(ids_.status_pgn, ids_.status_id_11bit);
  const bool flags[] = {h.no_camera,    h.stale_frames, h.calibration_invalid, h.low_texture, h.frame_drops,
                        h.can_tx_drops, h.bus_off,      h.recording_error};
  for (int i = 0; i < 8; ++i) put_bits(frame.data, kFlagsStartBit + i, 1, flags[i] ? 1U : 0U);
  put(frame.data, kFrameRate, h.frame_rate_hz, true);
  put_bits(frame.data, kDroppedStartBit, kDroppedBits,
           std::min<std::uint64_t>(h.dropped_frames, all_ones(kDroppedBits) - 1));
  protect(frame, kStatusDataId, status_counter_, status_nibble(h.last_status));
  status_counter_ = next_counter(status_counter_);
  return frame;
}

int CanEncoder::encode_segment(const Segment& s, std::array<CanFrame, 2>& out) noexcept {
  const auto advisory = static_cast<std::uint8_t>(s.advisory);
  CanFrame& first = out[0];
  first = make_frame(ids_.segment_pgn, ids_.segment_id_11bit);
  put(first.data, kSegmentEnd, s.end_m, true);
  put(first.data, kSegmentMean, s.mean_depth_mm, true);
  put(first.data, kSegmentP95, s.p95_depth_mm, true);
  put_bits(first.data, kSegmentWorstStartBit, 4, s.frames > 0 ? status_nibble(s.worst_status) : kUnknownStatus);
  protect(first, kSegmentDataId, segment_counter_, advisory);

  CanFrame& second = out[1];
  second = make_frame(ids_.segment_stats_pgn, ids_.segment_stats_id_11bit);
  put(second.data, kSegmentMax, s.max_depth_mm, true);
  put(second.data, kSegmentRefused, s.frames > 0 ? 100.0 * s.refused / s.frames : 0.0, s.frames > 0);
  put(second.data, kSegmentFrames, static_cast<double>(s.frames), true);
  put(second.data, kSegmentStrength, s.soil_strength, true);
  protect(second, kSegmentStatsDataId, segment_counter_, advisory);
  segment_counter_ = next_counter(segment_counter_);
  return 2;
}

CanFrame CanEncoder::encode_version(const SoftwareVersion& v) noexcept {
  CanFrame frame = make_frame(ids_.version_pgn, ids_.version_id_11bit);
  const std::uint8_t numbers[] = {v.major, v.minor, v.patch};
  for (int i = 0; i < 3; ++i) put_bits(frame.data, kVersionMajorStartBit + 8 * i, 8, numbers[i]);
  put_bits(frame.data, kVersionModifiedBit, 1, v.modified ? 1U : 0U);
  put_bits(frame.data, kVersionCommitUnknownBit, 1, v.commit_known ? 0U : 1U);
  put_bits(frame.data, kVersionCommitStartBit, kVersionCommitBits,
           v.commit_known ? v.commit_prefix & all_ones(kVersionCommitBits) : all_ones(kVersionCommitBits));
  protect(frame, kVersionDataId, version_counter_, v.revision);
  version_counter_ = next_counter(version_counter_);
  return frame;
}

}  // namespace rutd
