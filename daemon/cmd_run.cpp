// rutd run: measure continuously from a live source and publish every measurement as CAN frames, plus a
// status frame at a fixed rate that carries the sensor's health even when nothing can be measured.
// With no options it runs the embedded default: the synthetic cameras at their real frame rate, the CAN
// frames printed on stdout in candump format, logs on stderr. It stops cleanly on SIGINT or SIGTERM.
#include <spdlog/spdlog.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <fstream>
#include <iostream>
#include <memory>

#include "daemon/commands.hpp"
#include "daemon/measure_options.hpp"
#include "daemon/run_summary.hpp"
#include "daemon/synth_options.hpp"
#include "drivers/can_encoder.hpp"
#include "drivers/candump_log.hpp"
#include "drivers/input_error.hpp"
#include "drivers/synthetic_source.hpp"

namespace rutd {
namespace {

// Set from the signal handler; lock-free atomics are async-signal-safe.
std::atomic<bool> g_stop_requested{false};
static_assert(std::atomic<bool>::is_always_lock_free);

extern "C" void on_stop_signal(int) { g_stop_requested.store(true, std::memory_order_relaxed); }

void install_stop_handlers() {
  struct sigaction action {};
  action.sa_handler = on_stop_signal;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

struct RunOptions {
  std::uint64_t frames = 0;  // 0: until stopped
  std::string candump = "-";
  std::string can_interface = "can0";
  double status_period_ms = 100.0;
  SynthOptions scene;
  MeasureOptions measure;
};

std::int64_t monotonic_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

int run_live(const RunOptions& o) {
  SyntheticSource source(resolve_synth_options(o.scene));
  const MeasurerConfig config = resolve_measure_options(o.measure, source.calibration().image_size);
  StereoMeasurer measurer(source.calibration(), config);

  std::ofstream file;
  std::ostream* out = &std::cout;
  if (o.candump != "-") {
    file.open(o.candump, std::ios::out | std::ios::trunc);
    if (!file) throw InputError(o.candump, "--candump", "cannot open for writing");
    out = &file;
  }
  CandumpLogWriter candump(*out, o.can_interface);
  CanEncoder encoder;
  install_stop_handlers();
  spdlog::info("measuring from the synthetic cameras with engine {}{}; CAN frames to {}", to_string(config.engine),
               config.dic ? " + DIC" : "", o.candump == "-" ? "stdout" : o.candump);

  RunSummary summary;
  StereoFrame frame;
  std::array<CanFrame, 2> frames{};
  SensorHealth health;
  std::int64_t last_status_ns = 0, rate_window_start_ns = monotonic_ns();
  std::uint64_t rate_window_pairs = 0;
  const auto status_period_ns = static_cast<std::int64_t>(o.status_period_ms * 1e6);
  while (!g_stop_requested.load(std::memory_order_relaxed) && (o.frames == 0 || summary.pairs() < o.frames)) {
    const SourceStatus status = source.next(frame);
    health.no_camera = status == SourceStatus::Error;
    if (status == SourceStatus::Ok) {
      const RutMeasurement m = measurer.measure(frame.left, frame.right);
      summary.add(m, measurer.diagnostics());
      health.last_status = m.status;
      ++rate_window_pairs;
      const int n = encoder.encode_measurement(m, frames);
      const std::int64_t now = monotonic_ns();
      for (int i = 0; i < n; ++i) candump.write(frames[static_cast<std::size_t>(i)], now);
    } else if (status == SourceStatus::Error) {
      spdlog::error("{}", source.error_message());
    }
    const std::int64_t now = monotonic_ns();
    if (now - last_status_ns >= status_period_ns) {
      if (now > rate_window_start_ns)
        health.frame_rate_hz = rate_window_pairs * 1e9 / static_cast<double>(now - rate_window_start_ns);
      rate_window_start_ns = now;
      rate_window_pairs = 0;
      candump.write(encoder.encode_status(health), now);
      last_status_ns = now;
    }
    out->flush();
  }
  summary.log();
  return 0;
}

}  // namespace

void add_run_command(CLI::App& app, int& exit_code) {
  auto options = std::make_shared<RunOptions>();
  CLI::App* cmd = app.add_subcommand("run", "Measure continuously and publish rut depth as CAN frames");
  cmd->add_option("--frames", options->frames, "Stop after this many stereo pairs (0: run until SIGINT/SIGTERM)")
      ->capture_default_str();
  cmd->add_option("--candump", options->candump, "Where CAN frames go, candump -L format ('-': standard output)")
      ->capture_default_str();
  cmd->add_option("--can-interface", options->can_interface, "Interface name written in the candump log")
      ->capture_default_str();
  add_synth_options(*cmd, options->scene);
  add_measure_options(*cmd, options->measure);
  cmd->callback([options, &exit_code] { exit_code = run_live(*options); });
}

}  // namespace rutd
