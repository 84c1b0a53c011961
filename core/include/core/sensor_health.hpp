#pragma once
// What the sensor says about itself, whether or not a depth could be measured: the pipeline fills it
// every status period, the sinks that know more (CAN transmit drops, bus off, recording errors) add
// their flags, and the CAN status frame carries it (can/can_encoder.hpp, config/rutd.dbc: one bit per
// flag, in this order).
#include <cstdint>

#include "core/rut_measurement.hpp"

namespace rutd {

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
};

}  // namespace rutd
