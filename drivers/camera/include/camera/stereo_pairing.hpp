#pragma once
// Pairs left and right camera frames into stereo pairs by hardware timestamp or by frame id, with fixed
// memory and no allocation after construction. The camera driver feeds it the descriptors of the frames
// its two stream threads deliver (funnelled to one thread) and gets back pairs to process and frames to
// requeue.
//
// Contract
// - Thread safety: none. One thread calls every member; stats are read by that thread too (copy them
//   out for a status line).
// - Time base: both cameras' timestamps must share one clock (PTP, or a trigger-synchronised clock), in
//   nanoseconds. The window must be below half the frame period, so that each frame has at most one
//   partner candidate; then the pairs are exactly "every left/right couple within the window".
// - Every pushed frame comes back exactly once: in one FramePair (PairingReceiver::on_pair) or as a drop
//   (PairingReceiver::on_drop, with the reason). The buffer index is the caller's; the pairer only carries it.
// - Output order: pairs come out in non-decreasing order of their earlier timestamp (strictly increasing
//   for distinct frames under the window rule above), within one epoch. Drops are reported when decided.
// - Every emitted pair has |right.t_ns - left.t_ns| <= window_ns; no other pair ever comes out.
// - Reordering: a frame may arrive up to reorder_ns after frames newer than it (on either side). A frame
//   older than (oldest of the two sides' newest timestamps - reorder_ns), or older than something already
//   decided, is late and dropped. A pair is emitted as soon as its earlier timestamp is at or below that
//   bound, so with reorder_ns = 0 an in-order pair comes out when its second frame arrives; an unmatched
//   frame is dropped once the bound passes its timestamp + window.
// - Memory: at most `capacity` pending frames per side. Pushing into a full side first decides the
//   globally oldest pending frames (pairing them if their partner is pending, else dropping them as
//   Evicted) until there is room; so a stalled camera costs the other side bounded memory.
// - Clock jumps: a frame whose timestamp differs from its side's newest by more than jump_ns (a camera
//   reconnect resets its clock, a PTP step) ends the epoch: every pending frame is decided (pairs still
//   within the window come out, the rest are dropped as Flushed), the learnt id offset is forgotten, the
//   epoch number increments, and the frame starts the new epoch. Both sides are flushed, so when the two
//   cameras reset one after the other, a frame of the first one pending at the second one's jump is lost.
// - Triggered mode (PairingMode::FrameId): the first pair is found by timestamp and fixes the id offset
//   (right.frame_id - left.frame_id, modulo 2^64). Afterwards a frame's only candidate is the frame with
//   the matching id, still subject to the window. If that candidate is beyond the window (a camera missed
//   a trigger without advancing its counter), the offset is forgotten (counted in id_resyncs) and the
//   next pair found by timestamp learns it again.
#include <array>
#include <cstddef>
#include <cstdint>

namespace rutd {

enum class CameraSide : std::uint8_t { Left = 0, Right = 1 };

// One delivered camera frame, as the driver knows it. Trivially copyable; the image stays in the
// caller's buffer `buffer`.
struct FrameDescriptor {
  CameraSide side = CameraSide::Left;
  std::uint64_t frame_id = 0;  // the camera's frame (block) counter
  std::int64_t t_ns = 0;       // hardware timestamp, nanoseconds
  std::uint32_t buffer = 0;    // opaque index of the caller's buffer holding the image
};

struct FramePair {
  FrameDescriptor left;
  FrameDescriptor right;
  std::int64_t skew_ns = 0;  // right.t_ns - left.t_ns
  std::uint32_t epoch = 0;   // increments at every clock jump
};

enum class DropReason : std::uint8_t {
  Unmatched,  // no partner within the window (or with the matching id) arrived in time
  Late,       // arrived after its time had been decided (beyond reorder_ns)
  Evicted,    // its side's pending list was full and it was the oldest frame
  Flushed,    // pending when a clock jump or flush() ended the epoch, and had no partner
};

// Receives the pairer's decisions. Called synchronously from push()/flush(), on the caller's thread.
class PairingReceiver {
 public:
  virtual void on_pair(const FramePair& pair) = 0;
  virtual void on_drop(const FrameDescriptor& frame, DropReason reason) = 0;

 protected:
  ~PairingReceiver() = default;
};

enum class PairingMode : std::uint8_t { Timestamp, FrameId };

struct PairingConfig {
  PairingMode mode = PairingMode::Timestamp;
  std::int64_t window_ns = 2'000'000;    // largest |skew| of a pair
  std::int64_t reorder_ns = 0;           // how late a frame may arrive, see the contract above
  std::int64_t jump_ns = 1'000'000'000;  // a same-side timestamp step beyond this is a clock jump
  std::size_t capacity = 8;              // pending frames per side, 1..StereoPairer::kMaxCapacity
};

// Fixed-size linear histogram of |skew| over [0, range_ns]; larger values land in the last bin.
// A percentile is the upper edge of its bin clamped to the recorded max, so it is never below the true
// nearest-rank value and at most bin_width_ns() above it.
class SkewHistogram {
 public:
  static constexpr std::size_t kBins = 512;

  explicit SkewHistogram(std::int64_t range_ns) noexcept;

  void record(std::int64_t skew_ns) noexcept;  // signed; binned by magnitude
  void reset() noexcept;

  // Nearest-rank percentile of |skew|, q in [0, 1]; 0 when empty.
  std::int64_t percentile(double q) const noexcept;
  std::int64_t max_ns() const noexcept { return max_ns_; }
  std::uint64_t count() const noexcept { return count_; }
  double mean_signed_ns() const noexcept;  // mean of the signed skews: a systematic camera offset
  std::int64_t bin_width_ns() const noexcept { return width_ns_; }

 private:
  std::array<std::uint64_t, kBins> bins_{};
  std::int64_t width_ns_ = 1;
  std::uint64_t count_ = 0;
  std::int64_t max_ns_ = 0;
  double sum_signed_ns_ = 0.0;
};

struct SideCounters {
  std::uint64_t received = 0;
  std::uint64_t unmatched = 0;
  std::uint64_t late = 0;
  std::uint64_t evicted = 0;
  std::uint64_t flushed = 0;
  std::uint64_t clock_jumps = 0;  // jumps detected on this side's timestamps

  std::uint64_t dropped() const noexcept { return unmatched + late + evicted + flushed; }
};

struct PairingStats {
  std::uint64_t pairs = 0;
  std::uint64_t id_resyncs = 0;  // FrameId mode: learnt offsets found wrong and forgotten
  std::uint32_t epoch = 0;
  SideCounters left;
  SideCounters right;
  // |skew| of emitted pairs, nanoseconds; 0 when none.
  std::int64_t skew_p50_ns = 0;
  std::int64_t skew_p99_ns = 0;
  std::int64_t skew_max_ns = 0;
  double skew_mean_ns = 0.0;  // signed, right - left
};

class StereoPairer {
 public:
  static constexpr std::size_t kMaxCapacity = 64;

  // Throws InputError (field named after the PairingConfig member) for a non-positive window, negative
  // reorder_ns, jump_ns not above window_ns + reorder_ns, or capacity outside 1..kMaxCapacity.
  explicit StereoPairer(const PairingConfig& config);

  // Takes one frame; reports the decisions it enables to `sink` before returning. No allocation.
  void push(const FrameDescriptor& frame, PairingReceiver& sink) noexcept;
  // Decides every pending frame now (end of stream, acquisition stop): pairs still within the window come
  // out, the rest are dropped as Flushed. Starts a new epoch, like a clock jump.
  void flush(PairingReceiver& sink) noexcept;

  PairingStats stats() const noexcept;
  const SkewHistogram& skew_histogram() const noexcept { return skew_; }
  std::size_t pending(CameraSide side) const noexcept { return lists_[index(side)].size; }
  const PairingConfig& config() const noexcept { return config_; }

 private:
  // Pending frames of one side, sorted by timestamp (oldest first).
  struct PendingList {
    std::array<FrameDescriptor, kMaxCapacity> frames{};
    std::size_t size = 0;
    void insert(const FrameDescriptor& frame) noexcept;
    FrameDescriptor take(std::size_t i) noexcept;
  };
  static constexpr std::size_t kNone = kMaxCapacity;

  static std::size_t index(CameraSide side) noexcept { return static_cast<std::size_t>(side); }
  std::int64_t decided_bound() const noexcept;
  bool is_late(std::int64_t t_ns) const noexcept;
  bool is_clock_jump(const FrameDescriptor& frame) const noexcept;
  bool oldest_side(CameraSide& side) const noexcept;
  std::size_t find_partner(const FrameDescriptor& frame) noexcept;
  std::size_t nearest_within_window(const FrameDescriptor& frame) const noexcept;
  bool decide_one(bool force, DropReason unmatched_reason, PairingReceiver& sink) noexcept;
  void emit_pair(CameraSide oldest, std::size_t partner, PairingReceiver& sink) noexcept;
  void drop(const FrameDescriptor& frame, DropReason reason, PairingReceiver& sink) noexcept;
  void end_epoch(PairingReceiver& sink) noexcept;
  SideCounters& counters(CameraSide side) noexcept { return side == CameraSide::Left ? left_ : right_; }

  PairingConfig config_;
  std::array<PendingList, 2> lists_{};
  std::array<std::int64_t, 2> newest_{};
  std::array<bool, 2> seen_{};
  bool any_decided_ = false;
  std::int64_t decided_ns_ = 0;  // earlier timestamp of the last decided pair or frame
  bool offset_known_ = false;
  std::uint64_t id_offset_ = 0;  // right.frame_id - left.frame_id
  std::uint32_t epoch_ = 0;
  std::uint64_t pairs_ = 0;
  std::uint64_t id_resyncs_ = 0;
  SideCounters left_;
  SideCounters right_;
  SkewHistogram skew_;
};

}  // namespace rutd
