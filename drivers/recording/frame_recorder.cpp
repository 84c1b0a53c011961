#include "recording/frame_recorder.hpp"

#include <chrono>
#include <exception>
#include <stdexcept>

#include <spdlog/spdlog.h>

#include "core/slot_queue.hpp"

namespace rutd {
namespace {

constexpr auto kRelaxed = std::memory_order_relaxed;
constexpr std::size_t kMaxCapacity = 1024;

void add(std::atomic<std::uint64_t>& counter) noexcept { counter.fetch_add(1, kRelaxed); }

// Checked before the writer creates anything on disk.
const FrameRecorderConfig& checked(const FrameRecorderConfig& options) {
  if (options.capacity < 1 || options.capacity > kMaxCapacity) {
    throw std::invalid_argument("frame recorder: capacity must be 1.." + std::to_string(kMaxCapacity) + ", got " +
                                std::to_string(options.capacity));
  }
  return options;
}

}  // namespace

// The slot loop: `ready` from the producer to the writer, `free` back. Each can hold every slot, so a
// push never fails.
struct FrameRecorder::Queues {
  explicit Queues(std::size_t capacity) : ready(capacity), free(capacity) {}
  SlotQueue<StereoFrame> ready;
  SlotQueue<StereoFrame> free;
};

FrameRecorder::FrameRecorder(const std::string& dir, const StereoCalibration& calibration, FrameRecorderConfig options)
    : dir_(dir), writer_(dir, calibration, checked(options).writer) {
  slots_.resize(options.capacity);
  queues_ = std::make_unique<Queues>(options.capacity);
  for (StereoFrame& slot : slots_) {
    // The usual case (8-bit at the calibrated size) then copies without allocating from the first pair.
    slot.left.create(calibration.image_size, CV_8UC1);
    slot.right.create(calibration.image_size, CV_8UC1);
    queues_->free.push(&slot);
  }
  thread_ = std::jthread([this](std::stop_token stop) { writer_loop(std::move(stop)); });
}

FrameRecorder::~FrameRecorder() { close(); }

bool FrameRecorder::offer(const StereoFrame& frame) noexcept {
  add(offered_);
  if (closed_ || failed_.load(kRelaxed)) {
    add(discarded_);
    return false;
  }
  StereoFrame* slot = spare_ != nullptr ? spare_ : queues_->free.pop();
  spare_ = nullptr;
  if (slot == nullptr) {
    add(dropped_);
    return false;
  }
  try {
    // copyTo reallocates only when size or type differ from what the slot already holds.
    frame.left.copyTo(slot->left);
    frame.right.copyTo(slot->right);
  } catch (...) {
    // Out of memory for a new image size: this pair is lost like one without a slot; keep the slot.
    spare_ = slot;
    add(dropped_);
    return false;
  }
  slot->seq = frame.seq;
  slot->t_ns = frame.t_ns;
  slot->skew_ns = frame.skew_ns;
  slot->clock = frame.clock;
  queues_->ready.push(slot);  // wakes the writer
  return true;
}

void FrameRecorder::close() {
  closed_ = true;
  if (!thread_.joinable()) return;
  thread_.request_stop();
  queues_->ready.wake();
  thread_.join();
}

void FrameRecorder::write_pair(StereoFrame& frame) {
  if (failed_.load(kRelaxed)) {
    add(discarded_);
    return;
  }
  bool ok = false;
  try {
    ok = writer_.append(frame);
  } catch (const std::exception& e) {
    error_ = dir_ + ": cannot record pair seq " + std::to_string(frame.seq) + ": " + e.what();
  }
  if (ok) {
    add(written_);
    return;
  }
  if (error_.empty()) error_ = writer_.error();
  add(discarded_);
  failed_.store(true, std::memory_order_release);
  spdlog::error("recording stopped: {}", error_);
}

void FrameRecorder::writer_loop(std::stop_token stop) {
  for (;;) {
    // Both read before looking at the queue. A push after mark() makes wait() return at once. close()
    // requests stop only after the producer's last push, so once `stopping` is seen every pair still
    // queued is visible to the pops below: an empty queue then means drained.
    const std::uint64_t since = queues_->ready.mark();
    const bool stopping = stop.stop_requested();
    bool worked = false;
    while (StereoFrame* slot = queues_->ready.pop()) {
      worked = true;
      write_pair(*slot);
      queues_->free.push(slot);
    }
    if (worked) continue;
    if (stopping) return;
    queues_->ready.wait(since, std::chrono::milliseconds(100));  // bounded: close() also wakes it
  }
}

std::string FrameRecorder::error() const { return failed() ? error_ : std::string(); }

FrameRecorderStats FrameRecorder::stats() const {
  FrameRecorderStats s;
  s.failed = failed();
  if (s.failed) s.error = error_;
  // Outcomes first: offered_ is bumped before an outcome, so the snapshot never shows more outcomes
  // than offers.
  s.written = written_.load(kRelaxed);
  s.dropped = dropped_.load(kRelaxed);
  s.discarded = discarded_.load(kRelaxed);
  s.offered = offered_.load(kRelaxed);
  return s;
}

RecordingTee::RecordingTee(std::unique_ptr<FrameSource> inner, FrameRecorder& recorder)
    : inner_(std::move(inner)), recorder_(recorder) {}

SourceStatus RecordingTee::next(StereoFrame& frame) {
  const SourceStatus status = inner_->next(frame);
  if (status == SourceStatus::Ok) recorder_.offer(frame);
  return status;
}

}  // namespace rutd
