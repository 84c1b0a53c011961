#pragma once
// Recording while acquiring: FrameRecorder takes stereo pairs from the acquisition thread without ever
// making it wait, and writes them to a recording folder (recording/recording.hpp) on a thread of its own.
//
// Threading. offer() is called by ONE producer thread (the acquisition thread, or whichever thread owns
// the FrameSource). It copies the pair into a free slot of a pool allocated at construction and hands
// the slot to the writer thread through a SlotQueue (core/slot_queue.hpp); slots come back through a
// second one. A producer pays a wake-up system call only when the writer is actually asleep. PNG encoding and fsync
// happen on the writer thread only. When no slot is free the pair is dropped and counted: acquisition is never blocked
// by the disk. close() (and the destructor) must not run concurrently with offer(): call it from the producer thread or
// after it stopped. stats(), failed() and error() are safe from any thread.
//
// Crash safety (RecordingWriter's contract): a pair's images are completely written (and synced, unless
// sync_to_disk is off) before its frames.csv line is appended, so a kill -9 at any moment (or, with
// sync_to_disk, a power cut) leaves a folder that replays every pair it lists. Pairs still queued in
// memory at a crash are lost; they were never listed.
//
// Failure. The first append that fails (disk full, file too large, folder unwritable or gone) stops the
// recording for good: the message is kept (it names the file and the OS reason, e.g. "cannot write
// rec/left/.00000123.png.tmp: No space left on device"), failed() turns true, the message is logged once
// with spdlog::error, pairs still queued are discarded and later offers are refused at the cost of one
// atomic load. The failed pair is not listed; everything listed before it stays replayable. Measuring
// is the caller's business and goes on.
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "core/frame_source.hpp"
#include "core/stereo_frame.hpp"
#include "recording/recording.hpp"

namespace rutd {

struct FrameRecorderConfig {
  // Slots between acquisition and the writer, 1..1024: how many pairs may wait while the disk is slow
  // (each slot holds one pair, e.g. 0.6 MB at 640x480 8-bit).
  std::size_t capacity = 8;
  RecordingWriterConfig writer;
};

// A snapshot of the recorder's counters. Each counter is read atomically but not all at one instant;
// after close() they are final and offered == written + dropped + discarded.
struct FrameRecorderStats {
  std::uint64_t offered = 0;    // offer() calls
  std::uint64_t written = 0;    // pairs listed in frames.csv
  std::uint64_t dropped = 0;    // no free slot: the writer was behind
  std::uint64_t discarded = 0;  // not written because the recording had failed (or was closed)
  bool failed = false;
  std::string error;  // why the recording failed; empty unless failed
};

class FrameRecorder {
 public:
  // Creates the recording in `dir` (calibration.yaml and the frames.csv header, see RecordingWriter),
  // allocates `options.capacity` slots of the calibration's image size (8-bit) and starts the writer
  // thread. Throws InputError naming the folder when it cannot be written or already holds a recording,
  // std::invalid_argument for a capacity out of range.
  FrameRecorder(const std::string& dir, const StereoCalibration& calibration, FrameRecorderConfig options = {});
  ~FrameRecorder();  // close()
  FrameRecorder(const FrameRecorder&) = delete;
  FrameRecorder& operator=(const FrameRecorder&) = delete;

  // Producer thread only. Copies the pair into a free slot and queues it; returns at once. false: the
  // pair is not recorded (no free slot: counted as dropped; recording failed or closed: discarded).
  // Allocates nothing once the slots have held a pair of this size and type.
  bool offer(const StereoFrame& frame) noexcept;

  // Writes what is queued, then stops the writer thread and joins it. Idempotent; later offers are
  // discarded. Not concurrently with offer().
  void close();

  bool failed() const noexcept { return failed_.load(std::memory_order_acquire); }
  // Why the recording failed; empty while it has not. Any thread: set once, before failed() turns true.
  std::string error() const;
  FrameRecorderStats stats() const;
  const std::string& directory() const noexcept { return dir_; }

 private:
  struct Queues;
  void writer_loop(std::stop_token stop);
  void write_pair(StereoFrame& frame);

  std::string dir_;
  RecordingWriter writer_;  // writer thread only, once started
  std::vector<StereoFrame> slots_;
  std::unique_ptr<Queues> queues_;
  // A slot taken from the free queue whose copy failed (allocation); the producer reuses it next time.
  StereoFrame* spare_ = nullptr;
  bool closed_ = false;  // producer side

  std::atomic<std::uint64_t> offered_{0}, written_{0}, dropped_{0}, discarded_{0};
  std::atomic<bool> failed_{false};
  std::string error_;  // written once by the writer thread before failed_ is released
  std::jthread thread_;
};

// A FrameSource that records what it passes on: forwards next(), calibration() and error_message() to
// the wrapped source and offers every Ok pair to the recorder. Same threading as any FrameSource (one
// thread owns it); that thread is the recorder's producer. The recorder must outlive this object.
class RecordingTee final : public FrameSource {
 public:
  RecordingTee(std::unique_ptr<FrameSource> inner, FrameRecorder& recorder);
  SourceStatus next(StereoFrame& frame) override;
  const StereoCalibration& calibration() const override { return inner_->calibration(); }
  const std::string& error_message() const override { return inner_->error_message(); }

 private:
  std::unique_ptr<FrameSource> inner_;
  FrameRecorder& recorder_;
};

}  // namespace rutd
