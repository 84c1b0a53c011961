// rutd record DIR: records the configured source (the same configuration as `rutd run`) into a new
// recording folder (DESIGN.md, Formats) without measuring. Acquisition runs on the calling thread and
// hands pairs to a FrameRecorder, whose own thread encodes and writes them; acquisition never waits for
// the disk, so pairs the writer cannot keep up with are dropped and counted. Crash-safe: a kill -9 (and,
// unless --no-sync, a power cut) at any moment leaves a folder that replays every pair it lists.
// SIGINT/SIGTERM stop cleanly (what is queued is written). Exit 0; 1 when the recording failed (disk
// full, file too large; the error names the file); 2 for bad input at start, including a folder that
// already holds a recording (never overwritten).
#include <atomic>
#include <chrono>
#include <csignal>
#include <memory>

#include <spdlog/spdlog.h>

#include "daemon/commands.hpp"
#include "daemon/config.hpp"
#include "daemon/run_sources.hpp"
#include "daemon/stop_signal.hpp"
#include "recording/frame_recorder.hpp"

namespace rutd {
namespace {

struct RecordOptions {
  std::string dir;
  std::string config;
  std::uint64_t frames = 0;  // stop once this many pairs were accepted for writing; 0: no limit
  double duration_s = 0;     // stop after this long; 0: no limit
  bool no_sync = false;
};

int run_record(const RecordOptions& o) {
  // First, before any file is written: an exceeded file-size limit must be a write error the recorder
  // reports (EFBIG), not a kill.
  std::signal(SIGXFSZ, SIG_IGN);
  const RutdConfig c =
      o.config.empty() ? parse_config(default_config_text(), "(embedded default)") : load_config(o.config);
  spdlog::set_level(spdlog::level::from_str(c.logging.level));
  std::unique_ptr<FrameSource> source = make_source(c);  // throws InputError for an unusable source
  FrameRecorderConfig options;
  options.capacity = static_cast<std::size_t>(c.record_buffer);
  options.writer.sync_to_disk = !o.no_sync;
  // Throws InputError when DIR cannot be written or already holds a recording.
  FrameRecorder recorder(o.dir, source->calibration(), options);
  install_stop_handlers();
  spdlog::info(
      "recording {} into {} ({})", describe_source(c), o.dir,
      o.no_sync ? "no sync: safe against a killed process, not against a power cut" : "synced to disk per pair");

  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  const auto deadline =
      start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(o.duration_s));
  auto last_error_log = start - std::chrono::seconds(1);
  std::uint64_t accepted = 0, source_errors = 0;
  StereoFrame frame;
  bool ended = false;
  // Every wait below is the source's own bounded wait, so a signal is seen within one frame period.
  while (!stop_requested() && !recorder.failed()) {
    if (o.frames > 0 && accepted >= o.frames) break;
    if (o.duration_s > 0 && Clock::now() >= deadline) break;
    const SourceStatus status = source->next(frame);
    if (status == SourceStatus::Ok) {
      if (recorder.offer(frame)) ++accepted;
    } else if (status == SourceStatus::EndOfStream) {
      ended = true;
      break;
    } else if (status == SourceStatus::Error) {
      // At most one line a second: a lost camera reports an error per frame period.
      ++source_errors;
      if (Clock::now() - last_error_log >= std::chrono::seconds(1)) {
        last_error_log = Clock::now();
        spdlog::warn("source: {} ({} source errors so far)", source->error_message(), source_errors);
      }
    }
  }
  recorder.close();  // writes what is queued
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  const FrameRecorderStats s = recorder.stats();
  spdlog::info("recorded {} pairs into {} in {:.2f} s ({:.1f} pairs/s); {} dropped (writer behind), {} source errors{}",
               s.written, o.dir, seconds, seconds > 0 ? static_cast<double>(s.written) / seconds : 0.0, s.dropped,
               source_errors, ended ? "; the source ended" : "");
  if (s.failed) {
    spdlog::error("recording {} failed after {} pairs (every listed pair replays): {}", o.dir, s.written, s.error);
    return 1;
  }
  return 0;
}

}  // namespace

void add_record_command(CLI::App& app, int& exit_code) {
  auto o = std::make_shared<RecordOptions>();
  CLI::App* cmd = app.add_subcommand("record", "Record the configured cameras (or source) into a new recording folder");
  cmd->add_option("dir", o->dir, "Recording folder to create (an existing recording is never overwritten)")->required();
  cmd->add_option("--config", o->config, "Configuration file whose source is recorded (default: the embedded one)");
  cmd->add_option("--frames", o->frames, "Stop after this many pairs written (0: no limit)")->capture_default_str();
  cmd->add_option("--duration", o->duration_s, "Stop after this many seconds (0: no limit)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_flag("--no-sync", o->no_sync,
                "Do not fdatasync each pair: faster, safe against a killed process but not against a power cut");
  cmd->callback([o, &exit_code] { exit_code = run_record(*o); });
}

}  // namespace rutd
