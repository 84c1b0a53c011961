#pragma once
// The rutd sub-commands. Each add_*_command registers its options and a callback that runs the command
// and stores its exit status in `exit_code`. Callbacks throw InputError for bad input at start-up.
#include <CLI/CLI.hpp>

#include "daemon/run_injection.hpp"

namespace rutd {

// measure live, publish CAN frames; `injection`: tests only (daemon/run_injection.hpp)
void add_run_command(CLI::App& app, int& exit_code, RunInjection injection = {});
void add_synth_command(CLI::App& app, int& exit_code);      // render a synthetic recording with truth
void add_replay_command(CLI::App& app, int& exit_code);     // measure a recording
void add_calibrate_command(CLI::App& app, int& exit_code);  // chessboard pairs to a calibration file
void add_bench_command(CLI::App& app, int& exit_code);      // pipeline rate and latency figures
void add_record_command(CLI::App& app, int& exit_code);     // record the configured source, no measuring
void add_cameras_command(CLI::App& app, int& exit_code);    // list cameras and their features
void add_map_command(CLI::App& app, int& exit_code);        // map measured ruts over passes (GeoJSON, PNG, CSV)

}  // namespace rutd
