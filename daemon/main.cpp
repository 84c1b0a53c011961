// rutd: real-time tyre rut depth from a stereo camera pair. main() only wires the commands; each
// command lives in its own file and calls the libraries. Error policy at this level: an error found at
// start-up is printed once (naming the file and the field) and the process exits non-zero: 2 for bad
// input (configuration, calibration, recordings), which no restart can mend, so the unit does not restart
// on it (RestartPreventExitStatus=2); 1 when the system refused something rutd needs (std::system_error:
// a CAN interface not there yet, a disk not mounted), which may come, so systemd restarts rutd.
#include <exception>
#include <iostream>
#include <system_error>

#include <CLI/CLI.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "core/input_error.hpp"
#include "daemon/build_info.hpp"
#include "daemon/commands.hpp"

int main(int argc, char** argv) {
  // Logs go to stderr: stdout carries data (CSV, candump) that other programs read.
  spdlog::set_default_logger(spdlog::stderr_color_mt("rutd"));
  spdlog::set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ %v");

  CLI::App app{"rutd: real-time tyre rut depth from a calibrated stereo camera pair"};
  // The package version and the commit: what a field engineer reads off a vehicle PC (the CAN bus carries
  // the same in RutSoftwareVersion).
  app.set_version_flag("--version", "rutd " + rutd::version_line(), "Print the package version and git commit");
  app.require_subcommand(1);
  int exit_code = 0;
  rutd::add_run_command(app, exit_code);
  rutd::add_synth_command(app, exit_code);
  rutd::add_replay_command(app, exit_code);
  rutd::add_calibrate_command(app, exit_code);
  rutd::add_bench_command(app, exit_code);
  rutd::add_record_command(app, exit_code);
  rutd::add_cameras_command(app, exit_code);
  rutd::add_map_command(app, exit_code);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const rutd::InputError& e) {
    std::cerr << "rutd: error: " << e.what() << '\n';
    return 2;
  } catch (const std::system_error& e) {
    std::cerr << "rutd: error: " << e.what() << '\n';
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "rutd: error: " << e.what() << '\n';
    return 2;
  }
  return exit_code;
}
