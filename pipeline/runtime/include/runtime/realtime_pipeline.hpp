#pragma once
// The real-time measurement pipeline (DESIGN.md, Threads and queues): five threads
//   acquire -> rectify -> match -> extract -> publish
// joined by bounded single-producer/single-consumer lock-free queues (SlotQueue, core/slot_queue.hpp,
// over Boost.Lockfree) that carry pointers to FrameSlots of a pool allocated at start. Each stage that can
// let go of a slot has its own return queue back to acquisition, which keeps the free list.
//
// Freshest frame wins: a stage that falls behind takes the newest queued frame and gives the older ones
// back, counted as dropped at its input. Acquisition never waits for downstream: when every slot is in
// flight it reads the pair into a spare slot and drops it (counted as dropped at Acquire). A frame whose
// age (now - FrameSlot::t0_ns) exceeds max_frame_age when it reaches a stage is refused, counted as stale.
// Nothing is allocated per frame once every slot has seen a frame (prime_slots does that at start).
//
// Every wait is bounded (a few ms), so stop() returns within the longest single stage call (or the
// source's own bounded wait) plus a few ms. A finite source (EndOfStream) drains: each stage finishes
// what is queued, then the pipeline reports finished(); drain() does the same on demand.
#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "core/frame_source.hpp"
#include "core/measurement_sink.hpp"
#include "core/monotonic_clock.hpp"
#include "core/sensor_health.hpp"
#include "measurement/measurer.hpp"
#include "runtime/latency_stats.hpp"

namespace rutd {

enum class Stage : std::uint8_t { Acquire = 0, Rectify = 1, Match = 2, Extract = 3, Publish = 4 };
inline constexpr std::size_t kStageCount = 5;
std::string_view to_string(Stage stage) noexcept;

// The three compute stages. Each method is called from its own stage thread only (and, before the
// threads start, from start() to prime the slots), so an implementation may keep per-stage scratch
// without locking. They must not throw on the per-frame path; an exception is caught, the frame is
// discarded and counted in PipelineStats::stage_errors.
class PipelineStages {
 public:
  virtual ~PipelineStages() = default;
  // false: the frame cannot be measured (does not fit the calibration); it is discarded.
  virtual bool rectify(FrameWork& work) = 0;
  virtual void match(FrameWork& work) = 0;
  virtual void extract(FrameWork& work) = 0;
};

// The real stages: StereoMeasurer's three const, thread-safe stages with one MatchContext (match
// thread) and one RutWorkspace (extract thread). The measurer must outlive this object.
class MeasurerStages final : public PipelineStages {
 public:
  explicit MeasurerStages(const StereoMeasurer& measurer)
      : measurer_(measurer), context_(measurer.make_match_context()) {}
  bool rectify(FrameWork& work) override { return measurer_.rectify(work); }
  void match(FrameWork& work) override { measurer_.match(work, context_); }
  void extract(FrameWork& work) override { measurer_.extract(work, workspace_); }
  // The match stage's engine (DisparityEngine::device() says where it computes). Thread: the match
  // stage's, or any once the pipeline has stopped.
  const DisparityEngine& engine() const { return *context_.engine; }

 private:
  const StereoMeasurer& measurer_;
  MatchContext context_;
  RutWorkspace workspace_;
};

// Best-effort real-time placement of one thread, applied by start(); failures are reported by
// RealtimePipeline::placement_warnings(), never fatal.
struct ThreadPlacement {
  int cpu = -1;           // pin to this CPU; -1: any
  int fifo_priority = 0;  // SCHED_FIFO priority 1..99; 0: normal scheduling
};

struct PipelineStats;

struct PipelineConfig {
  // Slots in the pool, 6..RealtimePipeline::kMaxPoolSlots. Five threads hold at most one slot each;
  // the rest absorb frames queued in front of a slow stage before acquisition has to drop.
  std::size_t pool_slots = 16;
  // false (real time): freshest frame wins, as above. true (replay, tests): every frame is measured in
  // order; stages take the oldest queued frame and acquisition waits (bounded, repeatedly) for a slot.
  bool lossless = false;
  // Frames older than this when they reach a stage are refused. 0: no limit.
  std::chrono::milliseconds max_frame_age{500};
  // true: a pair stamped ClockKind::Monotonic carries this machine's CLOCK_MONOTONIC capture time (live
  // sources). false, or ClockKind::Hardware: latency and age count from the moment acquisition
  // received the pair (a recording's own time base or a camera clock cannot be compared with ours).
  bool capture_clock_is_local = true;
  // The status message goes to the sink this often, measurements or not, and at once when the source
  // starts failing (a camera lost), so that the loss is on the bus without waiting for the period.
  std::chrono::milliseconds status_period{100};
  // SensorHealth::no_camera is raised after this long without a pair (or while the source reports Error).
  std::chrono::milliseconds no_frame_timeout{1000};
  // on_log(stats()) is called from the publish thread this often (the daemon logs it with spdlog);
  // 0 or an empty function: never. Latency figures in the stats are cumulative since start.
  std::chrono::milliseconds log_period{10000};
  std::function<void(const PipelineStats&)> on_log;
  // Run every slot once through the stages at start on a black frame of the calibration's size, so
  // their buffers exist before the first real frame (nothing allocated in steady state).
  bool prime_slots = true;
  // Indexed by Stage.
  std::array<ThreadPlacement, kStageCount> threads{};
};

// Throws std::invalid_argument naming the field when `config` is unusable.
void validate(const PipelineConfig& config);

// A snapshot of the pipeline's counters, any thread. Every acquired pair ends in exactly one of:
// published, dropped[*], stale[*], rectify_rejected, stage_errors (or is in flight / lost at stop()).
struct PipelineStats {
  std::uint64_t acquired = 0;  // pairs the source delivered (SourceStatus::Ok)
  std::uint64_t source_timeouts = 0;
  std::uint64_t source_errors = 0;
  // Indexed by Stage. dropped[Acquire]: no free slot; dropped[s]: superseded by a newer frame while
  // queued in front of stage s. stale[s]: refused at stage s for age.
  std::array<std::uint64_t, kStageCount> dropped{};
  std::array<std::uint64_t, kStageCount> stale{};
  std::uint64_t rectify_rejected = 0;  // rectify() returned false
  std::uint64_t stage_errors = 0;      // a stage threw
  std::uint64_t sink_errors = 0;       // a sink threw (the frame still counts as published)
  std::uint64_t measured = 0;          // extract() completed
  std::uint64_t published = 0;         // handed to the sink
  std::uint64_t published_ok = 0;      // ... with RutStatus::Ok
  std::uint64_t status_sent = 0;
  std::int64_t last_publish_ns = 0;  // CLOCK_MONOTONIC of the last publish; 0: none yet
  double acquire_hz = 0.0;           // over the last >= 1 s window
  double publish_hz = 0.0;
  // Indexed by Stage: Acquire = capture -> acquired (source delay), the others the time spent in the
  // stage call (Publish: in the sink).
  std::array<LatencySummary, kStageCount> stage_latency{};
  LatencySummary end_to_end;  // t0 -> the sink's publish() returned
  bool finished = false;      // a finite source ended and everything queued was handled

  std::uint64_t dropped_total() const noexcept;
  std::uint64_t stale_total() const noexcept;
  // Acquired and in none of the outcomes above: in flight (or abandoned by stop()).
  std::uint64_t in_flight() const noexcept;
};

// One line for the log: counters, rates, end-to-end and per-stage p50/p99/max in ms.
std::string describe(const PipelineStats& stats);

class RealtimePipeline {
 public:
  static constexpr std::size_t kMaxPoolSlots = 64;

  // References must outlive the pipeline. Allocates the pool. Throws std::invalid_argument for a bad
  // config (validate()).
  RealtimePipeline(FrameSource& source, PipelineStages& stages, MeasurementSink& sink, PipelineConfig config);
  ~RealtimePipeline();  // stop()
  RealtimePipeline(const RealtimePipeline&) = delete;
  RealtimePipeline& operator=(const RealtimePipeline&) = delete;

  // Primes the slots (config.prime_slots; what a stage throws while priming propagates), starts the
  // five threads and applies their placement. Once only: throws std::logic_error when called again.
  void start();
  // Asks every thread to stop and joins them; frames in flight are abandoned. Idempotent, any thread
  // but a pipeline thread (a sink must not call it).
  void stop();
  // Stops acquisition (joins its thread) and lets the other stages finish what they hold, as at the end
  // of a finite source, for up to `timeout`; true when everything acquired was handled (finished()).
  // The daemon's stop: a pair already acquired, and so recorded by a recording source, is measured and
  // published rather than abandoned. Call stop() after it. Same threads as stop(); once started.
  bool drain(std::chrono::milliseconds timeout);
  // Waits up to `timeout` for a finite source to drain; true when finished().
  bool wait_finished(std::chrono::milliseconds timeout) const;
  bool finished() const noexcept;

  // Any thread, lock-free reads.
  PipelineStats stats() const;
  // For the status message. Over the last status period: no_camera (no pair for no_frame_timeout, or
  // the source reports Error), stale_frames, frame_drops. calibration_invalid: rectify refused a pair in
  // the period, or refused the last pair it saw (held until a pair fits again).
  // low_texture: the last measurement was TooFewPoints. frame_rate_hz: pairs acquired per second.
  // dropped_frames: dropped + stale since start. can_tx_drops, bus_off, recording_error stay false: the
  // sinks that know them set them.
  SensorHealth health() const;
  // For a watchdog: count of published measurements and the CLOCK_MONOTONIC time of the last one
  // (0: none yet). Ping only while these advance.
  std::uint64_t progress() const noexcept;
  std::int64_t last_publish_ns() const noexcept;
  // What start() could not apply of config.threads (e.g. "match: SCHED_FIFO 50: Operation not
  // permitted"); empty when everything applied. Valid after start().
  const std::vector<std::string>& placement_warnings() const noexcept;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rutd
