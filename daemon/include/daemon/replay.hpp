#pragma once
// rutd replay as a function, for the commands that measure recordings (replay, map).
#include <cstdint>
#include <string>

#include "daemon/measure_options.hpp"
#include "gps/gps_config.hpp"

namespace rutd {

struct ReplayOptions {
  std::string dir;
  std::string out;      // empty or "-": stdout
  std::string candump;  // empty: none
  std::string can_interface = "can0";
  std::string plots;  // empty: none
  std::uint64_t plot_every = 0;
  bool positions = false;  // join the recording's gps.jsonl; the CSV gets the position columns
  double max_fix_age_ms = GpsConfig{}.max_fix_age_ms;
  std::string config;    // its trafficability section; empty: the embedded default
  std::string segments;  // segment CSV; empty: none
  MeasureOptions measure;
};

// Measures every pair of the recording into the sinks the options name. Returns the exit status (0, or 1
// when pairs could not be read or an output failed); throws InputError for an unusable recording or output.
int replay_recording(const ReplayOptions& options);

}  // namespace rutd
