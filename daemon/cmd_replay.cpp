// rutd replay DIR: measures every pair of a recording, as fast as it can, and writes one CSV line per
// pair (and the CAN frames that would have been sent, in candump format). Output is flushed per line so
// a failure part-way keeps everything measured before it; a pair that cannot be read is reported and
// skipped, and the command then exits 1. With --plots, PNG plots of chosen pairs and of the whole run are
// written by the plot sink's thread (losslessly: replay waits for it rather than drop a plot).
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>

#include <spdlog/spdlog.h>

#include "can/can_encoder.hpp"
#include "can/candump_log.hpp"
#include "core/input_error.hpp"
#include "daemon/commands.hpp"
#include "daemon/measure_options.hpp"
#include "daemon/progress.hpp"
#include "daemon/run_summary.hpp"
#include "plots/plot_sink.hpp"
#include "recording/measurement_csv.hpp"
#include "recording/recording.hpp"

namespace rutd {
namespace {

struct ReplayOptions {
  std::string dir;
  std::string out;      // empty or "-": stdout
  std::string candump;  // empty: none
  std::string can_interface = "can0";
  std::string plots;  // empty: none
  std::uint64_t plot_every = 0;
  MeasureOptions measure;
};

// Pairs listed in DIR/frames.csv (lines after the header), for the progress line; 0 when unknown.
std::uint64_t count_pairs(const std::string& dir) {
  std::ifstream in(dir + "/frames.csv");
  std::string line;
  std::uint64_t n = 0;
  while (std::getline(in, line)) n += line.empty() ? 0 : 1;
  return n > 0 ? n - 1 : 0;
}

std::ostream& open_output(const std::string& path, std::ofstream& file, const char* option) {
  if (path.empty() || path == "-") return std::cout;
  file.open(path, std::ios::out | std::ios::trunc);
  if (!file) throw InputError(path, option, "cannot open for writing");
  return file;
}

int run_replay(const ReplayOptions& o) {
  ReplaySource reader(o.dir);  // throws InputError for a bad folder, calibration or header
  const MeasurerConfig config = resolve_measure_options(o.measure, reader.calibration().image_size);
  StereoMeasurer measurer(reader.calibration(), config);

  std::ofstream csv_file, can_file;
  MeasurementCsvWriter csv(open_output(o.out, csv_file, "--out"), /*flush_each_line=*/true);
  std::unique_ptr<CandumpLogWriter> candump;
  CanEncoder encoder;
  if (!o.candump.empty())
    candump = std::make_unique<CandumpLogWriter>(open_output(o.candump, can_file, "--candump"), o.can_interface);

  std::unique_ptr<PlotSink> plots;
  if (!o.plots.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(o.plots, ec);
    if (ec) throw InputError(o.plots, "--plots", "cannot create the folder: " + ec.message());
    PlotConfig pc;
    pc.dir = o.plots;
    pc.every = o.plot_every;
    pc.min_interval_s = 0;
    pc.series_period_s = 0;
    pc.lossless = true;
    try {
      plots = std::make_unique<PlotSink>(pc, PlotContext::from(reader.calibration(), measurer));
    } catch (const std::invalid_argument& e) {
      throw InputError(o.plots, "--plots", e.what());
    }
  }

  RunSummary summary;
  // The stages one after the other (StereoMeasurer::measure does the same), keeping the strip, the
  // disparity and the cross-section of each pair for the plots.
  FrameWork work;
  MatchContext context = measurer.make_match_context();
  // Which device computes (the GPU engine's, or the CPU and why), again at the end if that changed.
  const std::string device = context.engine->device();
  spdlog::info("replaying {} with engine {}{} on {}", o.dir, to_string(config.engine), config.dic ? " + DIC" : "",
               device);
  RutWorkspace rut_ws;
  StereoFrame& frame = work.frame;
  std::array<CanFrame, 2> frames{};
  std::uint64_t unreadable = 0, done = 0;
  ProgressLine progress("replay", count_pairs(o.dir));
  for (;;) {
    progress.update(done++);
    const SourceStatus status = reader.next(frame);
    if (status == SourceStatus::EndOfStream) break;
    if (status != SourceStatus::Ok) {
      // One bad pair (a corrupt image, a malformed line) must not cost the rest of a long recording:
      // report it, go on with the next line, and fail the command at the end.
      progress.clear();
      spdlog::error("{}", reader.error_message());
      ++unreadable;
      continue;
    }
    if (measurer.rectify(work)) {
      measurer.match(work, context);
      measurer.extract(work, rut_ws);
    }
    const RutMeasurement& m = work.measurement;
    summary.add(m, work.diag);
    if (plots) plots->publish(work, SensorHealth{});
    if (!csv.write(frame.seq, frame.t_ns, m)) {
      // Measuring on with nowhere to put the result is pointless: stop, keeping the rows written so far.
      progress.clear();
      spdlog::error("{}: cannot write the measurement of seq {} (disk full or output closed); {} rows written",
                    o.out.empty() ? std::string("standard output") : o.out, frame.seq, csv.rows_written());
      return 1;
    }
    if (candump) {
      const int n = encoder.encode_measurement(m, frames);
      for (int i = 0; i < n; ++i) candump->write(frames[static_cast<std::size_t>(i)], frame.t_ns);
      candump->write(encoder.encode_conditions(m), frame.t_ns);
    }
  }
  progress.clear();
  if (context.engine->device() != device)
    spdlog::warn("the engine left {} during the replay: now on {}", device, context.engine->device());
  if (plots) {
    const PlotSinkStats ps = plots->finish();
    spdlog::info("plots: {} files written to {} ({} pairs plotted)", ps.files_written, o.plots, ps.frames_plotted);
    if (ps.errors > 0) {
      spdlog::error("plots: {} files could not be written, the last: {}", ps.errors, ps.last_error);
      return 1;
    }
  }
  if (reader.truncated_tail())
    spdlog::warn("{}: the last line of frames.csv was cut off; replayed up to the last complete pair", o.dir);
  summary.log();
  if (unreadable > 0) {
    spdlog::error("{}: {} pairs could not be read (see above); the other pairs were measured", o.dir, unreadable);
    return 1;
  }
  return 0;
}

}  // namespace

void add_replay_command(CLI::App& app, int& exit_code) {
  auto options = std::make_shared<ReplayOptions>();
  CLI::App* cmd = app.add_subcommand("replay", "Measure every stereo pair of a recording folder");
  cmd->add_option("dir", options->dir, "Recording folder (calibration.yaml, frames.csv, left/, right/)")->required();
  cmd->add_option("--out", options->out, "Measurement CSV file (default: standard output)");
  cmd->add_option("--candump", options->candump, "Also write the CAN frames that would be sent, candump -L format");
  cmd->add_option("--can-interface", options->can_interface, "Interface name written in the candump log")
      ->capture_default_str();
  cmd->add_option("--plots", options->plots,
                  "Write PNG plots into this folder: cross-section, disparity and rectified image of chosen pairs, "
                  "depth/width/quality over the run (series.png)");
  cmd->add_option("--plot-every", options->plot_every,
                  "Also plot every N-th pair (the first pair of each status change is always plotted)")
      ->check(CLI::Range(0, 1000000));
  add_measure_options(*cmd, options->measure);
  cmd->callback([options, &exit_code] { exit_code = run_replay(*options); });
}

}  // namespace rutd
