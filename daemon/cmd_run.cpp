// rutd run: the daemon. Loads the configuration (or the embedded default), starts the real-time
// pipeline (acquire -> rectify -> match -> extract -> publish), publishes every measurement as CAN
// frames plus a periodic status frame, and talks to systemd (READY, STATUS, WATCHDOG). With no options it
// runs on any machine: synthetic cameras at their real frame rate, CAN frames on stdout (candump -L
// format), logs on stderr. SIGINT/SIGTERM: stop, drain, exit 0 within a second. With source.record (or
// --record DIR) the raw pairs are also recorded (recording/frame_recorder.hpp); a recording that fails
// (disk full, file too large) stops with one error and raises RecordingError in the status frames
// while measuring goes on; so does a measurement CSV row that cannot be written (sinks.csv, which
// resumes by itself when the disk has room again).
#include <atomic>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <memory>
#include <optional>
#include <thread>

#include <spdlog/spdlog.h>

#include "can/can_sink.hpp"
#include "can/vehicle_speed_receiver.hpp"
#include "core/input_error.hpp"
#include "daemon/build_info.hpp"
#include "daemon/commands.hpp"
#include "daemon/config.hpp"
#include "daemon/dimensions.hpp"
#include "daemon/latest_measurement_sink.hpp"
#include "daemon/no_output_status_sink.hpp"
#include "daemon/position_join_sink.hpp"
#include "daemon/run_sources.hpp"
#include "daemon/service_notifier.hpp"
#include "daemon/stalling_stages.hpp"
#include "daemon/stop_signal.hpp"
#include "daemon/supervisor.hpp"
#include "daemon/trafficability_sink.hpp"
#include "daemon/uplink_state_sink.hpp"
#include "gps/gpsd_source.hpp"
#include "recording/calibration_file.hpp"
#include "recording/frame_recorder.hpp"
#include "recording/measurement_csv_sink.hpp"
#include "recording/segment_csv_sink.hpp"
#include "runtime/realtime_pipeline.hpp"
#include "uplink/uplink_sink.hpp"
#include "web/live_view.hpp"

namespace rutd {
namespace {

// How long a stop waits for the pairs in flight (RealtimePipeline::drain): a handful of slots, each a
// few tens of ms per stage, well within the unit's one-second stop.
constexpr std::chrono::milliseconds kStopDrain{400};

// Command-line overrides of the configuration, for quick runs and tests.
struct RunOptions {
  std::string config;
  std::uint64_t frames = 0;  // stop after this many published measurements; 0: until a signal
  std::optional<std::string> socketcan, candump, csv, record, size, engine, replay_dir;
  std::optional<std::string> speed_socketcan, segments;  // trafficability.speed.socketcan, .segments_csv
  bool no_dic = false;
  bool check = false;                                   // --check: see check_run
  std::optional<std::uint64_t> test_stall_match_after;  // tests only: see daemon/stalling_stages.hpp
};

RutdConfig effective_config(const RunOptions& o) {
  RutdConfig c = o.config.empty() ? parse_config(default_config_text(), "(embedded default)") : load_config(o.config);
  if (o.socketcan) c.sinks.socketcan = *o.socketcan;
  if (o.candump) c.sinks.candump = *o.candump;
  if (o.csv) c.sinks.csv = *o.csv;
  if (o.record) c.record = *o.record;
  if (o.no_dic) c.measurement.dic = false;
  if (o.speed_socketcan) c.trafficability.socketcan = *o.speed_socketcan;
  if (o.segments) c.trafficability.segments_csv = *o.segments;
  if (o.engine) c.measurement.engine = *parse_engine(*o.engine);  // checked by IsMember
  if (o.replay_dir) {
    c.source = SourceKind::Replay;
    c.replay.dir = *o.replay_dir;
  }
  if (o.size) {
    const auto size = parse_dimensions(*o.size, 64, 8192);
    if (!size)
      throw CLI::ValidationError("--size", "expected WIDTHxHEIGHT between 64x64 and 8192x8192, got '" + *o.size + "'");
    c.synthetic.rig.image_size = *size;
  }
  return c;
}

std::ostream* open_stream(const std::string& path, std::ofstream& file, const char* key) {
  if (path.empty()) return nullptr;
  if (path == "-") return &std::cout;
  file.open(path, std::ios::out | std::ios::trunc);
  if (!file) throw InputError(path, key, "cannot open for writing");
  return &file;
}

PipelineConfig pipeline_config(const RutdConfig& c) {
  PipelineConfig p = c.pipeline;  // ages, status period, thread placement from the file
  p.log_period = std::chrono::milliseconds(static_cast<long>(c.logging.stats_period_s * 1000));
  p.on_log = [](const PipelineStats& s) { spdlog::info("{}", describe(s)); };
  // A recording's timestamps are its own time base, not this machine's clock.
  p.capture_clock_is_local = c.source != SourceKind::Replay;
  return p;
}

// --check: what `rutd run` would refuse at start-up, found without starting: the configuration (every key,
// the cameras named), the calibration file the cameras need, a replay's recording. The cameras are not
// opened: rutd waits for them when it runs. Throws InputError as run does (exit 2); prints one line and
// returns 0 when rutd could start. The package's postinst starts the service only then.
int check_run(const RunOptions& o) {
  const RutdConfig c = effective_config(o);
  if (c.source == SourceKind::Aravis) load_calibration(c.calibration);
  if (c.source == SourceKind::Replay) make_source(c);
  std::cout << "rutd: " << c.file << ": ready to run: source " << describe_source(c) << '\n';
  return 0;
}

int run_daemon(const RunOptions& o, const RunInjection& injection) {
  // First, before any file is written: an exceeded file-size limit (RLIMIT_FSIZE) must fail the write
  // with EFBIG, which the recorder reports, instead of killing the daemon.
  std::signal(SIGXFSZ, SIG_IGN);
  const RutdConfig c = effective_config(o);
  spdlog::set_level(spdlog::level::from_str(c.logging.level));
  std::unique_ptr<FrameSource> source =
      make_source(c, injection.faults);  // throws InputError for a bad recording/calibration
  const StereoMeasurer measurer(source->calibration(), c.measurement);
  MeasurerStages measurer_stages(measurer);
  std::optional<StallingStages> stalling;
  if (o.test_stall_match_after) stalling.emplace(measurer_stages, *o.test_stall_match_after);
  PipelineStages& stages = stalling ? static_cast<PipelineStages&>(*stalling) : measurer_stages;

  std::ofstream candump_file;
  std::ostream* candump_stream = open_stream(c.sinks.candump, candump_file, "sinks.candump");
  std::unique_ptr<MeasurementCsvSink> csv;
  if (!c.sinks.csv.empty())
    csv = std::make_unique<MeasurementCsvSink>(c.sinks.csv, "sinks.csv", injection.faults, c.sinks.csv_positions);
  std::unique_ptr<SocketCanBus> bus;
  if (!c.sinks.socketcan.empty()) {
    bus = injection.open_bus
              ? injection.open_bus(c.sinks.socketcan)
              : std::make_unique<SocketCanBus>(c.sinks.socketcan, injection.faults);  // throws, naming it
  }
  // Created after every other start-up check, so a start that fails leaves no empty recording behind
  // (which would block the next start: an existing recording is refused, InputError, never overwritten).
  std::unique_ptr<FrameRecorder> recorder;
  if (!c.record.empty()) {
    FrameRecorderConfig recording;
    recording.capacity = static_cast<std::size_t>(c.record_buffer);
    recording.writer.faults = injection.faults;
    recorder = std::make_unique<FrameRecorder>(c.record, source->calibration(), recording);
    source = std::make_unique<RecordingTee>(std::move(source), *recorder);
  }
  std::unique_ptr<CandumpLogWriter> log;
  if (candump_stream != nullptr) log = std::make_unique<CandumpLogWriter>(*candump_stream, c.sinks.can_interface_name);
  // RecordingError: the recording has stopped on an error, or a CSV row was lost since the last status.
  std::function<bool()> recording_failed;
  if (recorder || csv) {
    recording_failed = [r = recorder.get(), m = csv.get()] {
      const bool csv_failed = m != nullptr && m->failed_since_last_check();
      return (r != nullptr && r->failed()) || csv_failed;
    };
  }
  // The fleet uplink: a thread and a queue of its own; a broken link never slows the measurement.
  std::unique_ptr<Uplink> uplink;
  if (c.uplink.enabled) {
    const SoftwareVersion& v = software_version();
    try {
      uplink = std::make_unique<Uplink>(c.uplink, fmt::format("{}.{}.{}-{}", v.major, v.minor, v.patch, v.revision));
    } catch (const std::exception& e) {
      throw InputError(c.file, "uplink", e.what());
    }
  }
  CanSink can(c.can, bus.get(), log.get(), candump_stream, std::move(recording_failed), CandumpTime::WallClock,
              software_version());
  // The CAN status frame says NO_MEASUREMENT once nothing has been published for as long as it takes to
  // call a camera lost.
  // RutMotion with every measurement once there is a speed or a position to tell.
  if (!c.trafficability.socketcan.empty() || c.gps.enabled) can.enable_motion();
  NoOutputStatusSink can_status(can, c.pipeline.no_frame_timeout);
  LatestMeasurementSink latest;
  // With an uplink, its state goes into each status on the way to CAN (RutUplinkStatus); its sink sends
  // the segments, the seconds without speed and the health.
  std::optional<UplinkStateSink> uplink_state;
  std::optional<UplinkSink> uplink_sink;
  if (uplink) {
    uplink_state.emplace(can_status, *uplink);
    uplink_sink.emplace(*uplink);
  }
  std::vector<MeasurementSink*> sinks{uplink_state ? static_cast<MeasurementSink*>(&*uplink_state) : &can_status,
                                      &latest};
  if (uplink_sink) sinks.push_back(&*uplink_sink);
  if (csv) sinks.push_back(csv.get());
  std::unique_ptr<PlotSink> plots;
  if (c.sinks.plots_enabled) {
    std::error_code ec;
    std::filesystem::create_directories(c.sinks.plots.dir, ec);
    if (ec)
      throw InputError(c.file, "sinks.plots.dir", c.sinks.plots.dir + ": cannot create the folder: " + ec.message());
    try {
      plots = std::make_unique<PlotSink>(c.sinks.plots,
                                         PlotContext{source->calibration(), measurer.geometry().rectification()});
    } catch (const std::invalid_argument& e) {
      throw InputError(c.file, "sinks.plots.dir", e.what());
    }
    sinks.push_back(plots.get());
  }
  // The live view: its own threads, fed a few pairs a second; it sees the segments too.
  std::unique_ptr<WebLiveView> web;
  if (c.web.enabled) {
    try {
      web =
          std::make_unique<WebLiveView>(c.web, WebContext{source->calibration(), measurer.geometry().rectification()});
    } catch (const std::invalid_argument& e) {
      throw InputError(c.file, "web.token_file", e.what());
    } catch (const std::exception& e) {
      throw InputError(c.file, "web.port", e.what());
    }
    sinks.push_back(web.get());
  }
  // Trafficability: the vehicle speed from the bus, recorded beside the pairs as vehicle.log.
  std::unique_ptr<SegmentCsvSink> segments_csv;
  if (!c.trafficability.segments_csv.empty()) {
    segments_csv = std::make_unique<SegmentCsvSink>(c.trafficability.segments_csv, "trafficability.segments_csv");
    sinks.push_back(segments_csv.get());
  }
  std::ofstream vehicle_log;
  std::unique_ptr<VehicleSpeedReceiver> speed;
  if (!c.trafficability.socketcan.empty()) {
    if (recorder) {
      const std::string path = recorder->directory() + "/vehicle.log";
      vehicle_log.open(path, std::ios::out | std::ios::trunc);
      if (!vehicle_log) throw InputError(path, "source.record", "cannot open the vehicle log for writing");
    }
    std::ostream* log_out = vehicle_log.is_open() ? &vehicle_log : nullptr;
    speed = injection.open_speed
                ? injection.open_speed(c.trafficability.socketcan, c.trafficability.speed, log_out)
                : std::make_unique<VehicleSpeedReceiver>(c.trafficability.socketcan, c.trafficability.speed, log_out,
                                                         c.sinks.can_interface_name);
  }
  SpeedSamplePull pull;
  if (speed) pull = [r = speed.get()](std::int64_t up_to, SpeedSample& out) { return r->next(up_to, out); };
  SinkFanout fanout(sinks);
  // A frame reaches publishing at most max_frame_age after its capture (older ones are refused as stale);
  // with no age limit, 1 s is as late as it matters. The margin covers the publish stage's own time.
  const auto max_age =
      c.pipeline.max_frame_age.count() > 0 ? c.pipeline.max_frame_age : std::chrono::milliseconds(1000);
  const std::int64_t status_lag_ns = std::chrono::nanoseconds(max_age + std::chrono::milliseconds(100)).count();
  TrafficabilitySink traffic(fanout, std::move(pull), c.trafficability.odometer, c.trafficability.segments,
                             status_lag_ns);
  // Positions (gps): gpsd read on its own thread, joined to every pair before the sinks (and the segments)
  // see it, and its reports recorded beside the pairs (gps.jsonl) when recording.
  std::unique_ptr<GpsJsonlWriter> gps_record;
  if (c.gps.enabled && recorder) gps_record = std::make_unique<GpsJsonlWriter>(recorder->directory() + "/gps.jsonl");
  std::unique_ptr<GpsdSource> gps;
  if (c.gps.enabled) gps = std::make_unique<GpsdSource>(c.gps, gps_record.get());
  std::optional<PositionJoinSink> positions;
  if (gps) positions.emplace(traffic, *gps, pipeline_config(c).capture_clock_is_local);
  MeasurementSink& published = positions ? static_cast<MeasurementSink&>(*positions) : traffic;

  install_stop_handlers();
  ServiceNotifier systemd;
  PipelineConfig pipeline_settings = pipeline_config(c);
  if (gps || uplink) {
    // The positions' and the uplink's state with each summary (publish thread, which also owns the join's
    // counts).
    pipeline_settings.on_log = [g = gps.get(), j = positions ? &*positions : nullptr,
                                u = uplink.get()](const PipelineStats& s) {
      spdlog::info("{}", describe(s));
      if (g) {
        const GpsStats gs = g->stats();
        spdlog::info(
            "gps: gpsd {}, {} pairs with a position, {} without; {} fixes, {} without a fix, {} malformed, {} "
            "connections lost, {} time jumps",
            gs.connected ? "connected" : "not connected", j->stats().with_position, j->stats().without_position,
            gs.fixes, gs.no_fix_reports, gs.malformed, gs.disconnects, gs.time_jumps);
      }
      if (u) spdlog::info("uplink: {}", describe(u->health()));
    };
  }
  RealtimePipeline pipeline(*source, stages, published, pipeline_settings);
  spdlog::info("rutd {}, {}: source {}, engine {}{}, CAN to {}{}{}{}", version_line(), c.file, describe_source(c),
               to_string(c.measurement.engine), c.measurement.dic ? " + DIC" : "",
               bus ? c.sinks.socketcan : std::string("no bus"),
               log ? (", candump log to " + (c.sinks.candump == "-" ? std::string("stdout") : c.sinks.candump)) : "",
               recorder ? ", recording to " + recorder->directory() : "",
               gps ? fmt::format(", positions from gpsd at {}:{}", c.gps.host, c.gps.port) : "");
  pipeline.start();
  if (web)
    spdlog::info("web view at http://{}:{}/",
                 c.web.bind.find(':') != std::string::npos ? "[" + c.web.bind + "]" : c.web.bind, web->port());
  if (stalling) spdlog::warn("test switch: the match stage stalls after {} pairs", *o.test_stall_match_after);
  for (const auto& w : pipeline.placement_warnings()) spdlog::warn("thread placement: {}", w);

  // The main thread supervises: readiness, watchdog, status line, stop conditions.
  using namespace std::chrono;
  const auto watchdog = duration_cast<milliseconds>(systemd.watchdog_interval());
  const auto tick = watchdog.count() > 0 ? std::min(watchdog / 4, milliseconds(100)) : milliseconds(100);
  Supervisor supervisor(systemd, watchdog.count() > 0 ? watchdog : milliseconds(5000), seconds(30));
  while (!stop_requested()) {
    std::this_thread::sleep_for(tick);
    const PipelineStats s = pipeline.stats();
    supervisor.tick(s, latest, monotonic_now_ns());
    if ((o.frames > 0 && s.published >= o.frames) || s.finished) break;
  }
  systemd.stopping();
  // The pairs already acquired (and recorded) are measured and published; what is left after
  // kStopDrain is abandoned, so that SIGTERM still ends the daemon within a second, and said so.
  const bool drained = pipeline.drain(kStopDrain);
  pipeline.stop();
  const PipelineStats s = pipeline.stats();
  spdlog::info("stopped: {}", describe(s));
  if (!drained)
    spdlog::warn("stop: {} pairs acquired were still in the pipeline after {} ms and are not published", s.in_flight(),
                 kStopDrain.count());
  if (speed) {
    speed->stop();
    traffic.finish();  // the last, open segment
    const VehicleSpeedReceiverStats r = speed->stats();
    const VehicleSpeedStats& d = r.decoded;
    spdlog::info(
        "vehicle speed on {} ({}): {} frames, {} samples ({} ok, {} not available, {} error, {} out of range, "
        "{} implausible, {} direction unknown); ignored: {} wrong length, {} spoofed, {} burst, {} other; "
        "{} dropped by the kernel, {} by the queue",
        speed->interface(), c.trafficability.speed.signal.name, d.frames, d.samples, d.ok, d.not_available,
        d.error_value, d.out_of_range, d.implausible, d.direction_unknown, d.wrong_length, d.spoofed, d.burst,
        d.other_id, r.kernel_dropped, r.queue_full);
    spdlog::info("trafficability: {}", traffic.describe());
  }
  if (uplink) {
    // After the last segment closed: it goes into the queue, then up if the broker takes it within a
    // second; "offline" last.
    uplink->stop();
    spdlog::info("uplink {}:{}: {}", c.uplink.host, c.uplink.port, describe(uplink->health()));
  }
  if (web) {
    web->stop();
    const WebHandoff w = web->stats();
    spdlog::info(
        "web view: {} pairs shown, {} dropped (view thread behind), {} samples dropped, {} requests, {} refused",
        w.pairs_offered - w.pairs_dropped, w.pairs_dropped, w.samples_dropped, w.requests, w.refused);
  }
  if (segments_csv) {
    spdlog::info("segment CSV {}: {} rows written, {} lost", segments_csv->path(), segments_csv->rows_written(),
                 segments_csv->rows_lost());
    std::string error;
    if (speed && !traffic.write_damage_csv(damage_csv_path(segments_csv->path()), error)) spdlog::error("{}", error);
  }
  if (gps) {
    gps->stop();
    const GpsStats g = gps->stats();
    const PositionJoinStats& j = positions->stats();
    spdlog::info(
        "gps {}:{}: {} pairs with a position, {} without (no gpsd, no fix or stale); {} fixes, {} reports "
        "without a fix, {} malformed, {} connections, {} lost, {} failed attempts, {} time jumps{}",
        c.gps.host, c.gps.port, j.with_position, j.without_position, g.fixes, g.no_fix_reports, g.malformed, g.connects,
        g.disconnects, g.connect_failures, g.time_jumps,
        gps_record ? fmt::format("; {} reports recorded, {} not", g.recorded, g.record_errors) : "");
  }
  if (recorder) {
    recorder->close();  // writes what is still queued
    const FrameRecorderStats r = recorder->stats();
    // The failure itself was logged once, when it happened.
    spdlog::info("recording {}: {} pairs written, {} dropped (writer behind){}", recorder->directory(), r.written,
                 r.dropped, r.failed ? fmt::format(", stopped by an error, {} pairs not recorded", r.discarded) : "");
  }
  if (csv) {
    const MeasurementCsvStats& m = csv->stats();
    spdlog::info("measurement CSV {}: {} rows written, {} lost{}", csv->path(), m.rows_written, m.rows_lost,
                 m.rows_lost > 0 ? " (the last: " + m.last_error + ")" : std::string());
  }
  if (plots) {
    const PlotSinkStats p = plots->finish();
    spdlog::info("plots {}: {} files written for {} frames, {} frames dropped (plot thread behind), {} errors{}",
                 c.sinks.plots.dir, p.files_written, p.frames_plotted, p.dropped, p.errors,
                 p.errors > 0 ? " (the last: " + p.last_error + ")" : std::string());
  }
  if (bus) {
    const SocketCanStats& b = bus->stats();
    spdlog::info("CAN {}: {} frames sent, {} dropped (queue full), {} write errors, {} bus-off events",
                 c.sinks.socketcan, b.sent, b.dropped, b.write_errors, b.bus_off_events);
  }
  // Per-frame faults are reported on CAN and in the log, never through the exit status: a stop asked for
  // is a clean exit. Start-up errors throw before this point (exit 2 in main).
  return 0;
}

}  // namespace

void add_run_command(CLI::App& app, int& exit_code, RunInjection injection) {
  auto o = std::make_shared<RunOptions>();
  CLI::App* cmd = app.add_subcommand("run", "Measure continuously and publish rut depth on CAN (the daemon)");
  cmd->add_option("--config", o->config, "Configuration file (default: the embedded one, see config/rutd.yaml)");
  cmd->add_option("--frames", o->frames, "Stop after this many published measurements (0: until SIGINT/SIGTERM)")
      ->capture_default_str();
  cmd->add_option("--socketcan", o->socketcan, "Send on this CAN interface (overrides sinks.socketcan)");
  cmd->add_option("--candump", o->candump,
                  "candump -L log of the frames sent, '-' for stdout, '' for none (sinks.candump)");
  cmd->add_option("--csv", o->csv, "Measurement CSV file (sinks.csv)");
  cmd->add_option("--speed-socketcan", o->speed_socketcan,
                  "Receive the vehicle speed on this CAN interface (trafficability.speed.socketcan)");
  cmd->add_option("--segments", o->segments, "Segment CSV file (trafficability.segments_csv)");
  cmd->add_option("--record", o->record, "Also record the raw pairs into this new folder (source.record)");
  cmd->add_option("--replay", o->replay_dir,
                  "Measure a recording folder at its own pace instead of the configured source");
  cmd->add_option("--size", o->size, "Synthetic camera image size WIDTHxHEIGHT (source.synthetic.size)");
  cmd->add_option("--engine", o->engine, "Disparity engine (measurement.engine)")
      ->check(CLI::IsMember({"bm", "sgbm", "sgbm3way", "hh4", "hh", "gpu", "sgmref"}));
  cmd->add_flag("--no-dic", o->no_dic, "No sub-pixel refinement (measurement.dic: false)");
  cmd->add_flag("--check", o->check,
                "Check the configuration and the calibration it names, then exit: 0 and one line when rutd could "
                "start, else the error (exit 2)");
  // Hidden (empty group): a test switch, never for a vehicle. The watchdog test stalls a stage with it.
  cmd->add_option("--test-stall-match-after", o->test_stall_match_after,
                  "Tests only: the match stage stops returning after N pairs")
      ->group("");
  cmd->callback([o, &exit_code, injection] { exit_code = o->check ? check_run(*o) : run_daemon(*o, injection); });
}

}  // namespace rutd
