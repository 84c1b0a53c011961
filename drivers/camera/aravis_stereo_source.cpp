#include "camera/aravis_stereo_source.hpp"

#include <algorithm>
#include <condition_variable>
#include <ctime>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "aravis_camera.hpp"
#include "core/monotonic_clock.hpp"
#include "gige_probe.hpp"
#include "usb_hotplug.hpp"

namespace rutd {
namespace {

constexpr std::array<const char*, 2> kSideName{"left", "right"};
constexpr std::int64_t kMs = 1'000'000;

std::int64_t ms_to_ns(double ms) { return static_cast<std::int64_t>(ms * 1e6); }

void check(const AravisSourceConfig& c) {
  auto bad = [](const char* field, const std::string& why) {
    throw std::invalid_argument(std::string(field) + ": " + why);
  };
  if (c.left.empty()) bad("left", "no camera selected");
  if (c.right.empty()) bad("right", "no camera selected");
  if (c.left == c.right) bad("right", "the same camera as left");
  if (!(c.fps > 0)) bad("fps", "must be positive");
  if (c.buffers < 2 || c.buffers > AravisStereoSource::kMaxBuffers)
    bad("buffers", fmt::format("must be 2..{}", AravisStereoSource::kMaxBuffers));
  if (!(c.pairing_window_ms > 0) || c.pairing_window_ms * 2 >= 1000.0 / c.fps)
    bad("pairing_window_ms", "must be positive and below half the frame period");
  if (c.reconnect_min_ms <= 0 || c.reconnect_max_ms < c.reconnect_min_ms)
    bad("reconnect_min_ms", "must be positive and not above reconnect_max_ms");
}

std::string label_of(std::size_t side, const std::string& selector) {
  return fmt::format("{} camera {}", kSideName[side], selector);
}

// Opens (by `open_with`: a device id or an address), configures and starts one camera; throws CameraError.
std::unique_ptr<AravisCamera> open_camera(const CameraListing& listing, const std::string& open_with,
                                          const std::string& label, const AravisSourceConfig& config, cv::Size expected,
                                          const std::shared_ptr<FrameSignal>& signal,
                                          std::vector<std::string>& warnings) {
  auto camera = std::make_unique<AravisCamera>(open_with, label);
  camera->remember(listing);
  camera->configure(config, warnings);
  if (camera->image_size() != expected)
    throw CameraError(
        "roi", fmt::format("{}: delivers {}x{} images but the calibration is for {}x{}", label,
                           camera->image_size().width, camera->image_size().height, expected.width, expected.height));
  camera->start(config, signal, warnings);
  return camera;
}

}  // namespace

// Everything AravisStereoSource is made of; the public class only forwards. Members are used by the
// acquisition thread, except where Connector and Reaper say otherwise.
class AravisStereoSource::Impl {
 public:
  Impl(const AravisSourceConfig& config, StereoCalibration calibration, std::chrono::milliseconds log_period,
       IoFaults* faults);
  ~Impl();
  SourceStatus next(StereoFrame& frame);
  AravisSourceStats stats() const;

  class Connector;
  class Reaper;
  class PairReceiver;
  struct Side {
    std::unique_ptr<AravisCamera> camera;
    std::int64_t last_frame_ns = 0;  // CLOCK_MONOTONIC of the last buffer (or of the start)
    bool awaiting_first = true;
    std::int64_t lost_since_ns = 0;
    std::array<ArvBuffer*, kMaxBuffers> held{};  // buffers the pairer holds, by FrameDescriptor::buffer
    std::array<bool, kMaxBuffers> cut_short{};   // tests: held[i] is to be converted as a short buffer
  };

  void adopt_connected();
  bool check_faults(std::int64_t now);
  void lose(std::size_t side, const std::string& why);
  void fire_triggers(std::int64_t now);
  void drain(std::size_t side);
  void requeue(const FrameDescriptor& frame) noexcept;
  void release_pending() noexcept;
  bool take_pair(StereoFrame& frame);
  SourceStatus report_lost(std::int64_t now);
  void log_stats(std::int64_t now);

  AravisSourceConfig config_;
  StereoCalibration calibration_;
  std::shared_ptr<FrameSignal> signal_;
  std::unique_ptr<Reaper> reaper_;
  std::unique_ptr<Connector> connector_;
  std::unique_ptr<PairReceiver> receiver_;
  StereoPairer pairer_;
  std::array<Side, 2> sides_;
  std::vector<std::string> warnings_;
  std::string error_;
  std::uint64_t seq_ = 0;
  std::int64_t t_offset_ns_ = 0;  // added to camera timestamps after a clock reset
  std::int64_t last_t_ns_ = 0;
  std::int64_t last_pair_mono_ns_ = 0;
  std::int64_t trigger_period_ns_ = 0;
  std::int64_t next_trigger_ns_ = 0;
  std::int64_t stall_ns_ = 0;
  std::int64_t log_period_ns_ = 0;
  std::int64_t next_log_ns_ = 0;
  AravisSourceStats stats_;
  IoFaults* faults_;  // tests only; null in production
};

// Releases lost cameras on its own thread: Aravis blocks for seconds on a camera that does not answer.
// Its state is shared with the thread, so that a reaper still busy at exit can be left behind safely.
class AravisStereoSource::Impl::Reaper {
 public:
  Reaper() : state_(std::make_shared<State>()) {
    thread_ = std::thread([state = state_] { run(*state); });
  }
  ~Reaper() {
    {
      std::lock_guard lock(state_->mutex);
      state_->stop = true;
    }
    state_->cv.notify_one();
    // A daemon stopping must not wait out Aravis's timeouts: past a short grace the cameras are left to the
    // thread (the process is ending) rather than joined.
    std::unique_lock lock(state_->mutex);
    if (state_->cv_done.wait_for(lock, std::chrono::milliseconds(300), [&] { return state_->done; })) {
      lock.unlock();
      thread_.join();
    } else {
      lock.unlock();
      thread_.detach();
    }
  }
  void take(std::unique_ptr<AravisCamera> camera) {
    camera->mark_lost();
    {
      std::lock_guard lock(state_->mutex);
      state_->queue.push_back(std::move(camera));
    }
    state_->cv.notify_one();
  }

 private:
  struct State {
    std::mutex mutex;
    std::condition_variable cv, cv_done;
    std::vector<std::unique_ptr<AravisCamera>> queue;
    bool stop = false;
    bool done = false;
  };
  static void run(State& s) {
    std::unique_lock lock(s.mutex);
    for (;;) {
      s.cv.wait(lock, [&] { return s.stop || !s.queue.empty(); });
      if (s.queue.empty()) break;
      std::unique_ptr<AravisCamera> camera = std::move(s.queue.back());
      s.queue.pop_back();
      lock.unlock();
      camera.reset();  // may block for Aravis's timeouts
      lock.lock();
    }
    s.done = true;
    s.cv_done.notify_all();
  }
  std::shared_ptr<State> state_;
  std::thread thread_;
};

// Reopens lost cameras on its own thread with backoff, so acquisition never blocks on discovery. A
// camera it opened is handed over, configured and streaming, through take().
class AravisStereoSource::Impl::Connector {
 public:
  Connector(const AravisSourceConfig& config, cv::Size expected, std::shared_ptr<FrameSignal> signal)
      : config_(config), expected_(expected), signal_(std::move(signal)) {
    if (!hotplug_.available())
      spdlog::debug("camera reconnect: no USB hot-plug ({}), timed retries only", hotplug_.unavailable_reason());
    thread_ = std::jthread([this](std::stop_token st) { run(st); });
  }
  ~Connector() {
    thread_.request_stop();
    cv_.notify_one();
  }

  // Starts looking for the camera of `side`: where it was last seen (`known`; empty id: never seen).
  void request(std::size_t side, CameraListing known) {
    {
      std::lock_guard lock(mutex_);
      wanted_[side] = true;
      known_[side] = std::move(known);
      attempt_[side] = 0;
      next_try_ns_[side] = monotonic_now_ns() + ms_to_ns(config_.reconnect_min_ms);
      backoff_ns_[side] = ms_to_ns(config_.reconnect_min_ms);
    }
    cv_.notify_one();
  }
  std::unique_ptr<AravisCamera> take(std::size_t side) {
    std::lock_guard lock(mutex_);
    return std::move(ready_[side]);
  }
  bool any_ready() {
    std::lock_guard lock(mutex_);
    return ready_[0] != nullptr || ready_[1] != nullptr;
  }
  // "attempt N: why" of the last failed attempt for `side`.
  std::string last_failure(std::size_t side) {
    std::lock_guard lock(mutex_);
    return failure_[side];
  }
  std::vector<std::string> take_warnings() {
    std::lock_guard lock(mutex_);
    return std::exchange(warnings_, {});
  }

 private:
  void run(std::stop_token st) {
    std::stop_callback wake(st, [this] { cv_.notify_one(); });
    std::uint64_t arrivals_seen = hotplug_.arrivals();
    std::unique_lock lock(mutex_);
    while (!st.stop_requested()) {
      const std::int64_t now = monotonic_now_ns();
      // A USB3 Vision camera plugged in: try every wanted side now rather than after the backoff.
      if (const std::uint64_t a = hotplug_.arrivals(); a != arrivals_seen) {
        arrivals_seen = a;
        for (std::size_t s = 0; s < 2; ++s) next_try_ns_[s] = now;
      }
      bool tried = false;
      for (std::size_t s = 0; s < 2 && !st.stop_requested(); ++s) {
        if (!wanted_[s] || ready_[s] != nullptr || now < next_try_ns_[s]) continue;
        tried = true;
        const std::string selector = s == 0 ? config_.left : config_.right;
        CameraListing known = known_[s];
        const int attempt = ++attempt_[s];
        const std::int64_t started = now;
        lock.unlock();
        std::unique_ptr<AravisCamera> camera;
        std::string failure;
        std::vector<std::string> warnings;
        try {
          camera = reopen(s, selector, known, attempt, warnings);
        } catch (const std::exception& e) {
          failure = e.what();
        }
        lock.lock();
        known_[s] = known;
        for (auto& w : warnings) warnings_.push_back(std::move(w));
        if (camera) {
          ready_[s] = std::move(camera);
          wanted_[s] = false;
          signal_->notify();  // acquisition adopts it at once
        } else {
          failure_[s] = fmt::format("attempt {}: {}", attempt, failure);
          if (attempt == 1 || attempt % 10 == 0) spdlog::warn("reconnecting {}", failure_[s]);
          // The backoff counts from the attempt's start: an attempt that itself waited (a discovery) is
          // followed by the next one at once.
          next_try_ns_[s] = started + backoff_ns_[s];
          backoff_ns_[s] = std::min(backoff_ns_[s] * 2, ms_to_ns(config_.reconnect_max_ms));
        }
      }
      if (tried) continue;
      // Short slices keep hot-plug arrivals prompt without a second wait primitive.
      cv_.wait_for(lock, std::chrono::milliseconds(20));
    }
  }

  // One attempt. A GigE camera seen before is probed at its address first (tens of ms), which also
  // avoids Aravis's seconds-long timeouts on an absent camera; a full discovery by selector (about a
  // second) runs for others, and every tenth attempt in case the camera came back at another address.
  std::unique_ptr<AravisCamera> reopen(std::size_t s, const std::string& selector, CameraListing& known, int attempt,
                                       std::vector<std::string>& warnings) {
    const std::string label = label_of(s, selector);
    if (known.protocol == "GigEVision" && !known.address.empty() && attempt % 10 != 0) {
      if (!gige_camera_answers(known.address, std::chrono::milliseconds(100)))
        throw CameraError("", fmt::format("{}: no answer at {}", label, known.address));
      return open_camera(known, known.address, label, config_, expected_, signal_, warnings);
    }
    const auto found = find_camera(list_cameras(), selector);
    if (!found) throw CameraError("", fmt::format("{}: not found", label));
    known = *found;
    return open_camera(*found, found->id, label, config_, expected_, signal_, warnings);
  }

  const AravisSourceConfig config_;
  const cv::Size expected_;
  const std::shared_ptr<FrameSignal> signal_;
  UsbHotplugMonitor hotplug_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::array<bool, 2> wanted_{};
  std::array<CameraListing, 2> known_;
  std::array<int, 2> attempt_{};
  std::array<std::int64_t, 2> next_try_ns_{};
  std::array<std::int64_t, 2> backoff_ns_{};
  std::array<std::unique_ptr<AravisCamera>, 2> ready_;
  std::array<std::string, 2> failure_;
  std::vector<std::string> warnings_;
  std::jthread thread_;  // last: stops before the members it uses go
};

// Receives the pairer's decisions: pairs wait in a fixed ring for next(); drops go back to their stream.
class AravisStereoSource::Impl::PairReceiver final : public PairingReceiver {
 public:
  explicit PairReceiver(Impl& source) : source_(source) {}
  void on_pair(const FramePair& pair) override {
    if (count_ == ring_.size()) {  // cannot happen while held buffers <= ring size; never lose a buffer
      const FramePair& oldest = ring_[head_];
      source_.requeue(oldest.left);
      source_.requeue(oldest.right);
      head_ = (head_ + 1) % ring_.size();
      --count_;
    }
    ring_[(head_ + count_) % ring_.size()] = pair;
    ++count_;
  }
  void on_drop(const FrameDescriptor& frame, DropReason) override { source_.requeue(frame); }
  bool pop(FramePair& pair) noexcept {
    if (count_ == 0) return false;
    pair = ring_[head_];
    head_ = (head_ + 1) % ring_.size();
    --count_;
    return true;
  }
  std::size_t size() const noexcept { return count_; }

 private:
  Impl& source_;
  std::array<FramePair, 2 * kMaxBuffers> ring_{};
  std::size_t head_ = 0, count_ = 0;
};

namespace {
PairingConfig pairing_config(const AravisSourceConfig& c) {
  PairingConfig p;
  p.mode = c.sync == CameraSync::FreeRun ? PairingMode::Timestamp : PairingMode::FrameId;
  p.window_ns = ms_to_ns(c.pairing_window_ms);
  p.reorder_ns = 0;  // each stream delivers in order; the other side's lag is handled without waiting
  p.jump_ns = std::max<std::int64_t>(1'000'000'000, static_cast<std::int64_t>(10e9 / c.fps));
  p.capacity = static_cast<std::size_t>(std::clamp(c.buffers / 2, 1, static_cast<int>(StereoPairer::kMaxCapacity)));
  return p;
}
const AravisSourceConfig& checked(const AravisSourceConfig& c) {
  check(c);
  return c;
}
}  // namespace

AravisStereoSource::Impl::Impl(const AravisSourceConfig& config, StereoCalibration calibration,
                               std::chrono::milliseconds log_period, IoFaults* faults)
    : config_(checked(config)),
      calibration_(std::move(calibration)),
      signal_(std::make_shared<FrameSignal>()),
      reaper_(std::make_unique<Reaper>()),
      receiver_(std::make_unique<PairReceiver>(*this)),
      pairer_(pairing_config(config)),
      faults_(faults) {
  const cv::Size expected = calibration_.image_size;
  trigger_period_ns_ = config_.sync == CameraSync::SoftwareTrigger ? static_cast<std::int64_t>(1e9 / config_.fps) : 0;
  stall_ns_ = ms_to_ns(config_.stall_timeout_ms);
  log_period_ns_ = std::chrono::nanoseconds(log_period).count();
  const std::vector<CameraListing> found = list_cameras();
  std::array<CameraListing, 2> known;
  const std::int64_t now = monotonic_now_ns();
  for (std::size_t s = 0; s < 2; ++s) {
    const std::string& selector = s == 0 ? config_.left : config_.right;
    const auto listing = find_camera(found, selector);
    sides_[s].last_frame_ns = now;
    if (!listing) {
      warnings_.push_back(fmt::format("{}: not found; measuring starts when it appears", label_of(s, selector)));
      sides_[s].lost_since_ns = now;
      continue;
    }
    known[s] = *listing;
    // A camera that is here but refuses the configuration is a start-up error (CameraError propagates).
    sides_[s].camera = open_camera(*listing, listing->id, label_of(s, selector), config_, expected, signal_, warnings_);
  }
  connector_ = std::make_unique<Connector>(config_, expected, signal_);
  for (std::size_t s = 0; s < 2; ++s)
    if (!sides_[s].camera) connector_->request(s, known[s]);
  next_trigger_ns_ = now;
}

AravisStereoSource::Impl::~Impl() {
  connector_.reset();  // stops opening cameras
  release_pending();
  for (Side& side : sides_) side.camera.reset();  // healthy cameras: a prompt AcquisitionStop
  spdlog::info("cameras: {}", describe(stats()));
}

void AravisStereoSource::Impl::requeue(const FrameDescriptor& frame) noexcept {
  Side& side = sides_[static_cast<std::size_t>(frame.side)];
  ArvBuffer*& held = side.held[frame.buffer];
  if (held != nullptr && side.camera) side.camera->requeue(held);
  held = nullptr;
}

void AravisStereoSource::Impl::release_pending() noexcept {
  // Every buffer the pairer or the ready ring holds goes back to its stream.
  pairer_.flush(*receiver_);
  FramePair pair;
  while (receiver_->pop(pair)) {
    requeue(pair.left);
    requeue(pair.right);
  }
}

void AravisStereoSource::Impl::adopt_connected() {
  if (!connector_->any_ready()) return;
  for (auto& w : connector_->take_warnings()) spdlog::warn("{}", w);
  for (std::size_t s = 0; s < 2; ++s) {
    std::unique_ptr<AravisCamera> camera = connector_->take(s);
    if (!camera) continue;
    Side& side = sides_[s];
    side.camera = std::move(camera);
    side.last_frame_ns = monotonic_now_ns();
    side.awaiting_first = true;
    ++stats_.reconnects[s];
    spdlog::info("{}: back after {:.2f} s", side.camera->label(), (monotonic_now_ns() - side.lost_since_ns) * 1e-9);
  }
}

void AravisStereoSource::Impl::lose(std::size_t s, const std::string& why) {
  Side& side = sides_[s];
  error_ = fmt::format("{}: {}; reconnecting", side.camera->label(), why);
  spdlog::error("{}", error_);
  release_pending();  // before the camera's buffers go with it
  CameraListing known = side.camera->listing();
  reaper_->take(std::move(side.camera));
  side.lost_since_ns = monotonic_now_ns();
  ++stats_.losses[s];
  connector_->request(s, std::move(known));
}

bool AravisStereoSource::Impl::check_faults(std::int64_t now) {
  bool lost = false;
  for (std::size_t s = 0; s < 2; ++s) {
    Side& side = sides_[s];
    if (!side.camera) continue;
    // The first frame after a start may take a frame period plus the camera's own start-up.
    const std::int64_t limit = side.awaiting_first ? std::max<std::int64_t>(stall_ns_, 1'000 * kMs) : stall_ns_;
    if (side.camera->control_lost()) {
      lose(s, "control lost (heartbeat)");
      lost = true;
    } else if (stall_ns_ > 0 && now - side.last_frame_ns > limit) {
      lose(s, fmt::format("no frame for {} ms", (now - side.last_frame_ns) / kMs));
      lost = true;
    }
  }
  return lost;
}

void AravisStereoSource::Impl::fire_triggers(std::int64_t now) {
  if (trigger_period_ns_ == 0 || now < next_trigger_ns_) return;
  // Both commands leave from this one thread back to back, so both exposures start within a few µs
  // of each other on GigE (one UDP packet each).
  for (Side& side : sides_)
    if (side.camera && !side.camera->software_trigger()) ++stats_.trigger_failures;
  ++stats_.triggers;
  next_trigger_ns_ = std::max(next_trigger_ns_ + trigger_period_ns_, now);
}

void AravisStereoSource::Impl::drain(std::size_t s) {
  Side& side = sides_[s];
  while (ArvBuffer* buffer = side.camera->try_pop()) {
    // Tests only: a timeout loses the buffer unseen (as if it never arrived: no sign of life, so a run
    // of them is a stall); a corrupt one is seen as incomplete; a short one fails conversion.
    const int fault = faults_ != nullptr ? faults_->check(IoPoint::CameraPop) : 0;
    if (fault == io_fault::kTimeout) {
      side.camera->requeue(buffer);
      continue;
    }
    side.last_frame_ns = monotonic_now_ns();
    side.awaiting_first = false;
    CameraFrameInfo info = side.camera->info(buffer);
    if (fault == io_fault::kCorrupt) info.complete = false;
    if (!info.complete) {
      ++stats_.incomplete[s];
      side.camera->requeue(buffer);
      continue;
    }
    std::size_t slot = 0;
    while (slot < side.held.size() && side.held[slot] != nullptr) ++slot;
    if (slot == side.held.size()) {  // more buffers than configured: cannot happen, but never leak one
      side.camera->requeue(buffer);
      continue;
    }
    side.held[slot] = buffer;
    side.cut_short[slot] = fault == io_fault::kShort;
    pairer_.push({static_cast<CameraSide>(s), info.frame_id, info.t_ns, static_cast<std::uint32_t>(slot)}, *receiver_);
  }
}

bool AravisStereoSource::Impl::take_pair(StereoFrame& frame) {
  FramePair pair;
  if (!receiver_->pop(pair)) return false;
  Side& left = sides_[0];
  Side& right = sides_[1];
  const bool ok = left.camera->convert(left.held[pair.left.buffer], frame.left, left.cut_short[pair.left.buffer]) &&
                  right.camera->convert(right.held[pair.right.buffer], frame.right, right.cut_short[pair.right.buffer]);
  requeue(pair.left);
  requeue(pair.right);
  if (!ok) {
    ++stats_.convert_failures;
    error_ = "a camera delivered a buffer shorter than its image";
    return true;
  }
  frame.seq = seq_++;
  // A camera that restarts resets its clock: shift its timestamps so that t_ns never goes backwards
  // (recordings and the pipeline rely on that), keeping the real time that passed as the gap.
  const std::int64_t now = monotonic_now_ns();
  std::int64_t t = pair.left.t_ns + t_offset_ns_;
  if (seq_ > 1 && t <= last_t_ns_) {
    t_offset_ns_ += last_t_ns_ + std::max<std::int64_t>(now - last_pair_mono_ns_, 1) - t;
    t = pair.left.t_ns + t_offset_ns_;
  }
  last_t_ns_ = t;
  last_pair_mono_ns_ = now;
  frame.t_ns = t;
  // Free-running cameras share a PTP clock: their skew is real. Triggered pairs are paired by frame id,
  // their timestamps need not share a clock: skew unknown (a hardware trigger exposes both at once).
  frame.skew_ns = config_.sync == CameraSync::FreeRun ? pair.skew_ns : 0;
  frame.clock = ClockKind::Hardware;
  error_.clear();
  return true;
}

void AravisStereoSource::Impl::log_stats(std::int64_t now) {
  if (log_period_ns_ <= 0 || now < next_log_ns_) return;
  if (next_log_ns_ != 0) spdlog::info("cameras: {}", describe(stats()));
  next_log_ns_ = now + log_period_ns_;
}

SourceStatus AravisStereoSource::Impl::report_lost(std::int64_t now) {
  for (std::size_t s = 0; s < 2; ++s) {
    if (sides_[s].camera) continue;
    const std::string selector = s == 0 ? config_.left : config_.right;
    const std::string failure = connector_->last_failure(s);
    error_ = fmt::format("{}: lost {:.1f} s ago, reconnecting{}{}", label_of(s, selector),
                         (now - sides_[s].lost_since_ns) * 1e-9, failure.empty() ? "" : " (",
                         failure.empty() ? "" : failure + ")");
    break;
  }
  return SourceStatus::Error;
}

SourceStatus AravisStereoSource::Impl::next(StereoFrame& frame) {
  const std::int64_t deadline = monotonic_now_ns() + 100 * kMs;
  for (;;) {
    const std::uint64_t seen = signal_->mark();
    adopt_connected();
    std::int64_t now = monotonic_now_ns();
    if (check_faults(now)) return SourceStatus::Error;
    if (!sides_[0].camera || !sides_[1].camera) {
      // Keep the healthy camera's stream flowing (its frames are dropped as unmatched), then wait for the
      // connector; Error keeps no_camera raised in the status message meanwhile.
      for (std::size_t s = 0; s < 2; ++s)
        if (sides_[s].camera) drain(s);
      fire_triggers(now);  // a triggered camera left without triggers would stall and be lost too
      signal_->wait(seen, std::chrono::milliseconds(20));
      adopt_connected();
      if (!sides_[0].camera || !sides_[1].camera) return report_lost(monotonic_now_ns());
      continue;
    }
    if (receiver_->size() == 0) {
      drain(0);
      drain(1);
    }
    if (take_pair(frame)) {
      log_stats(now);
      return error_.empty() ? SourceStatus::Ok : SourceStatus::Error;
    }
    fire_triggers(now);
    now = monotonic_now_ns();
    if (now >= deadline) return SourceStatus::Timeout;
    // Wake for a buffer, the next trigger, the stall check or the deadline, whichever is first.
    std::int64_t wake = std::min(deadline, now + 10 * kMs);
    if (trigger_period_ns_ > 0) wake = std::min(wake, next_trigger_ns_);
    signal_->wait(seen, std::chrono::microseconds(std::max<std::int64_t>((wake - now) / 1000, 0)));
  }
}

AravisSourceStats AravisStereoSource::Impl::stats() const {
  AravisSourceStats s = stats_;
  s.pairing = pairer_.stats();
  return s;
}

AravisStereoSource::AravisStereoSource(const AravisSourceConfig& config, StereoCalibration calibration,
                                       std::chrono::milliseconds log_period, IoFaults* faults)
    : impl_(std::make_unique<Impl>(config, std::move(calibration), log_period, faults)) {}
AravisStereoSource::~AravisStereoSource() = default;
SourceStatus AravisStereoSource::next(StereoFrame& frame) { return impl_->next(frame); }
const StereoCalibration& AravisStereoSource::calibration() const { return impl_->calibration_; }
const std::string& AravisStereoSource::error_message() const { return impl_->error_; }
AravisSourceStats AravisStereoSource::stats() const { return impl_->stats(); }
const std::vector<std::string>& AravisStereoSource::warnings() const noexcept { return impl_->warnings_; }

std::string describe(const AravisSourceStats& s) {
  const PairingStats& p = s.pairing;
  return fmt::format(
      "{} pairs, skew |right-left| p50 {:.0f} us p99 {:.0f} us max {:.0f} us (mean {:+.0f} us); left {} frames, {} "
      "unmatched, {} late, {} evicted, {} flushed, {} incomplete; right {} frames, {} unmatched, {} late, {} evicted, "
      "{} flushed, {} incomplete; lost left {} right {}, back left {} right {}; {} triggers ({} refused)",
      p.pairs, p.skew_p50_ns * 1e-3, p.skew_p99_ns * 1e-3, p.skew_max_ns * 1e-3, p.skew_mean_ns * 1e-3, p.left.received,
      p.left.unmatched, p.left.late, p.left.evicted, p.left.flushed, s.incomplete[0], p.right.received,
      p.right.unmatched, p.right.late, p.right.evicted, p.right.flushed, s.incomplete[1], s.losses[0], s.losses[1],
      s.reconnects[0], s.reconnects[1], s.triggers, s.trigger_failures);
}

}  // namespace rutd
