#pragma once
// What the sensor says about itself, whether or not a depth could be measured: the pipeline fills it
// every status period, the sinks that know more (CAN transmit drops, bus off, recording errors) add
// their flags, and the CAN status frame carries it (can/can_encoder.hpp, config/rutd.dbc: one bit per
// flag, in this order).
#include <cstdint>

#include "core/rut_measurement.hpp"

namespace rutd {

// The fleet uplink's state as the CAN status tells it (RutUplinkStatus; drivers/uplink fills the figures,
// the daemon copies them in at every status). The flags are for the last status period.
struct UplinkState {
  bool enabled = false;          // false: no uplink configured, nothing to tell
  bool link_up = false;          // connected to the broker and accepted
  std::uint64_t queued = 0;      // messages waiting for the broker's acknowledgement
  double oldest_unsent_s = 0.0;  // age of the oldest of them
  bool send_errors = false;      // a send or connection attempt failed
  bool queue_error = false;      // a write to the queue failed (disk full)
  bool dropped = false;          // messages were dropped: beyond the queue's bound, or not queued
};

struct SensorHealth {
  bool no_camera = false;
  bool stale_frames = false;
  bool calibration_invalid = false;
  bool low_texture = false;
  bool frame_drops = false;
  bool can_tx_drops = false;
  bool bus_off = false;
  bool recording_error = false;
  double frame_rate_hz = 0.0;
  std::uint32_t dropped_frames = 0;
  RutStatus last_status = RutStatus::NoMeasurement;
  UplinkState uplink;
};

}  // namespace rutd
