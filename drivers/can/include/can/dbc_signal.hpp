#pragma once
// One signal's layout read from a DBC file (Vector's CAN database format, as config/rutd.dbc and
// canmatrix's j1939.dbc are written), for the vehicle speed from a signal the vehicle maker names:
//
//   BO_ 2364543233 WheelSpeeds: 8 ABS              message: identifier (bit 31 set: 29-bit), name
//    SG_ VehSpd : 8|16@1+ (0.01,0) [0|655.35] "km/h" rutd
//                 start|length@byte order (1 Intel/little-endian, 0 Motorola) sign (+/-), (factor,offset)
//
// Only BO_ and SG_ lines are read; multiplexed signals are refused. The unit converts to mm/s: km/h,
// m/s, mm/s, mph (any other unit is refused). J1939's not-available and error ranges apply when the
// message's identifier is 29-bit (a J1939 parameter group); for 11-bit messages every value is valid.
#include <string>

#include "can/vehicle_speed.hpp"

namespace rutd {

// Throws std::invalid_argument naming the file, message or signal at fault.
SpeedSignalLayout load_dbc_speed_signal(const std::string& path, const std::string& message, const std::string& signal);

}  // namespace rutd
