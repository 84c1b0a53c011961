#include "runtime/realtime_pipeline.hpp"

#include <pthread.h>
#include <sched.h>
#include <time.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstring>
#include <exception>
#include <limits>
#include <stdexcept>
#include <stop_token>
#include <thread>

#include "core/slot_queue.hpp"
#include "frame_pool.hpp"

namespace rutd {
namespace {

using std::chrono::milliseconds;
using std::chrono::nanoseconds;
constexpr auto kRelaxed = std::memory_order_relaxed;
// Upper bound of every wait inside the pipeline threads: the stop latency beyond a running stage call.
constexpr milliseconds kWait{5};

constexpr std::size_t idx(Stage s) noexcept { return static_cast<std::size_t>(s); }

std::int64_t to_ns(milliseconds ms) noexcept { return std::chrono::duration_cast<nanoseconds>(ms).count(); }

// SensorHealth's flags in CAN bit order, packed so the publish thread can hand them over atomically.
enum HealthBit : std::uint32_t { kNoCamera = 1, kStale = 2, kCalibration = 4, kLowTexture = 8, kDrops = 16 };

void add(std::atomic<std::uint64_t>& counter) noexcept { counter.fetch_add(1, kRelaxed); }

}  // namespace

std::string_view to_string(Stage stage) noexcept {
  switch (stage) {
    case Stage::Acquire: return "acquire";
    case Stage::Rectify: return "rectify";
    case Stage::Match: return "match";
    case Stage::Extract: return "extract";
    case Stage::Publish: return "publish";
  }
  return "?";
}

void validate(const PipelineConfig& c) {
  auto fail = [](const std::string& field, const std::string& why) {
    throw std::invalid_argument("pipeline config: " + field + ": " + why);
  };
  if (c.pool_slots < 6 || c.pool_slots > RealtimePipeline::kMaxPoolSlots)
    fail("pool_slots",
         "must be 6.." + std::to_string(RealtimePipeline::kMaxPoolSlots) + ", got " + std::to_string(c.pool_slots));
  if (c.max_frame_age.count() < 0) fail("max_frame_age", "must be >= 0 ms");
  if (c.status_period.count() <= 0) fail("status_period", "must be > 0 ms");
  if (c.no_frame_timeout.count() <= 0) fail("no_frame_timeout", "must be > 0 ms");
  if (c.log_period.count() < 0) fail("log_period", "must be >= 0 ms");
  for (std::size_t i = 0; i < kStageCount; ++i) {
    const ThreadPlacement& t = c.threads[i];
    const std::string name = "threads." + std::string(to_string(static_cast<Stage>(i)));
    if (t.cpu < -1 || t.cpu >= CPU_SETSIZE) fail(name + ".cpu", "must be -1 (any) or a CPU number");
    if (t.fifo_priority < 0 || t.fifo_priority > 99) fail(name + ".fifo_priority", "must be 0..99");
  }
}

std::uint64_t PipelineStats::in_flight() const noexcept {
  const std::uint64_t handled = published + dropped_total() + stale_total() + rectify_rejected + stage_errors;
  return acquired > handled ? acquired - handled : 0;
}

std::uint64_t PipelineStats::dropped_total() const noexcept {
  std::uint64_t n = 0;
  for (auto d : dropped) n += d;
  return n;
}

std::uint64_t PipelineStats::stale_total() const noexcept {
  std::uint64_t n = 0;
  for (auto d : stale) n += d;
  return n;
}

std::string describe(const PipelineStats& s) {
  auto ms = [](std::int64_t ns) { return static_cast<double>(ns) * 1e-6; };
  char buf[1024];
  int n = std::snprintf(
      buf, sizeof buf,
      "acquired %llu (%.1f Hz) published %llu (%.1f Hz, %llu ok) dropped %llu stale %llu "
      "rejected %llu errors %llu/%llu/%llu timeouts %llu | e2e p50 %.2f p99 %.2f max %.2f ms",
      static_cast<unsigned long long>(s.acquired), s.acquire_hz, static_cast<unsigned long long>(s.published),
      s.publish_hz, static_cast<unsigned long long>(s.published_ok), static_cast<unsigned long long>(s.dropped_total()),
      static_cast<unsigned long long>(s.stale_total()), static_cast<unsigned long long>(s.rectify_rejected),
      static_cast<unsigned long long>(s.source_errors), static_cast<unsigned long long>(s.stage_errors),
      static_cast<unsigned long long>(s.sink_errors), static_cast<unsigned long long>(s.source_timeouts),
      ms(s.end_to_end.p50_ns), ms(s.end_to_end.p99_ns), ms(s.end_to_end.max_ns));
  std::string out(buf, static_cast<std::size_t>(std::clamp(n, 0, static_cast<int>(sizeof buf) - 1)));
  for (std::size_t i = 0; i < kStageCount; ++i) {
    const LatencySummary& l = s.stage_latency[i];
    n = std::snprintf(buf, sizeof buf, " | %s p50 %.2f p99 %.2f ms drop %llu stale %llu",
                      std::string(to_string(static_cast<Stage>(i))).c_str(), ms(l.p50_ns), ms(l.p99_ns),
                      static_cast<unsigned long long>(s.dropped[i]), static_cast<unsigned long long>(s.stale[i]));
    out.append(buf, static_cast<std::size_t>(std::clamp(n, 0, static_cast<int>(sizeof buf) - 1)));
  }
  return out;
}

struct RealtimePipeline::Impl {
  Impl(FrameSource& src, PipelineStages& stg, MeasurementSink& snk, PipelineConfig cfg)
      : source(src), stages(stg), sink(snk), config(std::move(cfg)), pool(config.pool_slots) {
    for (auto& q : forward) q = std::make_unique<SlotQueue<FrameSlot>>(pool.size());
    for (auto& q : back) q = std::make_unique<SlotQueue<FrameSlot>>(pool.size(), &slot_returned);
  }

  FrameSource& source;
  PipelineStages& stages;
  MeasurementSink& sink;
  const PipelineConfig config;
  FramePool pool;
  FrameSlot spare;  // acquisition reads into this when no slot is free, then drops the pair

  // forward[k - 1] feeds stage k (Rectify..Publish); back[k - 1] returns slots from stage k to
  // acquisition, which waits on all four at once (slot_returned, lossless mode). Each has one producer
  // and one consumer thread, and holds every slot of the pool, so a push cannot fail.
  Wakeup slot_returned;
  std::array<std::unique_ptr<SlotQueue<FrameSlot>>, 4> forward, back;
  // Acquisition thread only: free slots in FIFO order, so every slot is used in turn and has seen real
  // frames (content-sized buffers such as the cross-section) after the first pool_slots frames.
  std::vector<FrameSlot*> free_ring;  // pool_slots entries, sized at start
  std::size_t free_head = 0, free_count = 0;
  void push_free(FrameSlot* slot) noexcept { free_ring[(free_head + free_count++) % free_ring.size()] = slot; }
  FrameSlot* pop_free() noexcept {
    if (free_count == 0) return nullptr;
    FrameSlot* slot = free_ring[free_head];
    free_head = (free_head + 1) % free_ring.size();
    --free_count;
    return slot;
  }

  std::array<std::atomic<bool>, kStageCount> done{};  // stage k drained after its upstream finished
  std::array<std::atomic<std::uint64_t>, kStageCount> dropped{}, stale{};
  std::atomic<std::uint64_t> acquired{0}, source_timeouts{0}, source_errors{0}, rejected{0}, fitted{0}, stage_errors{0},
      sink_errors{0}, measured{0}, published{0}, published_ok{0}, status_sent{0};
  std::atomic<std::int64_t> last_publish_ns{0}, last_frame_ns{0};
  std::atomic<bool> source_failing{false};
  std::atomic<std::uint8_t> last_status{static_cast<std::uint8_t>(RutStatus::NoMeasurement)};
  std::atomic<std::uint32_t> health_bits{0};
  std::atomic<double> acquire_hz{0.0}, publish_hz{0.0};

  std::array<LatencyHistogram, kStageCount> stage_latency;  // each written by its own stage thread
  LatencyHistogram end_to_end;                              // publish thread

  std::array<std::jthread, kStageCount> threads;
  std::vector<std::string> warnings;
  bool started = false;

  void prime();
  void place_threads();
  std::int64_t t0_of(const StereoFrame& frame, std::int64_t now) const noexcept {
    return config.capture_clock_is_local && frame.clock == ClockKind::Monotonic ? frame.t_ns : now;
  }
  bool too_old(const FrameSlot& slot, std::int64_t now) const noexcept {
    return config.max_frame_age.count() > 0 && now - slot.t0_ns > to_ns(config.max_frame_age);
  }

  // Hand-overs. The queues hold every slot of the pool, so a push cannot fail.
  void pass_on(Stage to, FrameSlot* slot) noexcept {
    if (!forward[idx(to) - 1]->push(slot)) std::terminate();
  }
  void give_back(Stage from, FrameSlot* slot) noexcept {
    if (!back[idx(from) - 1]->push(slot)) std::terminate();
  }
  std::uint64_t input_mark(Stage stage) const noexcept { return forward[idx(stage) - 1]->mark(); }
  void wait_for_input(Stage stage, std::uint64_t since, nanoseconds timeout) noexcept {
    forward[idx(stage) - 1]->wait(since, timeout);
  }
  FrameSlot* take(Stage stage) noexcept;
  void reclaim() noexcept;

  void acquire_loop(std::stop_token st);
  void stage_loop(Stage stage, std::stop_token st);
  void run_stage(Stage stage, FrameSlot* slot) noexcept;
  void publish_loop(std::stop_token st);
  void publish_one(FrameSlot* slot) noexcept;
  // Publish thread only: counter totals at the start of the current status period and rate window.
  struct Window {
    std::uint64_t drops = 0, stales = 0, rejected = 0, fitted = 0;
    std::int64_t rate_t0 = 0;
    std::uint64_t acquired = 0, published = 0;
  };
  void update_health(std::int64_t now, Window& window) noexcept;

  PipelineStats stats() const;
  SensorHealth health() const noexcept;
};

void RealtimePipeline::Impl::prime() {
  const cv::Size size = source.calibration().image_size;
  auto prime_frame = [&](StereoFrame& f) {
    f.left.create(size, CV_8UC1);
    f.right.create(size, CV_8UC1);
    f.left.setTo(0);
    f.right.setTo(0);
  };
  prime_frame(spare.work.frame);
  for (std::size_t i = 0; i < pool.size(); ++i) {
    FrameWork& w = pool[i].work;
    prime_frame(w.frame);
    if (stages.rectify(w)) {
      stages.match(w);
      stages.extract(w);
    }
  }
}

void RealtimePipeline::Impl::place_threads() {
  for (std::size_t i = 0; i < kStageCount; ++i) {
    const ThreadPlacement& t = config.threads[i];
    const std::string name(to_string(static_cast<Stage>(i)));
    const pthread_t handle = threads[i].native_handle();
    pthread_setname_np(handle, ("rutd-" + name).c_str());
    if (t.cpu >= 0) {
      cpu_set_t set;
      CPU_ZERO(&set);
      CPU_SET(t.cpu, &set);
      if (const int err = pthread_setaffinity_np(handle, sizeof set, &set))
        warnings.push_back(name + ": CPU " + std::to_string(t.cpu) + ": " + std::strerror(err));
    }
    if (t.fifo_priority > 0) {
      sched_param param{};
      param.sched_priority = t.fifo_priority;
      if (const int err = pthread_setschedparam(handle, SCHED_FIFO, &param))
        warnings.push_back(name + ": SCHED_FIFO " + std::to_string(t.fifo_priority) + ": " + std::strerror(err));
    }
  }
}

FrameSlot* RealtimePipeline::Impl::take(Stage stage) noexcept {
  SlotQueue<FrameSlot>& in = *forward[idx(stage) - 1];
  if (config.lossless) return in.pop();
  FrameSlot* newest = nullptr;
  while (FrameSlot* slot = in.pop()) {
    if (newest != nullptr) {
      add(dropped[idx(stage)]);
      give_back(stage, newest);
    }
    newest = slot;
  }
  return newest;
}

void RealtimePipeline::Impl::reclaim() noexcept {
  for (auto& queue : back)
    while (FrameSlot* slot = queue->pop()) push_free(slot);  // at most pool_slots: never overruns the ring
}

void RealtimePipeline::Impl::acquire_loop(std::stop_token st) {
  int error_streak = 0;
  while (!st.stop_requested()) {
    const std::uint64_t since = slot_returned.mark();
    reclaim();
    FrameSlot* slot = pop_free();
    if (slot == nullptr) {
      if (config.lossless) {
        slot_returned.wait(since, kWait);
        continue;
      }
      slot = &spare;
    }

    SourceStatus status = SourceStatus::Error;
    try {
      status = source.next(slot->work.frame);
    } catch (...) {  // a source must not throw per frame; treat it as a failed read
      status = SourceStatus::Error;
    }
    const std::int64_t now = monotonic_now_ns();
    if (status != SourceStatus::Ok) {
      if (slot != &spare) push_free(slot);
      if (status == SourceStatus::EndOfStream) {
        done[idx(Stage::Acquire)].store(true, std::memory_order_release);
        return;
      }
      if (status == SourceStatus::Timeout) {
        add(source_timeouts);
        continue;
      }
      add(source_errors);
      source_failing.store(true, kRelaxed);
      // Back off a source that fails at once (unplugged camera), at most 64 ms, so stop stays prompt.
      std::this_thread::sleep_for(milliseconds(1 << std::min(error_streak++, 6)));
      continue;
    }
    error_streak = 0;
    source_failing.store(false, kRelaxed);
    last_frame_ns.store(now, kRelaxed);
    add(acquired);
    slot->acquired_ns = now;
    slot->t0_ns = t0_of(slot->work.frame, now);
    stage_latency[idx(Stage::Acquire)].record(now - slot->t0_ns);
    if (slot == &spare) {
      add(dropped[idx(Stage::Acquire)]);
    } else if (too_old(*slot, now)) {
      add(stale[idx(Stage::Acquire)]);
      push_free(slot);
    } else {
      pass_on(Stage::Rectify, slot);
    }
  }
}

void RealtimePipeline::Impl::run_stage(Stage stage, FrameSlot* slot) noexcept {
  const std::size_t k = idx(stage);
  const std::int64_t t0 = monotonic_now_ns();
  if (too_old(*slot, t0)) {
    add(stale[k]);
    give_back(stage, slot);
    return;
  }
  bool keep = true;
  try {
    FrameWork& w = slot->work;
    if (stage == Stage::Rectify) {
      keep = stages.rectify(w);
      add(keep ? fitted : rejected);
    } else if (stage == Stage::Match) {
      stages.match(w);
    } else {
      stages.extract(w);
      add(measured);
    }
  } catch (...) {
    add(stage_errors);
    keep = false;
  }
  stage_latency[k].record(monotonic_now_ns() - t0);
  if (keep) pass_on(static_cast<Stage>(k + 1), slot);
  else give_back(stage, slot);
}

void RealtimePipeline::Impl::stage_loop(Stage stage, std::stop_token st) {
  const std::size_t k = idx(stage);
  while (!st.stop_requested()) {
    const std::uint64_t since = input_mark(stage);
    FrameSlot* slot = take(stage);
    if (slot == nullptr) {
      // Upstream's done flag is set after its last push: check it first, then the queue once more.
      if (!done[k - 1].load(std::memory_order_acquire)) {
        wait_for_input(stage, since, kWait);
        continue;
      }
      slot = take(stage);
      if (slot == nullptr) {
        done[k].store(true, std::memory_order_release);
        return;
      }
    }
    run_stage(stage, slot);
  }
}

void RealtimePipeline::Impl::publish_one(FrameSlot* slot) noexcept {
  const std::int64_t t0 = monotonic_now_ns();
  if (too_old(*slot, t0)) {
    add(stale[idx(Stage::Publish)]);
    give_back(Stage::Publish, slot);
    return;
  }
  const RutStatus status = slot->work.measurement.status;
  last_status.store(static_cast<std::uint8_t>(status), kRelaxed);
  try {
    sink.publish(published_frame(slot->work, health()));
  } catch (...) {
    add(sink_errors);
  }
  const std::int64_t t1 = monotonic_now_ns();
  stage_latency[idx(Stage::Publish)].record(t1 - t0);
  end_to_end.record(t1 - slot->t0_ns);
  if (status == RutStatus::Ok) add(published_ok);
  last_publish_ns.store(t1, kRelaxed);
  published.fetch_add(1, std::memory_order_release);
  give_back(Stage::Publish, slot);
}

// Flags over the last status period and rates over the last >= 1 s.
void RealtimePipeline::Impl::update_health(std::int64_t now, Window& w) noexcept {
  std::uint64_t drops = 0, stales = 0;
  for (std::size_t i = 0; i < kStageCount; ++i) {
    drops += dropped[i].load(kRelaxed);
    stales += stale[i].load(kRelaxed);
  }
  const std::uint64_t rej = rejected.load(kRelaxed), fit = fitted.load(kRelaxed);
  std::uint32_t bits = 0;
  if (source_failing.load(kRelaxed) || now - last_frame_ns.load(kRelaxed) > to_ns(config.no_frame_timeout))
    bits |= kNoCamera;
  if (stales > w.stales) bits |= kStale;
  // Images that do not fit the calibration are a state of the cameras, not an event: the flag stays up
  // through periods without any pair (a stall, a reconnect under way) and goes down only when a pair fits
  // again. A period with both says so.
  const bool was_invalid = health_bits.load(kRelaxed) & kCalibration;
  if (rej > w.rejected || (was_invalid && fit == w.fitted)) bits |= kCalibration;
  if (drops > w.drops) bits |= kDrops;
  if (last_status.load(kRelaxed) == static_cast<std::uint8_t>(RutStatus::TooFewPoints)) bits |= kLowTexture;
  health_bits.store(bits, kRelaxed);
  w.drops = drops;
  w.stales = stales;
  w.rejected = rej;
  w.fitted = fit;

  constexpr std::int64_t kRateWindowNs = 1'000'000'000;
  if (now - w.rate_t0 >= kRateWindowNs) {
    const std::uint64_t acq = acquired.load(kRelaxed), pub = published.load(kRelaxed);
    const double seconds = static_cast<double>(now - w.rate_t0) * 1e-9;
    acquire_hz.store(static_cast<double>(acq - w.acquired) / seconds, kRelaxed);
    publish_hz.store(static_cast<double>(pub - w.published) / seconds, kRelaxed);
    w.rate_t0 = now;
    w.acquired = acq;
    w.published = pub;
  }
}

void RealtimePipeline::Impl::publish_loop(std::stop_token st) {
  const std::int64_t period = to_ns(config.status_period);
  const std::int64_t log_period = config.on_log ? to_ns(config.log_period) : 0;
  std::int64_t now = monotonic_now_ns();
  std::int64_t next_status = now + period;
  std::int64_t next_log = now + log_period;
  Window window;
  window.rate_t0 = now;
  while (!st.stop_requested()) {
    const std::uint64_t since = input_mark(Stage::Publish);
    FrameSlot* slot = take(Stage::Publish);
    if (slot == nullptr && done[idx(Stage::Extract)].load(std::memory_order_acquire)) {
      slot = take(Stage::Publish);
      if (slot == nullptr) {
        // The stream ended (a finite source): one last status, so that what happened since the last one
        // (frames refused as stale at the very end, say) still reaches the sink.
        update_health(monotonic_now_ns(), window);
        try {
          sink.publish_status(health(), monotonic_now_ns());
        } catch (...) {
          add(sink_errors);
        }
        add(status_sent);
        done[idx(Stage::Publish)].store(true, std::memory_order_release);
        return;
      }
    }
    if (slot != nullptr) publish_one(slot);

    now = monotonic_now_ns();
    // A source that starts failing (camera lost) is told at once, not at the next period: the status
    // message is how the vehicle learns that measurements stopped. The periodic phase is kept.
    const bool newly_failing = source_failing.load(kRelaxed) && (health_bits.load(kRelaxed) & kNoCamera) == 0;
    const bool periodic = now >= next_status;
    if (newly_failing || periodic) {
      update_health(now, window);
      try {
        sink.publish_status(health(), now);
      } catch (...) {
        add(sink_errors);
      }
      add(status_sent);
    }
    if (periodic) {
      // Keep the phase; after a stall send one status now rather than a burst.
      next_status = std::max(next_status + period, now + 1);
    }
    if (log_period > 0 && now >= next_log) {
      config.on_log(stats());
      next_log = std::max(next_log + log_period, now + 1);
    }
    if (slot == nullptr) {
      const auto until_status = nanoseconds(std::max<std::int64_t>(next_status - monotonic_now_ns(), 0));
      wait_for_input(Stage::Publish, since, std::min<nanoseconds>(kWait, until_status));
    }
  }
}

SensorHealth RealtimePipeline::Impl::health() const noexcept {
  SensorHealth h;
  const std::uint32_t bits = health_bits.load(kRelaxed);
  h.no_camera = bits & kNoCamera;
  h.stale_frames = bits & kStale;
  h.calibration_invalid = bits & kCalibration;
  h.low_texture = bits & kLowTexture;
  h.frame_drops = bits & kDrops;
  h.frame_rate_hz = acquire_hz.load(kRelaxed);
  std::uint64_t lost = 0;
  for (std::size_t i = 0; i < kStageCount; ++i) lost += dropped[i].load(kRelaxed) + stale[i].load(kRelaxed);
  h.dropped_frames =
      static_cast<std::uint32_t>(std::min<std::uint64_t>(lost, std::numeric_limits<std::uint32_t>::max()));
  h.last_status = static_cast<RutStatus>(last_status.load(kRelaxed));
  return h;
}

PipelineStats RealtimePipeline::Impl::stats() const {
  PipelineStats s;
  s.acquired = acquired.load(kRelaxed);
  s.source_timeouts = source_timeouts.load(kRelaxed);
  s.source_errors = source_errors.load(kRelaxed);
  for (std::size_t i = 0; i < kStageCount; ++i) {
    s.dropped[i] = dropped[i].load(kRelaxed);
    s.stale[i] = stale[i].load(kRelaxed);
    s.stage_latency[i] = stage_latency[i].summary();
  }
  s.rectify_rejected = rejected.load(kRelaxed);
  s.stage_errors = stage_errors.load(kRelaxed);
  s.sink_errors = sink_errors.load(kRelaxed);
  s.measured = measured.load(kRelaxed);
  s.published = published.load(std::memory_order_acquire);
  s.published_ok = published_ok.load(kRelaxed);
  s.status_sent = status_sent.load(kRelaxed);
  s.last_publish_ns = last_publish_ns.load(kRelaxed);
  s.acquire_hz = acquire_hz.load(kRelaxed);
  s.publish_hz = publish_hz.load(kRelaxed);
  s.end_to_end = end_to_end.summary();
  s.finished = done[idx(Stage::Publish)].load(std::memory_order_acquire);
  return s;
}

RealtimePipeline::RealtimePipeline(FrameSource& source, PipelineStages& stages, MeasurementSink& sink,
                                   PipelineConfig config) {
  validate(config);
  impl_ = std::make_unique<Impl>(source, stages, sink, std::move(config));
}

RealtimePipeline::~RealtimePipeline() { stop(); }

void RealtimePipeline::start() {
  Impl& m = *impl_;
  if (m.started) throw std::logic_error("RealtimePipeline::start called twice");
  m.started = true;
  if (m.config.prime_slots) m.prime();
  m.free_ring.assign(m.pool.size(), nullptr);
  for (std::size_t i = 0; i < m.pool.size(); ++i) m.push_free(&m.pool[i]);
  m.last_frame_ns.store(monotonic_now_ns(), kRelaxed);
  m.threads[idx(Stage::Acquire)] = std::jthread([&m](std::stop_token st) { m.acquire_loop(st); });
  for (Stage s : {Stage::Rectify, Stage::Match, Stage::Extract})
    m.threads[idx(s)] = std::jthread([&m, s](std::stop_token st) { m.stage_loop(s, st); });
  m.threads[idx(Stage::Publish)] = std::jthread([&m](std::stop_token st) { m.publish_loop(st); });
  m.place_threads();
}

void RealtimePipeline::stop() {
  if (!impl_) return;
  for (auto& t : impl_->threads) t.request_stop();
  for (auto& t : impl_->threads)
    if (t.joinable()) t.join();
}

bool RealtimePipeline::drain(std::chrono::milliseconds timeout) {
  if (!impl_ || !impl_->started) return false;
  std::jthread& acquire = impl_->threads[idx(Stage::Acquire)];
  acquire.request_stop();
  if (acquire.joinable()) acquire.join();
  // Its last push is done: downstream now sees the end of the stream (stage_loop) and drains.
  impl_->done[idx(Stage::Acquire)].store(true, std::memory_order_release);
  return wait_finished(timeout);
}

bool RealtimePipeline::finished() const noexcept {
  return impl_->done[idx(Stage::Publish)].load(std::memory_order_acquire);
}

bool RealtimePipeline::wait_finished(std::chrono::milliseconds timeout) const {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!finished()) {
    if (std::chrono::steady_clock::now() >= deadline) return false;
    std::this_thread::sleep_for(milliseconds(1));
  }
  return true;
}

PipelineStats RealtimePipeline::stats() const { return impl_->stats(); }
SensorHealth RealtimePipeline::health() const { return impl_->health(); }
std::uint64_t RealtimePipeline::progress() const noexcept { return impl_->published.load(std::memory_order_acquire); }
std::int64_t RealtimePipeline::last_publish_ns() const noexcept { return impl_->last_publish_ns.load(kRelaxed); }
const std::vector<std::string>& RealtimePipeline::placement_warnings() const noexcept { return impl_->warnings; }

}  // namespace rutd
