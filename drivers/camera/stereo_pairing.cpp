#include "camera/stereo_pairing.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "core/input_error.hpp"

namespace rutd {
namespace {

constexpr std::int64_t kMinNs = std::numeric_limits<std::int64_t>::min();
constexpr std::int64_t kMaxNs = std::numeric_limits<std::int64_t>::max();

// a - b, saturated: timestamps of two unsynchronised clocks may be arbitrarily far apart.
std::int64_t sat_sub(std::int64_t a, std::int64_t b) noexcept {
  std::int64_t r = 0;
  if (__builtin_sub_overflow(a, b, &r)) return b < 0 ? kMaxNs : kMinNs;
  return r;
}

std::uint64_t magnitude(std::int64_t v) noexcept {
  return v < 0 ? std::uint64_t{0} - static_cast<std::uint64_t>(v) : static_cast<std::uint64_t>(v);
}

std::uint64_t distance(std::int64_t a, std::int64_t b) noexcept {
  return a < b ? static_cast<std::uint64_t>(b) - static_cast<std::uint64_t>(a)
               : static_cast<std::uint64_t>(a) - static_cast<std::uint64_t>(b);
}

CameraSide other(CameraSide side) noexcept { return side == CameraSide::Left ? CameraSide::Right : CameraSide::Left; }

void validate(const PairingConfig& c) {
  const char* file = "stereo pairing configuration";
  if (c.window_ns <= 0) throw InputError(file, "window_ns", "must be positive");
  if (c.reorder_ns < 0) throw InputError(file, "reorder_ns", "must not be negative");
  if (c.jump_ns <= sat_sub(c.window_ns, -c.reorder_ns))
    throw InputError(file, "jump_ns", "must exceed window_ns + reorder_ns");
  if (c.capacity < 1 || c.capacity > StereoPairer::kMaxCapacity)
    throw InputError(file, "capacity", "must be in 1.." + std::to_string(StereoPairer::kMaxCapacity));
}

}  // namespace

// ---- SkewHistogram ----

SkewHistogram::SkewHistogram(std::int64_t range_ns) noexcept
    : width_ns_(std::max<std::int64_t>(1, range_ns / static_cast<std::int64_t>(kBins) + 1)) {}

void SkewHistogram::record(std::int64_t skew_ns) noexcept {
  const std::uint64_t m = magnitude(skew_ns);
  const std::uint64_t bin = std::min<std::uint64_t>(m / static_cast<std::uint64_t>(width_ns_), kBins - 1);
  ++bins_[bin];
  ++count_;
  const auto clamped = static_cast<std::int64_t>(std::min<std::uint64_t>(m, kMaxNs));
  max_ns_ = std::max(max_ns_, clamped);
  sum_signed_ns_ += static_cast<double>(skew_ns);
}

void SkewHistogram::reset() noexcept {
  bins_.fill(0);
  count_ = 0;
  max_ns_ = 0;
  sum_signed_ns_ = 0.0;
}

std::int64_t SkewHistogram::percentile(double q) const noexcept {
  if (count_ == 0) return 0;
  q = std::clamp(q, 0.0, 1.0);
  const auto rank = std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::ceil(q * static_cast<double>(count_))));
  std::uint64_t seen = 0;
  for (std::size_t b = 0; b < kBins; ++b) {
    seen += bins_[b];
    if (seen >= rank) {
      const std::int64_t upper = (b + 1 < kBins) ? static_cast<std::int64_t>(b + 1) * width_ns_ - 1 : kMaxNs;
      return std::min(upper, max_ns_);
    }
  }
  return max_ns_;
}

double SkewHistogram::mean_signed_ns() const noexcept {
  return count_ == 0 ? 0.0 : sum_signed_ns_ / static_cast<double>(count_);
}

// ---- PendingList ----

void StereoPairer::PendingList::insert(const FrameDescriptor& frame) noexcept {
  // Stable: a frame with an equal timestamp goes after the ones already there.
  std::size_t i = size;
  while (i > 0 && frames[i - 1].t_ns > frame.t_ns) {
    frames[i] = frames[i - 1];
    --i;
  }
  frames[i] = frame;
  ++size;
}

FrameDescriptor StereoPairer::PendingList::take(std::size_t i) noexcept {
  const FrameDescriptor out = frames[i];
  for (std::size_t j = i + 1; j < size; ++j) frames[j - 1] = frames[j];
  --size;
  return out;
}

// ---- StereoPairer ----

StereoPairer::StereoPairer(const PairingConfig& config) : config_(config), skew_(config.window_ns) {
  validate(config_);
}

std::int64_t StereoPairer::decided_bound() const noexcept {
  if (!seen_[0] || !seen_[1]) return kMinNs;
  return sat_sub(std::min(newest_[0], newest_[1]), config_.reorder_ns);
}

bool StereoPairer::is_late(std::int64_t t_ns) const noexcept {
  return t_ns < decided_bound() || (any_decided_ && t_ns < decided_ns_);
}

bool StereoPairer::is_clock_jump(const FrameDescriptor& frame) const noexcept {
  const std::size_t s = index(frame.side);
  return seen_[s] && distance(frame.t_ns, newest_[s]) > static_cast<std::uint64_t>(config_.jump_ns);
}

void StereoPairer::push(const FrameDescriptor& frame, PairingReceiver& sink) noexcept {
  const std::size_t s = index(frame.side);
  ++counters(frame.side).received;
  if (is_clock_jump(frame)) {
    ++counters(frame.side).clock_jumps;
    end_epoch(sink);
  }
  if (!seen_[s] || frame.t_ns > newest_[s]) newest_[s] = frame.t_ns;
  seen_[s] = true;
  if (is_late(frame.t_ns)) {
    drop(frame, DropReason::Late, sink);
    return;
  }
  PendingList& list = lists_[s];
  while (list.size >= config_.capacity) decide_one(true, DropReason::Evicted, sink);
  // Making room may have decided frames newer than this one; keeping it would break the output order.
  if (any_decided_ && frame.t_ns < decided_ns_) {
    drop(frame, DropReason::Evicted, sink);
  } else {
    list.insert(frame);
  }
  while (decide_one(false, DropReason::Unmatched, sink)) {
  }
}

void StereoPairer::flush(PairingReceiver& sink) noexcept { end_epoch(sink); }

void StereoPairer::end_epoch(PairingReceiver& sink) noexcept {
  while (decide_one(true, DropReason::Flushed, sink)) {
  }
  seen_ = {false, false};
  any_decided_ = false;
  offset_known_ = false;
  ++epoch_;
}

bool StereoPairer::oldest_side(CameraSide& side) const noexcept {
  const PendingList& l = lists_[0];
  const PendingList& r = lists_[1];
  if (l.size == 0 && r.size == 0) return false;
  if (r.size == 0 || (l.size > 0 && l.frames[0].t_ns <= r.frames[0].t_ns)) {
    side = CameraSide::Left;
  } else {
    side = CameraSide::Right;
  }
  return true;
}

// Decides the globally oldest pending frame if its fate is settled (or `force`): pairs it with its
// partner, or drops it with `unmatched_reason`. Returns whether it decided something.
bool StereoPairer::decide_one(bool force, DropReason unmatched_reason, PairingReceiver& sink) noexcept {
  CameraSide side{};
  if (!oldest_side(side)) return false;
  PendingList& list = lists_[index(side)];
  const std::int64_t t = list.frames[0].t_ns;
  const std::int64_t bound = decided_bound();
  const std::size_t partner = find_partner(list.frames[0]);
  if (partner != kNone) {
    // Nothing that can still arrive is older than `bound`, so the pair cannot be overtaken.
    if (!force && t > bound) return false;
    emit_pair(side, partner, sink);
    return true;
  }
  // A partner would lie in [t - window, t + window]; once the bound is past it none can still arrive.
  if (!force && !(bound != kMinNs && t < sat_sub(bound, config_.window_ns))) return false;
  const FrameDescriptor frame = list.take(0);
  any_decided_ = true;
  decided_ns_ = frame.t_ns;
  drop(frame, unmatched_reason, sink);
  return true;
}

std::size_t StereoPairer::find_partner(const FrameDescriptor& frame) noexcept {
  if (config_.mode == PairingMode::FrameId && offset_known_) {
    const PendingList& list = lists_[index(other(frame.side))];
    const std::uint64_t want =
        frame.side == CameraSide::Left ? frame.frame_id + id_offset_ : frame.frame_id - id_offset_;
    for (std::size_t i = 0; i < list.size; ++i) {
      if (list.frames[i].frame_id != want) continue;
      if (distance(list.frames[i].t_ns, frame.t_ns) <= static_cast<std::uint64_t>(config_.window_ns)) return i;
      // The id says "same trigger", the clock says otherwise: a camera missed a trigger and its counter
      // did not advance. Trust the clock and learn the offset again.
      offset_known_ = false;
      ++id_resyncs_;
      break;
    }
    if (offset_known_) return kNone;
  }
  return nearest_within_window(frame);
}

std::size_t StereoPairer::nearest_within_window(const FrameDescriptor& frame) const noexcept {
  const PendingList& list = lists_[index(other(frame.side))];
  std::size_t best = kNone;
  std::uint64_t best_distance = static_cast<std::uint64_t>(config_.window_ns);
  for (std::size_t i = 0; i < list.size; ++i) {
    const std::uint64_t d = distance(list.frames[i].t_ns, frame.t_ns);
    if (d <= best_distance && (best == kNone || d < best_distance)) {
      best = i;
      best_distance = d;
    }
  }
  return best;
}

void StereoPairer::emit_pair(CameraSide oldest, std::size_t partner, PairingReceiver& sink) noexcept {
  const FrameDescriptor a = lists_[index(other(oldest))].take(partner);
  const FrameDescriptor b = lists_[index(oldest)].take(0);
  FramePair pair;
  pair.left = oldest == CameraSide::Left ? b : a;
  pair.right = oldest == CameraSide::Left ? a : b;
  pair.skew_ns = pair.right.t_ns - pair.left.t_ns;  // |skew| <= window_ns, no overflow
  pair.epoch = epoch_;
  if (config_.mode == PairingMode::FrameId && !offset_known_) {
    id_offset_ = pair.right.frame_id - pair.left.frame_id;
    offset_known_ = true;
  }
  any_decided_ = true;
  decided_ns_ = b.t_ns;
  ++pairs_;
  skew_.record(pair.skew_ns);
  sink.on_pair(pair);
}

void StereoPairer::drop(const FrameDescriptor& frame, DropReason reason, PairingReceiver& sink) noexcept {
  SideCounters& c = counters(frame.side);
  switch (reason) {
    case DropReason::Unmatched: ++c.unmatched; break;
    case DropReason::Late: ++c.late; break;
    case DropReason::Evicted: ++c.evicted; break;
    case DropReason::Flushed: ++c.flushed; break;
  }
  sink.on_drop(frame, reason);
}

PairingStats StereoPairer::stats() const noexcept {
  PairingStats s;
  s.pairs = pairs_;
  s.id_resyncs = id_resyncs_;
  s.epoch = epoch_;
  s.left = left_;
  s.right = right_;
  s.skew_p50_ns = skew_.percentile(0.5);
  s.skew_p99_ns = skew_.percentile(0.99);
  s.skew_max_ns = skew_.max_ns();
  s.skew_mean_ns = skew_.mean_signed_ns();
  return s;
}

}  // namespace rutd
