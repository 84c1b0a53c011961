// rutd replay DIR: measures every pair of a recording, as fast as it can, and hands each measurement to
// the same sink classes as `rutd run`: the measurement CSV (MeasurementCsvSink, one write per row), the CAN
// frames in candump format (CanSink, stamped on the recording's clock, with the status frames the vehicle
// would have sent every status period: ReplayStatus), and plots (PlotSink, losslessly: replay waits for
// its thread rather than drop a plot). A pair that cannot be read is reported and skipped, and the
// command then exits 1; an output that cannot be written stops it at once (exit 1), keeping every row
// written before.
#include <csignal>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>

#include <spdlog/spdlog.h>

#include "can/can_sink.hpp"
#include "can/candump_log.hpp"
#include "core/input_error.hpp"
#include "daemon/build_info.hpp"
#include "daemon/commands.hpp"
#include "daemon/config.hpp"
#include "daemon/measure_options.hpp"
#include "daemon/no_output_status_sink.hpp"
#include "daemon/position_join_sink.hpp"
#include "daemon/progress.hpp"
#include "daemon/replay.hpp"
#include "daemon/replay_status.hpp"
#include "daemon/run_summary.hpp"
#include "daemon/trafficability_sink.hpp"
#include "gps/gps_config.hpp"
#include "gps/gps_jsonl.hpp"
#include "plots/plot_sink.hpp"
#include "recording/measurement_csv_sink.hpp"
#include "recording/recording.hpp"
#include "recording/segment_csv_sink.hpp"
#include "runtime/realtime_pipeline.hpp"

namespace rutd {
namespace {

// DIR/vehicle.log (the CAN frames `rutd run` received, candump format, on the recording's clock) decoded
// as the receiver decoded them live. A line that is not a CAN frame is reported (file and line) and
// skipped; `bad` counts them. Empty when the recording has no vehicle.log.
std::vector<SpeedSample> read_vehicle_log(const std::string& dir, const VehicleSpeedConfig& config,
                                          VehicleSpeedStats& stats, std::uint64_t& bad) {
  std::vector<SpeedSample> samples;
  const std::string path = dir + "/vehicle.log";
  std::ifstream in(path);
  if (!in) return samples;
  VehicleSpeedDecoder decoder(config);
  std::string line;
  std::uint64_t number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.empty()) continue;
    const auto frame = parse_candump_line(line);
    if (!frame) {
      if (bad++ == 0) spdlog::error("{}: line {}: not a candump frame line, skipped: '{}'", path, number, line);
      continue;
    }
    if (const auto s = decoder.on_frame(frame->first, frame->second)) samples.push_back(*s);
  }
  stats = decoder.stats();
  return samples;
}

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

// The CAN side of a replay: CanSink writing the candump log on the recording's clock, behind the same
// NO_MEASUREMENT rule as `rutd run` (NoOutputStatusSink), counted on that clock too.
struct CandumpOutput {
  CandumpOutput(const std::string& path, const std::string& interface, std::chrono::milliseconds no_output_after)
      : stream(open_output(path, file, "--candump")),
        writer(stream, interface),
        can(CanIdConfig{}, nullptr, &writer, &stream, {}, CandumpTime::FrameClock, software_version()),
        sink(can, no_output_after, NoOutputStatusSink::Clock::Frames) {}
  std::ofstream file;
  std::ostream& stream;
  CandumpLogWriter writer;
  CanSink can;
  NoOutputStatusSink sink;
};

std::unique_ptr<PlotSink> make_plot_sink(const ReplayOptions& o, const StereoCalibration& calibration,
                                         const StereoMeasurer& measurer) {
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
    return std::make_unique<PlotSink>(pc, PlotContext{calibration, measurer.geometry().rectification()});
  } catch (const std::invalid_argument& e) {
    throw InputError(o.plots, "--plots", e.what());
  }
}

}  // namespace

int replay_recording(const ReplayOptions& o) {
  // A file-size limit (RLIMIT_FSIZE) fails the write (EFBIG), which stops the replay with the rows so far
  // kept, instead of killing it.
  std::signal(SIGXFSZ, SIG_IGN);
  ReplaySource reader(o.dir);  // throws InputError for a bad folder, calibration or header
  const MeasurerConfig config = resolve_measure_options(o.measure);
  StereoMeasurer measurer(reader.calibration(), config);

  // The sinks of `rutd run`, with its status period and no-output rule (PipelineConfig's defaults).
  const PipelineConfig live;
  // Positions as they were joined live: the recording's gpsd reports, by their receive time.
  std::unique_ptr<RecordedPositions> recorded;
  if (o.positions) {
    const std::string path = o.dir + "/" + kGpsJsonlFile;
    if (!std::filesystem::exists(path))
      throw InputError(path, "--positions", "the recording has no positions (recorded without gps.enabled)");
    RecordedFixes fixes = read_recorded_fixes(path);
    if (fixes.malformed > 0) spdlog::warn("{}: {} reports could not be read and were skipped", path, fixes.malformed);
    recorded =
        std::make_unique<RecordedPositions>(std::move(fixes.fixes), static_cast<std::int64_t>(o.max_fix_age_ms * 1e6));
    spdlog::info("{}: {} fixes from {} gpsd reports", path, recorded->size(), fixes.reports);
  }
  MeasurementCsvSink csv(o.out.empty() ? "-" : o.out, "--out", nullptr, o.positions);
  std::unique_ptr<CandumpOutput> candump;
  if (!o.candump.empty()) candump = std::make_unique<CandumpOutput>(o.candump, o.can_interface, live.no_frame_timeout);
  std::unique_ptr<PlotSink> plots;
  if (!o.plots.empty()) plots = make_plot_sink(o, reader.calibration(), measurer);
  std::vector<MeasurementSink*> outputs;
  if (candump) outputs.push_back(&candump->sink);
  outputs.push_back(&csv);
  if (plots) outputs.push_back(plots.get());
  // Trafficability from the recording's vehicle.log, with the configuration's trafficability section.
  const RutdConfig rutd_config =
      o.config.empty() ? parse_config(default_config_text(), "(embedded default)") : load_config(o.config);
  const TrafficabilityConfig& tc = rutd_config.trafficability;
  std::unique_ptr<SegmentCsvSink> segments_csv;
  if (!o.segments.empty()) {
    segments_csv = std::make_unique<SegmentCsvSink>(o.segments, "--segments");
    outputs.push_back(segments_csv.get());
  }
  VehicleSpeedStats speed_stats;
  std::uint64_t bad_log_lines = 0;
  const std::vector<SpeedSample> samples = read_vehicle_log(o.dir, tc.speed, speed_stats, bad_log_lines);
  const bool have_speed = speed_stats.frames > 0 || bad_log_lines > 0;
  if (!have_speed && segments_csv) spdlog::warn("{}: no vehicle.log: no speed, so no segments", o.dir);
  std::size_t next_sample = 0;
  SpeedSamplePull pull;
  if (have_speed) {
    pull = [&](std::int64_t up_to, SpeedSample& out) {
      if (next_sample >= samples.size() || samples[next_sample].t_ns > up_to) return false;
      out = samples[next_sample++];
      return true;
    };
  }
  if (candump && (have_speed || recorded)) candump->can.enable_motion();
  SinkFanout fanout(outputs);
  TrafficabilitySink traffic(fanout, pull, tc.odometer, tc.segments);
  // Positions before trafficability, so that the segments carry them.
  std::optional<PositionJoinSink> joined;
  if (recorded) joined.emplace(traffic, *recorded, true);
  MeasurementSink& sinks = joined ? static_cast<MeasurementSink&>(*joined) : traffic;
  ReplayStatus status(live.status_period, live.no_frame_timeout);

  RunSummary summary;
  // The stages one after the other (StereoMeasurer::measure does the same), keeping each pair's strips,
  // disparity and cross-section for the sinks.
  FrameWork work;
  MatchContext context = measurer.make_match_context();
  // Which device computes (the GPU engine's, or the CPU and why), again at the end if that changed.
  const std::string device = context.engine->device();
  spdlog::info("replaying {} with engine {}{} on {}", o.dir, to_string(config.engine), config.dic ? " + DIC" : "",
               device);
  RutWorkspace rut_ws;
  StereoFrame& frame = work.frame;
  std::uint64_t unreadable = 0, done = 0;
  ProgressLine progress("replay", count_pairs(o.dir));
  // Measuring on with nowhere to put the result is pointless: stop, keeping what was written so far.
  auto output_failed = [&]() -> bool {
    if (csv.stats().rows_lost > 0) {
      progress.clear();
      spdlog::error("replay stopped at seq {}: the {} rows written before it are kept in {}", frame.seq,
                    csv.stats().rows_written, csv.path() == "-" ? std::string("standard output") : csv.path());
      return true;
    }
    if (candump && !candump->stream) {
      progress.clear();
      spdlog::error("{}: cannot write the candump log (disk full or output closed); replay stopped at seq {}",
                    o.candump == "-" ? std::string("standard output") : o.candump, frame.seq);
      return true;
    }
    return false;
  };
  for (;;) {
    progress.update(done++);
    const SourceStatus read = reader.next(frame);
    if (read == SourceStatus::EndOfStream) break;
    if (read != SourceStatus::Ok) {
      // One bad pair (a corrupt image, a malformed line) must not cost the rest of a long recording:
      // report it, go on with the next line, and fail the command at the end.
      progress.clear();
      spdlog::error("{}", reader.error_message());
      ++unreadable;
      continue;
    }
    status.advance(frame.t_ns, sinks);
    const bool fitted = measurer.rectify(work);
    if (fitted) {
      measurer.match(work, context);
      measurer.extract(work, rut_ws);
    }
    summary.add(work.measurement, work.diag);
    status.add(frame.t_ns, fitted, work.measurement.status);
    sinks.publish(published_frame(work, status.health()));
    if (output_failed()) return 1;
  }
  status.finish(sinks);
  traffic.finish();  // the last, open segment
  progress.clear();
  if (have_speed) {
    spdlog::info("vehicle.log: {} frames, {} speed samples ({} ok), {} lines not frames", speed_stats.frames,
                 speed_stats.samples, speed_stats.ok, bad_log_lines);
    spdlog::info("trafficability: {}", traffic.describe());
  }
  if (have_speed && segments_csv) {
    std::string error;
    if (!traffic.write_damage_csv(damage_csv_path(o.segments), error)) {
      spdlog::error("{}", error);
      return 1;
    }
  }
  if (context.engine->device() != device)
    spdlog::warn("the engine left {} during the replay: now on {}", device, context.engine->device());
  if (output_failed()) return 1;
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
  if (bad_log_lines > 0) {
    spdlog::error("{}/vehicle.log: {} lines could not be read (the first is named above); the other frames were used",
                  o.dir, bad_log_lines);
    return 1;
  }
  if (unreadable > 0) {
    spdlog::error("{}: {} pairs could not be read (see above); the other pairs were measured", o.dir, unreadable);
    return 1;
  }
  return 0;
}

void add_replay_command(CLI::App& app, int& exit_code) {
  auto options = std::make_shared<ReplayOptions>();
  CLI::App* cmd = app.add_subcommand("replay", "Measure every stereo pair of a recording folder");
  cmd->add_option("dir", options->dir, "Recording folder (calibration.yaml, frames.csv, left/, right/)")->required();
  cmd->add_option("--out", options->out, "Measurement CSV file (default: standard output)");
  cmd->add_option("--candump", options->candump,
                  "Also write the CAN frames the vehicle would have been sent (measurements, and status frames "
                  "every 100 ms of recording time), candump -L format, stamped on the recording's clock");
  cmd->add_option("--can-interface", options->can_interface, "Interface name written in the candump log")
      ->capture_default_str();
  cmd->add_option("--plots", options->plots,
                  "Write PNG plots into this folder: cross-section, disparity and rectified image of chosen pairs, "
                  "depth/width/quality over the run (series.png)");
  cmd->add_option("--plot-every", options->plot_every,
                  "Also plot every N-th pair (the first pair of each status change is always plotted)")
      ->check(CLI::Range(0, 1000000));
  cmd->add_option("--segments", options->segments,
                  "Segment CSV file: the track's segments from the recording's vehicle.log (trafficability)");
  cmd->add_option("--config", options->config,
                  "Configuration whose trafficability section applies (default: the embedded one)");
  cmd->add_flag("--positions", options->positions,
                "Join the positions the recording's gps.jsonl holds to the pairs, as `rutd run` did; the CSV gets "
                "the position columns");
  cmd->add_option("--max-fix-age-ms", options->max_fix_age_ms,
                  "With --positions: a fix older than this at a pair's capture time is stale (gps.max_fix_age_ms)")
      ->capture_default_str()
      ->check(CLI::Range(10.0, 600000.0));
  add_measure_options(*cmd, options->measure);
  cmd->callback([options, &exit_code] { exit_code = replay_recording(*options); });
}

}  // namespace rutd
