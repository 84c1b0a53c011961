#pragma once
// Settings of the gpsd position source (the `gps` section of the configuration).
#include <string>

namespace rutd {

struct GpsConfig {
  bool enabled = false;  // off by default: a bench has no receiver
  std::string host = "127.0.0.1";
  std::string port = "2947";  // gpsd's port
  // A fix older than this at a frame's capture time is stale: the frame gets no position (Mode::NoFix).
  // gpsd reports 1 to 10 times a second; a receiver that stops reporting must not pin old positions on
  // new ground.
  double max_fix_age_ms = 1500;
  // Reconnection to a gpsd that is absent or went away: the wait doubles from min to max and stays there.
  double reconnect_min_ms = 250;
  double reconnect_max_ms = 5000;
  // A report whose fix time moves against the receive time by more than this is a time jump (counted; the
  // position is still joined by receive time, which never jumps).
  double time_jump_s = 2.0;
};

}  // namespace rutd
