// The real-time pipeline with fake stages (sleep, count, gate, fail) and with the real measurer's stages:
// freshest frame wins, acquisition never waits, stale frames refused, bounded stop, draining at end of
// stream, every acquired frame accounted for, status at a fixed rate, and no heap allocation per frame.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <memory>
#include <new>
#include <semaphore>
#include <stdexcept>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "runtime/realtime_pipeline.hpp"
#include "synthetic/cycling_source.hpp"
#include "synthetic/synthetic_renderer.hpp"

// ---- Allocation counter -------------------------------------------------------------------------
// Counts heap allocations made by any thread while g_counting is set: every call of the malloc family
// (OpenCV allocates cv::Mat data with posix_memalign, not operator new). Without a sanitizer the malloc
// family itself is replaced; AddressSanitizer and ThreadSanitizer own malloc (a replacement would run
// before their run-time is set up), so there their allocator's hooks count instead.
namespace {
std::atomic<bool> g_counting{false};
std::atomic<std::uint64_t> g_allocations{0};
void note_allocation() noexcept {
  if (g_counting.load(std::memory_order_relaxed)) g_allocations.fetch_add(1, std::memory_order_relaxed);
}
}  // namespace

#if defined(__SANITIZE_THREAD__) || defined(__SANITIZE_ADDRESS__)
// sanitizer/allocator_interface.h, which GCC does not install; libasan and libtsan define it.
extern "C" int __sanitizer_install_malloc_and_free_hooks(void (*malloc_hook)(const volatile void*, std::size_t),
                                                         void (*free_hook)(const volatile void*));
namespace {
void on_malloc(const volatile void*, std::size_t) { note_allocation(); }
void on_free(const volatile void*) {}
const int g_hooks_installed = __sanitizer_install_malloc_and_free_hooks(on_malloc, on_free);
bool g_hooks_installed_or_replaced() { return g_hooks_installed != 0; }
}  // namespace
#else
namespace {
bool g_hooks_installed_or_replaced() { return true; }
}  // namespace
extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* __libc_memalign(std::size_t, std::size_t);
void __libc_free(void*);

void* malloc(std::size_t n) {
  note_allocation();
  return __libc_malloc(n);
}
void* calloc(std::size_t n, std::size_t size) {
  note_allocation();
  return __libc_calloc(n, size);
}
void* realloc(void* p, std::size_t n) {
  note_allocation();
  return __libc_realloc(p, n);
}
void free(void* p) { __libc_free(p); }
void* memalign(std::size_t alignment, std::size_t n) {
  note_allocation();
  return __libc_memalign(alignment, n);
}
void* aligned_alloc(std::size_t alignment, std::size_t n) {
  note_allocation();
  return __libc_memalign(alignment, n);
}
int posix_memalign(void** out, std::size_t alignment, std::size_t n) {
  note_allocation();
  void* p = __libc_memalign(alignment, n);
  if (p == nullptr) return ENOMEM;
  *out = p;
  return 0;
}
}
#endif

namespace rutd {
namespace {

using namespace std::chrono_literals;
using std::chrono::microseconds;
using std::chrono::milliseconds;

constexpr std::size_t idx(Stage s) { return static_cast<std::size_t>(s); }

// Polls `done` every millisecond up to `limit`; true when it became true.
template <class F>
bool eventually(F done, milliseconds limit = 10s) {
  const auto deadline = std::chrono::steady_clock::now() + limit;
  while (!done()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(1ms);
  }
  return true;
}

// ---- Fakes ---------------------------------------------------------------------------------------

struct SourceOptions {
  microseconds period{0};                                            // 0: as fast as asked
  std::uint64_t frames = std::numeric_limits<std::uint64_t>::max();  // then EndOfStream
  std::uint64_t old_every = 0;                                       // every n-th pair is stamped one second old
  bool timeouts_only = false;                                        // a camera that never delivers
  std::counting_semaphore<>* gate = nullptr;                         // one permit per pair; Timeout after 5 ms without
};

// Tiny pairs on this machine's CLOCK_MONOTONIC. Records when acquisition called next().
class FakeSource final : public FrameSource {
 public:
  explicit FakeSource(SourceOptions options, cv::Size size = {32, 24}) : options_(options) {
    calibration_.image_size = size;
    calls_ns.reserve(1 << 16);
  }
  SourceStatus next(StereoFrame& f) override {
    const std::int64_t entered = monotonic_now_ns();
    if (calls_ns.size() < calls_ns.capacity()) calls_ns.push_back(entered);
    if (seq_ >= options_.frames) return SourceStatus::EndOfStream;
    if (options_.timeouts_only) {
      std::this_thread::sleep_for(2ms);
      return SourceStatus::Timeout;
    }
    if (options_.gate != nullptr && !options_.gate->try_acquire_for(5ms)) return SourceStatus::Timeout;
    if (options_.period.count() > 0) {
      if (due_ == std::chrono::steady_clock::time_point{}) due_ = std::chrono::steady_clock::now();
      due_ += options_.period;
      std::this_thread::sleep_until(due_);
    }
    f.left.create(calibration_.image_size, CV_8UC1);
    f.right.create(calibration_.image_size, CV_8UC1);
    f.left.at<std::uint8_t>(0, 0) = static_cast<std::uint8_t>(seq_);
    f.seq = seq_;
    const bool old = options_.old_every > 0 && seq_ % options_.old_every == options_.old_every - 1;
    f.t_ns = monotonic_now_ns() - (old ? 1'000'000'000 : 0);
    f.clock = ClockKind::Monotonic;
    ++seq_;
    delivered.fetch_add(1);
    return SourceStatus::Ok;
  }
  const StereoCalibration& calibration() const override { return calibration_; }
  const std::string& error_message() const override { return error_; }

  std::vector<std::int64_t> calls_ns;  // acquisition thread; read after stop()
  std::atomic<std::uint64_t> delivered{0};

 private:
  SourceOptions options_;
  StereoCalibration calibration_;
  std::string error_;
  std::uint64_t seq_ = 0;
  std::chrono::steady_clock::time_point due_{};
};

struct StageOptions {
  microseconds rectify{0}, match{0}, extract{0};
  std::uint64_t reject_every = 0;                                        // rectify refuses every n-th frame
  std::uint64_t reject_seq = std::numeric_limits<std::uint64_t>::max();  // and the frame of this seq
  std::uint64_t throw_every = 0;                                         // match throws on every n-th frame
  std::counting_semaphore<>* match_gate = nullptr;                       // the first match waits for a permit
};

// Stages that take a set time and stamp the frame's seq into the measurement (the sink checks it, so a
// slot mixed up between frames shows).
class FakeStages final : public PipelineStages {
 public:
  explicit FakeStages(StageOptions options) : options_(options) {}
  bool rectify(FrameWork& w) override {
    std::this_thread::sleep_for(options_.rectify);
    rectified.fetch_add(1);
    if (w.frame.seq == options_.reject_seq) return false;
    return !(options_.reject_every > 0 && w.frame.seq % options_.reject_every == options_.reject_every - 1);
  }
  void match(FrameWork& w) override {
    match_entered.fetch_add(1);
    if (options_.match_gate != nullptr && !gate_passed_) {
      gate_passed_ = options_.match_gate->try_acquire_for(10s);
    }
    std::this_thread::sleep_for(options_.match);
    if (options_.throw_every > 0 && w.frame.seq % options_.throw_every == options_.throw_every - 1)
      throw std::runtime_error("fake match failure");
  }
  void extract(FrameWork& w) override {
    std::this_thread::sleep_for(options_.extract);
    w.measurement = RutMeasurement{};
    w.measurement.status = RutStatus::Ok;
    w.measurement.depth_mm = static_cast<double>(w.frame.seq);
  }
  std::atomic<std::uint64_t> rectified{0}, match_entered{0};

 private:
  StageOptions options_;
  bool gate_passed_ = false;  // match thread only
};

class FakeSink final : public MeasurementSink {
 public:
  FakeSink() {
    seqs.reserve(1 << 16);
    calibration_flags.reserve(1 << 16);
  }
  void publish(const PublishedFrame& f) override {
    if (seqs.size() < seqs.capacity()) seqs.push_back(f.seq);
    if (f.measurement.status == RutStatus::Ok && f.measurement.depth_mm != static_cast<double>(f.seq))
      mismatches.fetch_add(1);
    published.fetch_add(1);
  }
  void publish_status(const SensorHealth& h, std::int64_t) override {
    statuses.fetch_add(1);
    if (calibration_flags.size() < calibration_flags.capacity()) calibration_flags.push_back(h.calibration_invalid);
    if (h.no_camera) saw_no_camera.store(true);
    if (h.stale_frames) saw_stale.store(true);
    if (h.frame_drops) saw_drops.store(true);
  }
  std::vector<std::uint64_t> seqs;      // publish thread; read after stop()
  std::vector<char> calibration_flags;  // each status's calibration_invalid, in order; as seqs
  std::atomic<std::uint64_t> published{0}, statuses{0}, mismatches{0};
  std::atomic<bool> saw_no_camera{false}, saw_stale{false}, saw_drops{false};
};

PipelineConfig test_config() {
  PipelineConfig c;
  c.prime_slots = false;
  c.max_frame_age = 0ms;
  c.status_period = 20ms;
  return c;
}

std::uint64_t accounted(const PipelineStats& s) {
  return s.published + s.dropped_total() + s.stale_total() + s.rectify_rejected + s.stage_errors;
}

void print_latency(const char* what, const LatencySummary& l) {
  std::printf("  %-10s n=%-6llu p50 %8.3f  p90 %8.3f  p99 %8.3f  max %8.3f ms\n", what,
              static_cast<unsigned long long>(l.count), l.p50_ns * 1e-6, l.p90_ns * 1e-6, l.p99_ns * 1e-6,
              l.max_ns * 1e-6);
}

void print_stats(const PipelineStats& s) {
  std::printf("%s\n", describe(s).c_str());
  for (std::size_t i = 0; i < kStageCount; ++i)
    print_latency(std::string(to_string(static_cast<Stage>(i))).c_str(), s.stage_latency[i]);
  print_latency("end-to-end", s.end_to_end);
}

// ---- Tests ---------------------------------------------------------------------------------------

TEST(RealtimePipeline, SlowMatchDropsOldestFramesAndAcquisitionKeepsItsOwnRate) {
  FakeSource source({.period = 5ms});
  FakeStages stages({.match = 100ms});
  FakeSink sink;
  PipelineConfig config = test_config();
  config.pool_slots = 48;  // room for a whole match period of frames: drops happen at match's input
  RealtimePipeline pipeline(source, stages, sink, config);
  pipeline.start();
  std::this_thread::sleep_for(1500ms);
  const std::uint64_t progress_mid = pipeline.progress();
  const std::int64_t last_mid = pipeline.last_publish_ns();
  std::this_thread::sleep_for(300ms);
  EXPECT_GT(pipeline.progress(), progress_mid);  // the watchdog's view advances while it measures
  EXPECT_GT(pipeline.last_publish_ns(), last_mid);
  pipeline.stop();
  const PipelineStats s = pipeline.stats();
  print_stats(s);

  EXPECT_GT(s.dropped[idx(Stage::Match)], 0u);
  EXPECT_GE(s.published, 5u);
  EXPECT_LT(s.published * 4, s.acquired);  // most frames superseded, not queued up
  EXPECT_EQ(sink.mismatches.load(), 0u);
  EXPECT_TRUE(std::is_sorted(sink.seqs.begin(), sink.seqs.end()));
  EXPECT_TRUE(std::adjacent_find(sink.seqs.begin(), sink.seqs.end()) == sink.seqs.end());
  EXPECT_LE(accounted(s), s.acquired);  // the rest were in flight at stop()
  EXPECT_TRUE(sink.saw_drops.load());

  // Acquisition never waits for the 100 ms match: the source is asked at its own 5 ms rate.
  std::vector<std::int64_t> gaps;
  for (std::size_t i = 1; i < source.calls_ns.size(); ++i) gaps.push_back(source.calls_ns[i] - source.calls_ns[i - 1]);
  ASSERT_GT(gaps.size(), 100u);
  std::sort(gaps.begin(), gaps.end());
  const double p50 = gaps[gaps.size() / 2] * 1e-6, p95 = gaps[gaps.size() * 95 / 100] * 1e-6;
  std::printf("source call gaps: p50 %.2f ms, p95 %.2f ms, max %.2f ms\n", p50, p95, gaps.back() * 1e-6);
  EXPECT_LT(p95, 50.0);  // a blocked acquisition would wait ~100 ms per match
  // Freshest frame wins: a published frame waited at most about one match in front of it.
  EXPECT_LT(s.end_to_end.p50_ns, 400'000'000);
}

TEST(RealtimePipeline, FreshestQueuedFrameWinsAndTheOlderOnesAreCountedAsDropped) {
  std::counting_semaphore<> source_gate(0), match_gate(0);
  FakeSource source({.gate = &source_gate});
  FakeStages stages({.match_gate = &match_gate});
  FakeSink sink;
  RealtimePipeline pipeline(source, stages, sink, test_config());
  pipeline.start();
  source_gate.release(1);  // frame 0 enters match and waits at the gate
  ASSERT_TRUE(eventually([&] { return stages.match_entered.load() == 1; }));
  for (std::uint64_t n = 2; n <= 6; ++n) {  // frames 1..5 queue in front of match, one by one so that
    source_gate.release(1);                 // rectify (freshest wins too) sees each of them
    ASSERT_TRUE(eventually([&] { return stages.rectified.load() == n; })) << "rectified " << stages.rectified.load();
  }
  std::this_thread::sleep_for(50ms);  // let rectify hand frame 5 over
  match_gate.release();
  ASSERT_TRUE(eventually([&] { return accounted(pipeline.stats()) == 6; }));
  pipeline.stop();
  const PipelineStats s = pipeline.stats();
  // Match finished frame 0, then took frame 5 and gave 1..4 back. (Whether extract still sees frame 0
  // before frame 5 catches up with it is up to the scheduler: freshest wins there too.)
  EXPECT_EQ(s.dropped[idx(Stage::Match)], 4u);
  ASSERT_FALSE(sink.seqs.empty());
  EXPECT_EQ(sink.seqs.back(), 5u);
  EXPECT_EQ(s.published + s.dropped[idx(Stage::Extract)] + s.dropped[idx(Stage::Publish)], 2u);
  EXPECT_EQ(s.acquired, 6u);
  EXPECT_EQ(accounted(s), 6u);
}

TEST(RealtimePipeline, FramesTooOldAtAcquisitionAreRefused) {
  FakeSource source({.frames = 40, .old_every = 2});  // odd seqs stamped one second old
  FakeStages stages({});
  FakeSink sink;
  PipelineConfig config = test_config();
  config.lossless = true;
  config.max_frame_age = 200ms;
  RealtimePipeline pipeline(source, stages, sink, config);
  pipeline.start();
  ASSERT_TRUE(pipeline.wait_finished(10s));
  pipeline.stop();
  const PipelineStats s = pipeline.stats();
  EXPECT_EQ(s.stale[idx(Stage::Acquire)], 20u);
  EXPECT_EQ(s.published, 20u);
  for (std::uint64_t seq : sink.seqs) EXPECT_EQ(seq % 2, 0u);
}

TEST(RealtimePipeline, FramesThatAgeInsideThePipelineAreRefusedBeforePublishing) {
  FakeSource source({.frames = 5});
  FakeStages stages({.extract = 60ms});
  FakeSink sink;
  PipelineConfig config = test_config();
  config.lossless = true;  // every frame queues in front of the slow extract and ages there
  config.max_frame_age = 30ms;
  RealtimePipeline pipeline(source, stages, sink, config);
  pipeline.start();
  ASSERT_TRUE(pipeline.wait_finished(10s));
  pipeline.stop();
  const PipelineStats s = pipeline.stats();
  print_stats(s);
  EXPECT_EQ(s.published, 0u);
  EXPECT_GE(s.stale[idx(Stage::Publish)], 1u);  // at least the first frame: 60 ms in extract
  EXPECT_EQ(s.stale[idx(Stage::Extract)] + s.stale[idx(Stage::Publish)], 5u);
  EXPECT_EQ(accounted(s), 5u);
  EXPECT_TRUE(sink.saw_stale.load()) << "frames were refused for age but no status said StaleFrames";
}

// A source at 1 kHz into stages of 20, 30 and 20 ms: every slot in flight, most pairs dropped.
struct UnderLoad {
  FakeSource source{{.period = 1ms}};
  FakeStages stages{{.rectify = 20ms, .match = 30ms, .extract = 20ms}};
  FakeSink sink;
  // Started, and run for 300 ms.
  std::unique_ptr<RealtimePipeline> run() {
    auto pipeline = std::make_unique<RealtimePipeline>(source, stages, sink, test_config());
    pipeline->start();
    std::this_thread::sleep_for(300ms);
    return pipeline;
  }
};

TEST(RealtimePipeline, StopUnderLoadReturnsWithinOneSecond) {
  UnderLoad load;
  {
    const std::unique_ptr<RealtimePipeline> running = load.run();
    RealtimePipeline& pipeline = *running;
    const auto t0 = std::chrono::steady_clock::now();
    pipeline.stop();
    const auto took = std::chrono::steady_clock::now() - t0;
    std::printf("stop() took %.2f ms\n", std::chrono::duration<double, std::milli>(took).count());
    EXPECT_LT(took, 1s);  // a bound on shutdown, not a speed figure
    EXPECT_GT(pipeline.stats().published, 0u);
    EXPECT_FALSE(pipeline.finished());
  }
  // Destroying a running pipeline stops it too.
  const auto t0 = std::chrono::steady_clock::now();
  {
    RealtimePipeline pipeline(load.source, load.stages, load.sink, test_config());
    pipeline.start();
    std::this_thread::sleep_for(100ms);
  }
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 1100ms);
}

// The daemon's stop: acquisition ends, and every pair it took is handled (published, or dropped, stale,
// rejected, failed, each counted) before the threads stop; stop() alone abandons those in flight.
TEST(RealtimePipeline, DrainHandlesEveryAcquiredFrameBeforeStopping) {
  UnderLoad load;
  const std::unique_ptr<RealtimePipeline> running = load.run();
  RealtimePipeline& pipeline = *running;
  ASSERT_TRUE(pipeline.drain(5s));
  const PipelineStats drained = pipeline.stats();
  std::this_thread::sleep_for(50ms);
  pipeline.stop();
  const PipelineStats s = pipeline.stats();
  print_stats(s);
  EXPECT_TRUE(s.finished);
  EXPECT_GT(s.published, 0u);
  EXPECT_EQ(accounted(s), s.acquired);
  EXPECT_EQ(s.acquired, drained.acquired) << "acquisition went on after drain()";
  EXPECT_EQ(s.published, load.sink.published.load());
  EXPECT_EQ(load.sink.mismatches.load(), 0u);
}

TEST(RealtimePipeline, EndOfStreamDrainsEveryFrameInOrderWhenLossless) {
  FakeSource source({.frames = 200});
  FakeStages stages({.match = 200us});
  FakeSink sink;
  PipelineConfig config = test_config();
  config.lossless = true;
  config.pool_slots = 6;
  RealtimePipeline pipeline(source, stages, sink, config);
  pipeline.start();
  ASSERT_TRUE(pipeline.wait_finished(20s));
  pipeline.stop();
  const PipelineStats s = pipeline.stats();
  EXPECT_TRUE(s.finished);
  ASSERT_EQ(sink.seqs.size(), 200u);
  for (std::uint64_t i = 0; i < 200; ++i) EXPECT_EQ(sink.seqs[i], i);
  EXPECT_EQ(s.dropped_total(), 0u);
  EXPECT_EQ(s.published, 200u);
  EXPECT_EQ(s.measured, 200u);
  EXPECT_EQ(sink.mismatches.load(), 0u);
}

TEST(RealtimePipeline, EndOfStreamDrainsAndAccountsForEveryFrameWhenFreshestWins) {
  FakeSource source({.period = 400us, .frames = 600});
  FakeStages stages({.rectify = 100us, .match = 600us, .extract = 100us, .reject_every = 7, .throw_every = 11});
  FakeSink sink;
  PipelineConfig config = test_config();
  config.pool_slots = 8;
  RealtimePipeline pipeline(source, stages, sink, config);
  pipeline.start();
  ASSERT_TRUE(pipeline.wait_finished(20s));
  pipeline.stop();
  const PipelineStats s = pipeline.stats();
  print_stats(s);
  EXPECT_TRUE(s.finished);
  EXPECT_EQ(s.acquired, 600u);
  EXPECT_EQ(accounted(s), 600u);  // published + dropped + stale + rejected + errors
  EXPECT_GT(s.rectify_rejected, 0u);
  EXPECT_GT(s.stage_errors, 0u);
  EXPECT_GT(s.dropped_total(), 0u);
  EXPECT_EQ(s.published, sink.published.load());
  // Publish also lets the freshest frame win: a measured frame superseded in front of it is dropped
  // there (seen when the sink thread is slowed, e.g. under ThreadSanitizer).
  const auto publish = static_cast<std::size_t>(Stage::Publish);
  EXPECT_EQ(s.published + s.dropped[publish] + s.stale[publish], s.measured);
  EXPECT_EQ(sink.mismatches.load(), 0u);
  EXPECT_TRUE(std::is_sorted(sink.seqs.begin(), sink.seqs.end()));
  for (std::uint64_t seq : sink.seqs) {
    EXPECT_NE(seq % 7, 6u);    // rejected by rectify
    EXPECT_NE(seq % 11, 10u);  // match threw
  }
}

TEST(RealtimePipeline, StatusGoesOutAtItsRateWithoutAnyFrameAndFlagsTheMissingCamera) {
  FakeSource source({.timeouts_only = true});
  FakeStages stages({});
  FakeSink sink;
  PipelineConfig config = test_config();
  config.status_period = 20ms;
  config.no_frame_timeout = 50ms;
  config.log_period = 50ms;
  std::atomic<int> logs{0};
  config.on_log = [&](const PipelineStats&) { logs.fetch_add(1); };
  RealtimePipeline pipeline(source, stages, sink, config);
  pipeline.start();
  std::this_thread::sleep_for(500ms);
  pipeline.stop();
  const PipelineStats s = pipeline.stats();
  std::printf("status frames in 500 ms at 20 ms: %llu, log calls: %d\n", static_cast<unsigned long long>(s.status_sent),
              logs.load());
  EXPECT_GE(s.status_sent, 5u);  // ~25 expected; generous for a loaded machine
  EXPECT_EQ(s.status_sent, sink.statuses.load());
  EXPECT_LE(s.status_sent, 26u);  // never a burst beyond the period
  EXPECT_GE(logs.load(), 1);
  EXPECT_TRUE(sink.saw_no_camera.load());
  EXPECT_TRUE(pipeline.health().no_camera);
  EXPECT_EQ(s.published, 0u);
  EXPECT_EQ(pipeline.progress(), 0u);
  EXPECT_EQ(pipeline.last_publish_ns(), 0);
  EXPECT_GT(s.source_timeouts, 0u);
}

// A pair that does not fit the calibration raises CalibrationInvalid, and the flag stays up through
// status periods without any pair (a camera stalled or reconnecting after it was reconfigured) until a
// pair fits again: a period in which nothing was seen says nothing new about the cameras.
TEST(RealtimePipeline, CalibrationInvalidHoldsUntilAPairFitsAgain) {
  std::counting_semaphore<> gate(0);
  FakeSource source({.gate = &gate});
  FakeStages stages({.reject_seq = 3});
  FakeSink sink;
  PipelineConfig config = test_config();
  config.status_period = 20ms;
  config.no_frame_timeout = 60s;  // the gaps below are not a lost camera
  config.lossless = true;         // every pair released is measured, none superseded
  RealtimePipeline pipeline(source, stages, sink, config);
  pipeline.start();
  gate.release(3);  // seqs 0..2 fit
  ASSERT_TRUE(eventually([&] { return pipeline.stats().published == 3; }));
  std::this_thread::sleep_for(100ms);
  gate.release(1);  // seq 3 does not fit, then 300 ms without any pair
  ASSERT_TRUE(eventually([&] { return pipeline.stats().rectify_rejected == 1; }));
  EXPECT_TRUE(eventually([&] { return pipeline.health().calibration_invalid; }, 1s));
  std::this_thread::sleep_for(300ms);
  EXPECT_TRUE(pipeline.health().calibration_invalid) << "the flag fell without a pair that fits";
  gate.release(1);  // seq 4 fits
  ASSERT_TRUE(eventually([&] { return pipeline.stats().published == 4; }));
  std::this_thread::sleep_for(100ms);
  pipeline.stop();

  // The flags in order: down, then up in one run covering the 300 ms gap, then down again.
  const std::vector<char>& f = sink.calibration_flags;
  const auto first_up = std::find(f.begin(), f.end(), 1);
  ASSERT_NE(first_up, f.end()) << "no status said CalibrationInvalid";
  const auto last_up = f.begin() + (f.rend() - std::find(f.rbegin(), f.rend(), 1));  // one past the last
  const auto run = static_cast<int>(last_up - first_up);
  std::printf("%zu status frames: %td before the refused pair, a run of %d flagged, %td after\n", f.size(),
              first_up - f.begin(), run, f.end() - last_up);
  EXPECT_EQ(std::count(first_up, last_up, 1), run) << "the flag fell inside the run";
  EXPECT_GE(run, 8);  // 300 ms at 20 ms a status, with room for a loaded machine
  EXPECT_GE(first_up - f.begin(), 2);
  EXPECT_GE(f.end() - last_up, 2) << "the flag stayed up after a pair fitted again";
  EXPECT_FALSE(pipeline.health().calibration_invalid);
}

TEST(RealtimePipeline, ConfigurationIsCheckedAndStartRunsOnce) {
  FakeSource source({.frames = 1});
  FakeStages stages({});
  FakeSink sink;
  PipelineConfig config = test_config();
  config.pool_slots = 3;
  EXPECT_THROW(RealtimePipeline(source, stages, sink, config), std::invalid_argument);
  config.pool_slots = RealtimePipeline::kMaxPoolSlots + 1;
  EXPECT_THROW(RealtimePipeline(source, stages, sink, config), std::invalid_argument);
  config = test_config();
  config.status_period = 0ms;
  EXPECT_THROW(RealtimePipeline(source, stages, sink, config), std::invalid_argument);
  config = test_config();
  config.threads[idx(Stage::Match)].fifo_priority = 100;
  EXPECT_THROW(RealtimePipeline(source, stages, sink, config), std::invalid_argument);

  RealtimePipeline pipeline(source, stages, sink, test_config());
  pipeline.start();
  EXPECT_THROW(pipeline.start(), std::logic_error);
}

TEST(RealtimePipeline, PlacementFailuresAreReportedNotFatal) {
  FakeSource source({.frames = 10});
  FakeStages stages({});
  FakeSink sink;
  PipelineConfig config = test_config();
  config.threads[idx(Stage::Rectify)].cpu = 1000;  // no such CPU here
  RealtimePipeline pipeline(source, stages, sink, config);
  pipeline.start();
  ASSERT_TRUE(pipeline.wait_finished(10s));
  pipeline.stop();
  ASSERT_EQ(pipeline.placement_warnings().size(), 1u);
  EXPECT_NE(pipeline.placement_warnings()[0].find("rectify: CPU 1000"), std::string::npos)
      << pipeline.placement_warnings()[0];
  EXPECT_EQ(pipeline.stats().published, 10u - pipeline.stats().dropped_total());
}

// ---- No allocation per frame ---------------------------------------------------------------------

// Runs the pipeline until `warm` frames were published, then counts allocations over the next
// `counted` acquired frames.
std::uint64_t allocations_in_steady_state(RealtimePipeline& pipeline, FakeSink& sink, std::uint64_t warm,
                                          std::uint64_t counted) {
  pipeline.start();
  EXPECT_TRUE(eventually([&] { return sink.published.load() >= warm; }, 30s));
  const std::uint64_t from = pipeline.stats().acquired;
  g_allocations.store(0);
  g_counting.store(true);
  const bool ran = eventually([&] { return pipeline.stats().acquired >= from + counted; }, 60s);
  g_counting.store(false);
  const PipelineStats s = pipeline.stats();
  pipeline.stop();
  EXPECT_TRUE(ran);
  std::printf("counted %llu acquired / %llu published frames: %llu allocations (%s)\n",
              static_cast<unsigned long long>(s.acquired - from), static_cast<unsigned long long>(s.published),
              static_cast<unsigned long long>(g_allocations.load()),
              g_hooks_installed_or_replaced() ? "malloc family" : "NOT COUNTED: the allocator hooks were refused");
  return g_allocations.load();
}

// The counter itself counts: one malloc inside the counting window is seen (else every "0 allocations"
// below would pass vacuously, e.g. if a sanitizer refused the hooks).
TEST(RealtimePipeline, AllocationCounterSeesMalloc) {
  ASSERT_TRUE(g_hooks_installed_or_replaced());
  g_allocations.store(0);
  g_counting.store(true);
  void* volatile p = std::malloc(123);
  g_counting.store(false);
  std::free(p);
  EXPECT_EQ(g_allocations.load(), 1u);
}

TEST(RealtimePipeline, FakeStagesAllocateNothingPerFrameWhenFreshestWins) {
  FakeSource source({.period = 300us});
  FakeStages stages({.rectify = 100us, .match = 800us, .extract = 100us});
  FakeSink sink;
  PipelineConfig config = test_config();
  config.prime_slots = true;
  config.log_period = 0ms;
  RealtimePipeline pipeline(source, stages, sink, config);
  EXPECT_EQ(allocations_in_steady_state(pipeline, sink, 50, 2000), 0u);
  EXPECT_GT(pipeline.stats().dropped_total(), 0u);  // the drop paths ran while counting too
}

TEST(RealtimePipeline, FakeStagesAllocateNothingPerFrameWhenLossless) {
  FakeSource source({});
  FakeStages stages({.match = 100us});
  FakeSink sink;
  PipelineConfig config = test_config();
  config.prime_slots = true;
  config.lossless = true;
  RealtimePipeline pipeline(source, stages, sink, config);
  EXPECT_EQ(allocations_in_steady_state(pipeline, sink, 50, 2000), 0u);
}

// ---- The real measurer's stages -----------------------------------------------------------------

struct RealRig {
  RealRig() : renderer((sequential_opencv_under_tsan(), params())), frames(renderer.render_pairs(3)) {
    // The band is estimated once (estimate_band allocates), then fixed as a deployed sensor would.
    StereoMeasurer probe(renderer.calibration(), MeasurerConfig{});
    probe.measure(frames[0].left, frames[0].right);
    config.fixed_band = probe.diagnostics().band;
  }
  // OpenCV's parallel_for_ runs on TBB, which ThreadSanitizer cannot see into (false races, crashes):
  // there OpenCV runs its loops on the calling thread. The pipeline's own threads are unaffected.
  static void sequential_opencv_under_tsan() {
#if defined(__SANITIZE_THREAD__)
    cv::setNumThreads(0);
#endif
  }
  static SyntheticRendererConfig params() {
    SyntheticRendererConfig p;
    p.rig.image_size = {320, 240};
    return p;
  }
  SyntheticRenderer renderer;
  std::vector<StereoFrame> frames;
  MeasurerConfig config;
};

// The measured strip's stages; the guard strips' (StripConfig::guards), which extract() measures, below.
TEST(RealtimePipeline, WhichRealStagesAllocatePerFrame) {
  RealRig rig;
  rig.config.strip.guards = 0;
  const StereoMeasurer measurer(rig.renderer.calibration(), rig.config);
  MatchContext context = measurer.make_match_context();
  RutWorkspace workspace;
  FrameWork w;
  auto run = [&](int frames, std::uint64_t& rectify, std::uint64_t& match, std::uint64_t& extract) {
    for (int i = 0; i < frames; ++i) {
      rig.frames[i % rig.frames.size()].left.copyTo(w.frame.left);
      rig.frames[i % rig.frames.size()].right.copyTo(w.frame.right);
      g_allocations.store(0);
      g_counting.store(true);
      ASSERT_TRUE(measurer.rectify(w));
      g_counting.store(false);
      rectify += g_allocations.exchange(0);
      g_counting.store(true);
      measurer.match(w, context);
      g_counting.store(false);
      match += g_allocations.exchange(0);
      g_counting.store(true);
      measurer.extract(w, workspace);
      g_counting.store(false);
      extract += g_allocations.exchange(0);
    }
  };
  std::uint64_t r = 0, m = 0, e = 0;
  run(5, r, m, e);  // warm-up
  r = m = e = 0;
  constexpr int kFrames = 12;
  run(kFrames, r, m, e);
  // Of match: the OpenCV engine alone on the same strips.
  g_allocations.store(0);
  g_counting.store(true);
  for (int i = 0; i < kFrames; ++i) context.engine->compute(w.left_strip, w.right_strip, w.diag.band, w.disparity);
  g_counting.store(false);
  std::printf("of which the %s engine alone: %.2f allocations per call\n",
              std::string(to_string(rig.config.engine)).c_str(), double(g_allocations.load()) / kFrames);
  std::printf(
      "real stages, allocations per frame over %d frames (320x240, %s, DIC %s): rectify %.2f, "
      "match %.2f, extract %.2f; measurement status %s depth %.2f mm\n",
      kFrames, std::string(to_string(rig.config.engine)).c_str(), rig.config.dic ? "on" : "off", double(r) / kFrames,
      double(m) / kFrames, double(e) / kFrames, std::string(to_string(w.measurement.status)).c_str(),
      w.measurement.depth_mm);
  EXPECT_EQ(w.measurement.status, RutStatus::Ok);  // the allocation-free path is the full one
  EXPECT_EQ(r, 0u);
  EXPECT_EQ(e, 0u);
}

// With guard strips, extract() measures each of them whole (StripConfig::guards) on the frames it finds
// OK, their match included: it allocates what the guards' match stages do (OpenCV's matcher and parallel
// loop), measured apart on measurers of the guards' own strips, and nothing else.
TEST(RealtimePipeline, GuardStripsAllocateOnlyWhatTheirMatchDoes) {
  RealRig rig;
  rig.config.strip.guards = 2;
  rig.config.strip.guards_always = true;  // dry sand: by default no water is seen and no guard asked
  const StereoMeasurer measurer(rig.renderer.calibration(), rig.config);
  const std::vector<StripRoi> strips = measurer.guard_strips();
  ASSERT_EQ(strips.size(), 2U);
  struct Apart {
    std::unique_ptr<StereoMeasurer> m;
    MatchContext context;
    RutWorkspace workspace;
    FrameWork w;
  };
  std::vector<Apart> apart(strips.size());
  for (std::size_t k = 0; k < strips.size(); ++k) {
    MeasurerConfig c = rig.config;
    c.strip = StripConfig{.rows = strips[k].rows, .first_row = strips[k].row0, .guards = 0};
    apart[k].m = std::make_unique<StereoMeasurer>(rig.renderer.calibration(), c);
    apart[k].context = apart[k].m->make_match_context();
  }
  MatchContext context = measurer.make_match_context();
  RutWorkspace workspace;
  FrameWork w;
  auto counted = [](bool on, auto&& stage) {
    g_allocations.store(0);
    g_counting.store(on);
    stage();
    g_counting.store(false);
    return g_allocations.exchange(0);
  };
  std::uint64_t extract = 0, apart_match = 0, apart_extract = 0;
  int guards = 0, frames = 0;
  for (int i = 0; i < 17; ++i) {
    const StereoFrame& f = rig.frames[i % rig.frames.size()];
    const bool on = i >= 5;  // after a warm-up
    f.left.copyTo(w.frame.left);
    f.right.copyTo(w.frame.right);
    ASSERT_TRUE(measurer.rectify(w));
    measurer.match(w, context);
    extract += counted(on, [&] { measurer.extract(w, workspace); });
    ASSERT_EQ(w.measurement.status, RutStatus::Ok) << "frame " << i;
    for (Apart& a : apart) {
      f.left.copyTo(a.w.frame.left);
      f.right.copyTo(a.w.frame.right);
      ASSERT_TRUE(a.m->rectify(a.w));
      apart_match += counted(on, [&] { a.m->match(a.w, a.context); });
      apart_extract += counted(on, [&] { a.m->extract(a.w, a.workspace); });
    }
    if (!on) continue;
    guards += w.diag.guard_strips;
    ++frames;
  }
  std::printf(
      "guard strips over %d frames: %d measured; extract allocated %llu times, the guards' strips "
      "measured apart %llu in match and %llu in extract\n",
      frames, guards, static_cast<unsigned long long>(extract), static_cast<unsigned long long>(apart_match),
      static_cast<unsigned long long>(apart_extract));
  EXPECT_EQ(guards, 2 * frames);
  EXPECT_EQ(apart_extract, 0u);
  // The same work: OpenCV's parallel loop allocates a little unlike from call to call.
  EXPECT_LE(extract, apart_match + apart_match / 4 + 4 * static_cast<std::uint64_t>(frames));
}

// Real rectify and extract threads with a match stage that replays the disparity the real matcher
// computed for the same pair (the OpenCV matchers allocate internally; see the test above).
class ReplayedMatchStages final : public PipelineStages {
 public:
  ReplayedMatchStages(const StereoMeasurer& m, std::vector<cv::Mat> disparities)
      : measurer_(m), disparities_(std::move(disparities)) {}
  bool rectify(FrameWork& w) override { return measurer_.rectify(w); }
  void match(FrameWork& w) override { disparities_[w.frame.seq % disparities_.size()].copyTo(w.disparity); }
  void extract(FrameWork& w) override { measurer_.extract(w, workspace_); }

 private:
  const StereoMeasurer& measurer_;
  std::vector<cv::Mat> disparities_;
  RutWorkspace workspace_;
};

TEST(RealtimePipeline, RealRectifyAndExtractAllocateNothingPerFrameInThePipeline) {
  RealRig rig;
  rig.config.strip.guards = 0;  // their matchers allocate (GuardStripsAllocateOnlyInTheirEngine)
  const StereoMeasurer measurer(rig.renderer.calibration(), rig.config);
  std::vector<cv::Mat> disparities;
  {
    StereoMeasurer single(rig.renderer.calibration(), rig.config);
    for (const StereoFrame& f : rig.frames) {
      single.measure(f.left, f.right);
      disparities.push_back(single.disparity().clone());
    }
    EXPECT_EQ(single.measure(rig.frames[0].left, rig.frames[0].right).status, RutStatus::Ok);
  }
  CyclingSource source(rig.renderer.calibration(), rig.frames, 1ms);
  ReplayedMatchStages stages(measurer, disparities);
  FakeSink sink;
  PipelineConfig config = test_config();
  config.prime_slots = true;
  config.lossless = true;
  RealtimePipeline pipeline(source, stages, sink, config);
  // Steady state: every slot has seen every pair (the cross-section's buffers grow with the X extent
  // of the points, so a slot's first sight of a wider pair may still allocate).
  const std::uint64_t warm = 2 * config.pool_slots * rig.frames.size();
  EXPECT_EQ(allocations_in_steady_state(pipeline, sink, warm, 300), 0u);
  print_stats(pipeline.stats());
}

}  // namespace
}  // namespace rutd
