#pragma once
// rutd's configuration: one YAML file loaded into one typed struct, with defaults, checked at start-up.
// Every error names the file, the line and the key ("rutd.yaml: line 12, measurement.engine: ...").
// `rutd run` without --config uses the embedded default (config/rutd.yaml, compiled in), which runs on any
// machine: the synthetic cameras at their real frame rate, CAN frames on stdout in candump format.
#include <cstdint>
#include <string>
#include <vector>

#include "camera/aravis_config.hpp"
#include "can/can_encoder.hpp"
#include "can/vehicle_speed.hpp"
#include "gps/gps_config.hpp"
#include "measurement/measurer.hpp"
#include "plots/plot_sink.hpp"
#include "runtime/realtime_pipeline.hpp"
#include "synthetic/synthetic_renderer.hpp"
#include "trafficability/odometer.hpp"
#include "trafficability/segment_tracker.hpp"
#include "uplink/uplink_config.hpp"
#include "web/web_config.hpp"

namespace rutd {

enum class SourceKind { Synthetic, Replay, Aravis };

struct ReplaySourceConfig {
  std::string dir;    // recording folder
  bool paced = true;  // play at the recording's own timestamps (false: as fast as it reads)
  bool loop = false;  // start again at the end
};

// The `sinks` section: where measurements go.
struct SinkConfig {
  std::string socketcan;                    // CAN interface (e.g. can0); empty: off
  std::string candump = "-";                // candump -L log file; "-": standard output; empty: off
  std::string can_interface_name = "can0";  // interface name written in the candump log
  std::string csv;                          // measurement CSV file; empty: off
  bool csv_positions = false;               // the CSV gets the position columns (needs gps.enabled)
  // sinks.plots: off by default. When on, PNG plots of chosen frames and of the run go to plots.dir from
  // the plot sink's own thread (rate-limited, dropped when behind, never blocking).
  bool plots_enabled = false;
  PlotConfig plots = [] {
    PlotConfig p;
    p.min_interval_s = 5.0;
    p.series_period_s = 60.0;
    return p;
  }();
};

// The `trafficability` section: the vehicle's speed from the CAN bus, segments of the track, soil
// strength and the advisory (trafficability/, can/vehicle_speed.hpp). Off while speed.socketcan is empty
// (then every frame's motion says NoSource and no segment is made), except in `rutd replay` of a
// recording that has a vehicle.log.
struct TrafficabilityConfig {
  std::string socketcan;  // trafficability.speed.socketcan: interface to receive the speed on; empty: off
  VehicleSpeedConfig speed;
  std::string dbc, dbc_message, dbc_signal;  // speed.message: dbc: the signal's file, message and name
  OdometerConfig odometer;                   // speed.max_age_ms
  SegmentConfig segments;                    // segment_length_m, advisory, soil, damage
  std::string segments_csv;                  // segment CSV file; empty: off
};

struct LoggingConfig {
  std::string level = "info";  // trace, debug, info, warn, error
  double stats_period_s = 10;  // period of the rate and latency log lines
};

struct RutdConfig {
  std::string file = "(embedded default)";  // where this came from, for messages
  SourceKind source = SourceKind::Synthetic;
  SyntheticRendererConfig synthetic;
  // source.synthetic.cycle_frames: > 0 renders that many pairs once at start and plays them over and over
  // at the synthetic fps, as a camera delivers (rendering a 640x480 pair costs tens of ms of CPU that a
  // camera does not); 0 renders every pair live, with its exact truth.
  int synthetic_cycle_frames = 0;
  ReplaySourceConfig replay;
  AravisSourceConfig aravis;
  // source.record: a recording tee. The source's raw pairs are also recorded into this new folder
  // (DESIGN.md Formats) on their way to the pipeline; empty: off.
  std::string record;
  // source.record_buffer: pairs that may wait for the disk (FrameRecorderConfig::capacity, 1..1024); a
  // pair that finds every slot taken is dropped and counted. 30 rides out a one-second disk stall at 30 fps.
  int record_buffer = 30;
  std::string calibration;  // calibration file; synthetic and replay sources bring their own
  MeasurerConfig measurement;
  CanIdConfig can;
  SinkConfig sinks;
  // The `pipeline` section: max_frame_age_ms, status_period_ms, cpu_affinity (one CPU per stage thread,
  // in Stage order; entries past the last stage are ignored) and realtime_priority (SCHED_FIFO of every
  // stage thread) land in max_frame_age, status_period and threads. The daemon sets the rest.
  PipelineConfig pipeline;
  TrafficabilityConfig trafficability;
  // The `gps` section: positions from gpsd joined to every published pair (off by default).
  GpsConfig gps;
  // The `uplink` section: segments and health to an MQTT broker, store and forward (off by default).
  UplinkConfig uplink;
  // The `web` section: the live view for installing and checking the cameras (off by default).
  WebConfig web;
  LoggingConfig logging;
};

// Parses YAML text; `file` is used in messages. Throws InputError(file, "line N, KEY", message) for
// unknown keys, wrong types, impossible values and contradictions, and for the keys of older releases,
// naming the key that replaced them (kMovedKeys).
RutdConfig parse_config(const std::string& yaml_text, const std::string& file);
// Reads and parses a file; an unreadable file is an InputError too.
RutdConfig load_config(const std::string& path);
// The embedded default configuration (the text of config/rutd.yaml).
const std::string& default_config_text();

}  // namespace rutd
