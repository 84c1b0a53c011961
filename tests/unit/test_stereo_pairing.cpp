// StereoPairer against a brute-force reference matcher (every left/right couple within the window, over
// the frames that were not dropped), and SkewHistogram against nearest-rank percentiles of a sorted array.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <random>
#include <set>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "camera/stereo_pairing.hpp"
#include "core/input_error.hpp"

namespace rutd {
namespace {

constexpr std::int64_t kPeriodNs = 33'333'333;  // 30 fps
constexpr std::int64_t kWindowNs = 2'000'000;
constexpr std::uint32_t kRightBufferBase = 1'000'000;

struct Collector final : PairingReceiver {
  std::vector<FramePair> pairs;
  std::vector<std::pair<FrameDescriptor, DropReason>> drops;
  void on_pair(const FramePair& p) override { pairs.push_back(p); }
  void on_drop(const FrameDescriptor& f, DropReason r) override { drops.emplace_back(f, r); }
};

using BufferPairs = std::set<std::pair<std::uint32_t, std::uint32_t>>;

BufferPairs buffer_pairs(const std::vector<FramePair>& pairs) {
  BufferPairs out;
  for (const auto& p : pairs) out.emplace(p.left.buffer, p.right.buffer);
  return out;
}

// Brute force: every couple within the window. Asserts the test's own precondition that no frame has two
// candidates, so the expected pairing is unambiguous.
BufferPairs reference_pairs(const std::vector<FrameDescriptor>& left, const std::vector<FrameDescriptor>& right,
                            std::int64_t window_ns) {
  BufferPairs out;
  std::map<std::uint32_t, int> right_uses;
  for (const auto& l : left) {
    int candidates = 0;
    for (const auto& r : right) {
      if (std::llabs(r.t_ns - l.t_ns) <= window_ns) {
        out.emplace(l.buffer, r.buffer);
        ++candidates;
        ++right_uses[r.buffer];
      }
    }
    EXPECT_LE(candidates, 1) << "test stream is ambiguous";
  }
  for (const auto& [buffer, uses] : right_uses) EXPECT_LE(uses, 1) << "test stream is ambiguous";
  return out;
}

// Every pushed buffer comes back exactly once, in a pair or a drop.
void expect_conservation(const std::vector<FrameDescriptor>& pushed, const Collector& c) {
  std::multiset<std::uint32_t> back;
  for (const auto& p : c.pairs) {
    back.insert(p.left.buffer);
    back.insert(p.right.buffer);
  }
  for (const auto& [f, reason] : c.drops) back.insert(f.buffer);
  std::multiset<std::uint32_t> in;
  for (const auto& f : pushed) in.insert(f.buffer);
  EXPECT_EQ(back, in);
}

// Pairs within the window, sides right, earlier timestamps non-decreasing within an epoch.
void expect_well_formed(const std::vector<FramePair>& pairs, std::int64_t window_ns) {
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const auto& p = pairs[i];
    EXPECT_EQ(p.left.side, CameraSide::Left);
    EXPECT_EQ(p.right.side, CameraSide::Right);
    EXPECT_EQ(p.skew_ns, p.right.t_ns - p.left.t_ns);
    EXPECT_LE(std::llabs(p.skew_ns), window_ns);
    if (i > 0 && pairs[i - 1].epoch == p.epoch) {
      EXPECT_LE(std::min(pairs[i - 1].left.t_ns, pairs[i - 1].right.t_ns), std::min(p.left.t_ns, p.right.t_ns))
          << "pair " << i << " out of order";
      EXPECT_LT(pairs[i - 1].left.t_ns, p.left.t_ns);
      EXPECT_LT(pairs[i - 1].right.t_ns, p.right.t_ns);
    }
  }
}

FrameDescriptor frame(CameraSide side, std::uint64_t id, std::int64_t t_ns, std::uint32_t buffer) {
  return FrameDescriptor{side, id, t_ns, buffer};
}

struct Streams {
  std::vector<FrameDescriptor> left;
  std::vector<FrameDescriptor> right;
};

// n triggers; each side keeps a frame with probability keep, jittered uniformly by +-jitter_ns.
Streams make_streams(std::mt19937_64& rng, int n, double keep, std::int64_t jitter_ns) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::uniform_int_distribution<std::int64_t> jitter(-jitter_ns, jitter_ns);
  Streams s;
  const std::int64_t t0 = 5'000'000'000;
  for (int i = 0; i < n; ++i) {
    const std::int64_t t = t0 + i * kPeriodNs;
    const auto id = static_cast<std::uint64_t>(i);
    if (u(rng) < keep) s.left.push_back(frame(CameraSide::Left, id, t + jitter(rng), static_cast<std::uint32_t>(i)));
    if (u(rng) < keep)
      s.right.push_back(
          frame(CameraSide::Right, id, t + jitter(rng), kRightBufferBase + static_cast<std::uint32_t>(i)));
  }
  return s;
}

// Arrival order: each frame arrives at its timestamp plus a random delay in [0, max_delay_ns].
std::vector<FrameDescriptor> arrival_order(std::mt19937_64& rng, const Streams& s, std::int64_t max_delay_ns) {
  std::uniform_int_distribution<std::int64_t> delay(0, max_delay_ns);
  std::vector<std::pair<std::int64_t, FrameDescriptor>> keyed;
  for (const auto* side : {&s.left, &s.right})
    for (const auto& f : *side) keyed.emplace_back(f.t_ns + delay(rng), f);
  std::stable_sort(keyed.begin(), keyed.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<FrameDescriptor> out;
  for (const auto& k : keyed) out.push_back(k.second);
  return out;
}

Collector run(StereoPairer& pairer, const std::vector<FrameDescriptor>& order) {
  Collector c;
  for (const auto& f : order) {
    pairer.push(f, c);
    EXPECT_LE(pairer.pending(CameraSide::Left), pairer.config().capacity);
    EXPECT_LE(pairer.pending(CameraSide::Right), pairer.config().capacity);
  }
  pairer.flush(c);
  return c;
}

std::size_t count_reason(const Collector& c, DropReason reason) {
  return static_cast<std::size_t>(
      std::count_if(c.drops.begin(), c.drops.end(), [&](const auto& d) { return d.second == reason; }));
}

TEST(StereoPairing, SynchronisedStreamsPairOneToOneAsSoonAsBothArrive) {
  StereoPairer pairer(PairingConfig{});
  Collector c;
  std::vector<FrameDescriptor> pushed;
  const int n = 1000;
  for (int i = 0; i < n; ++i) {
    const std::int64_t t = 1'000'000'000 + i * kPeriodNs;
    const auto b = static_cast<std::uint32_t>(i);
    pushed.push_back(frame(CameraSide::Left, b, t, b));
    pushed.push_back(frame(CameraSide::Right, b, t, kRightBufferBase + b));
    pairer.push(pushed[pushed.size() - 2], c);
    pairer.push(pushed.back(), c);
    // With reorder_ns = 0 the pair is out the moment its second frame is in.
    ASSERT_EQ(c.pairs.size(), static_cast<std::size_t>(i + 1));
    EXPECT_EQ(c.pairs.back().left.buffer, b);
    EXPECT_EQ(c.pairs.back().right.buffer, kRightBufferBase + b);
  }
  pairer.flush(c);
  EXPECT_TRUE(c.drops.empty());
  expect_conservation(pushed, c);
  expect_well_formed(c.pairs, kWindowNs);
  const PairingStats s = pairer.stats();
  EXPECT_EQ(s.pairs, static_cast<std::uint64_t>(n));
  EXPECT_EQ(s.left.dropped() + s.right.dropped(), 0u);
  EXPECT_EQ(s.left.received, static_cast<std::uint64_t>(n));
  EXPECT_EQ(s.skew_max_ns, 0);
  EXPECT_EQ(s.skew_p99_ns, 0);
}

// A constant offset between the cameras: at the window edge every frame pairs, one nanosecond beyond
// none does.
TEST(StereoPairing, SkewAtWindowPairsAndBeyondDoesNot) {
  for (const std::int64_t offset : {kWindowNs, -kWindowNs, kWindowNs + 1, -kWindowNs - 1}) {
    std::vector<FrameDescriptor> order;
    for (int i = 0; i < 200; ++i) {
      const std::int64_t t = 10'000'000'000 + i * kPeriodNs;
      const auto b = static_cast<std::uint32_t>(i);
      order.push_back(frame(CameraSide::Left, b, t, b));
      order.push_back(frame(CameraSide::Right, b, t + offset, kRightBufferBase + b));
    }
    PairingConfig config;
    config.window_ns = kWindowNs;
    StereoPairer pairer(config);
    const Collector c = run(pairer, order);
    expect_conservation(order, c);
    expect_well_formed(c.pairs, kWindowNs);
    const bool inside = std::llabs(offset) <= kWindowNs;
    EXPECT_EQ(c.pairs.size(), inside ? 200u : 0u) << "offset " << offset;
    EXPECT_EQ(c.drops.size(), inside ? 0u : 400u) << "offset " << offset;
    if (inside) {
      EXPECT_EQ(pairer.stats().skew_max_ns, kWindowNs);
      EXPECT_DOUBLE_EQ(pairer.stats().skew_mean_ns, static_cast<double>(offset));
    } else {
      // All but the last frame or two are decided as unmatched while streaming, not at the flush.
      EXPECT_GE(count_reason(c, DropReason::Unmatched), 396u);
    }
  }
}

TEST(StereoPairing, RandomDropsAndJitterMatchBruteForceReference) {
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    std::mt19937_64 rng(seed);
    // Jitter up to 1.5 ms per side: some couples are within the 2 ms window, some are not.
    const Streams s = make_streams(rng, 500, 0.85, 1'500'000);
    const auto order = arrival_order(rng, s, kPeriodNs * 9 / 10);
    StereoPairer pairer(PairingConfig{});
    const Collector c = run(pairer, order);
    const BufferPairs expected = reference_pairs(s.left, s.right, kWindowNs);
    EXPECT_EQ(buffer_pairs(c.pairs), expected) << "seed " << seed;
    EXPECT_EQ(c.drops.size(), order.size() - 2 * expected.size()) << "seed " << seed;
    EXPECT_EQ(count_reason(c, DropReason::Late) + count_reason(c, DropReason::Evicted), 0u) << "seed " << seed;
    expect_conservation(order, c);
    expect_well_formed(c.pairs, kWindowNs);
    const PairingStats st = pairer.stats();
    EXPECT_EQ(st.left.dropped(), s.left.size() - expected.size());
    EXPECT_EQ(st.right.dropped(), s.right.size() - expected.size());
  }
}

TEST(StereoPairing, OutOfOrderArrivalWithinReorderHorizonMatchesReference) {
  for (const int n_frames : {1, 3, 6}) {
    for (std::uint64_t seed = 1; seed <= 10; ++seed) {
      std::mt19937_64 rng(seed * 100 + static_cast<std::uint64_t>(n_frames));
      const Streams s = make_streams(rng, 400, 0.9, 800'000);
      const std::int64_t max_delay = n_frames * kPeriodNs;
      const auto order = arrival_order(rng, s, max_delay);
      PairingConfig config;
      config.reorder_ns = max_delay + kPeriodNs / 2;
      config.capacity = static_cast<std::size_t>(2 * n_frames + 4);
      StereoPairer pairer(config);
      const Collector c = run(pairer, order);
      const BufferPairs expected = reference_pairs(s.left, s.right, kWindowNs);
      EXPECT_EQ(buffer_pairs(c.pairs), expected) << "N=" << n_frames << " seed " << seed;
      EXPECT_EQ(count_reason(c, DropReason::Late) + count_reason(c, DropReason::Evicted), 0u);
      expect_conservation(order, c);
      expect_well_formed(c.pairs, kWindowNs);
    }
  }
}

// The same shuffled input with no reorder allowance: late frames are dropped as Late, and what does come
// out is still a subset of the reference, in order.
TEST(StereoPairing, OutOfOrderBeyondHorizonDropsLateFramesOnly) {
  std::mt19937_64 rng(7);
  const Streams s = make_streams(rng, 400, 1.0, 500'000);
  const auto order = arrival_order(rng, s, 3 * kPeriodNs);
  StereoPairer pairer(PairingConfig{});
  const Collector c = run(pairer, order);
  const BufferPairs expected = reference_pairs(s.left, s.right, kWindowNs);
  const BufferPairs got = buffer_pairs(c.pairs);
  EXPECT_TRUE(std::includes(expected.begin(), expected.end(), got.begin(), got.end()));
  EXPECT_GT(count_reason(c, DropReason::Late), 0u);
  EXPECT_LT(got.size(), expected.size());
  expect_conservation(order, c);
  expect_well_formed(c.pairs, kWindowNs);
}

// Triggered cameras whose counters start at different values. `right_id(i)` gives the right id at trigger
// i; the buffer index is the trigger index so pairs can be checked against the trigger.
struct TriggeredRun {
  Collector c;
  PairingStats stats;
};

TriggeredRun run_triggered(const std::vector<int>& right_missing, bool counter_advances_on_miss,
                           PairingMode mode = PairingMode::FrameId) {
  std::mt19937_64 rng(42);
  std::uniform_int_distribution<std::int64_t> jitter(-400'000, 400'000);
  std::vector<FrameDescriptor> order;
  std::uint64_t right_id = 57;
  for (int i = 0; i < 120; ++i) {
    const std::int64_t t = 3'000'000'000 + i * kPeriodNs;
    const auto b = static_cast<std::uint32_t>(i);
    order.push_back(frame(CameraSide::Left, 1000 + b, t + jitter(rng), b));
    const bool missing = std::find(right_missing.begin(), right_missing.end(), i) != right_missing.end();
    if (!missing) order.push_back(frame(CameraSide::Right, right_id, t + jitter(rng), kRightBufferBase + b));
    if (!missing || counter_advances_on_miss) ++right_id;
  }
  PairingConfig config;
  config.mode = mode;
  StereoPairer pairer(config);
  TriggeredRun r{run(pairer, order), {}};
  r.stats = pairer.stats();
  expect_conservation(order, r.c);
  expect_well_formed(r.c.pairs, kWindowNs);
  for (const auto& p : r.c.pairs) EXPECT_EQ(p.right.buffer, p.left.buffer + kRightBufferBase);
  return r;
}

TEST(StereoPairing, TriggeredModeMissedTriggerWithStalledCounterResyncsOnce) {
  const TriggeredRun r = run_triggered({40}, false);
  EXPECT_EQ(r.stats.pairs, 119u);
  EXPECT_EQ(r.stats.id_resyncs, 1u);
  ASSERT_EQ(r.c.drops.size(), 1u);
  EXPECT_EQ(r.c.drops[0].first.buffer, 40u);
  EXPECT_EQ(r.c.drops[0].second, DropReason::Unmatched);
}

TEST(StereoPairing, TriggeredModeLostFrameKeepsOffset) {
  const TriggeredRun r = run_triggered({0, 40, 41}, true);
  EXPECT_EQ(r.stats.pairs, 117u);
  EXPECT_EQ(r.stats.id_resyncs, 0u);
  std::set<std::uint32_t> dropped;
  for (const auto& d : r.c.drops) dropped.insert(d.first.buffer);
  EXPECT_EQ(dropped, (std::set<std::uint32_t>{0, 40, 41}));
  EXPECT_EQ(r.stats.left.unmatched, 3u);
}

// Once the offset is known, a frame whose id disagrees is not paired even though its time fits.
TEST(StereoPairing, TriggeredModeRejectsTimeCoincidentFrameWithWrongId) {
  PairingConfig config;
  config.mode = PairingMode::FrameId;
  for (const PairingMode mode : {PairingMode::FrameId, PairingMode::Timestamp}) {
    config.mode = mode;
    StereoPairer pairer(config);
    Collector c;
    std::vector<FrameDescriptor> pushed;
    for (std::uint32_t i = 0; i < 20; ++i) {
      const std::int64_t t = 1'000'000'000 + i * kPeriodNs;
      const std::uint64_t rid = (i == 10) ? 9999 : 300 + i;  // a corrupt id at trigger 10
      pushed.push_back(frame(CameraSide::Left, 5 + i, t, i));
      pushed.push_back(frame(CameraSide::Right, rid, t + 100'000, kRightBufferBase + i));
    }
    for (const auto& f : pushed) pairer.push(f, c);
    pairer.flush(c);
    expect_conservation(pushed, c);
    EXPECT_EQ(c.pairs.size(), mode == PairingMode::FrameId ? 19u : 20u);
    EXPECT_EQ(pairer.stats().id_resyncs, 0u);
  }
}

// Left camera reconnects at frame 50 (its clock restarts near zero), the right one two frames later.
// Frames 50, 51 cannot pair (different clocks); left 52 arrives first and is still pending when the right
// clock's jump ends the epoch, so it is flushed too (documented: a jump flushes both sides).
TEST(StereoPairing, ClockResetFlushesAndStartsNewEpoch) {
  std::vector<FrameDescriptor> order;
  const int n = 120;
  auto time = [](int i, bool reset) { return reset ? 7'000'000 + i * kPeriodNs : 900'000'000'000 + i * kPeriodNs; };
  for (int i = 0; i < n; ++i) {
    const auto b = static_cast<std::uint32_t>(i);
    order.push_back(frame(CameraSide::Left, b, time(i, i >= 50), b));
    order.push_back(frame(CameraSide::Right, b, time(i, i >= 52) + 300'000, kRightBufferBase + b));
  }
  StereoPairer pairer(PairingConfig{});
  const Collector c = run(pairer, order);
  expect_conservation(order, c);
  expect_well_formed(c.pairs, kWindowNs);
  const PairingStats s = pairer.stats();
  EXPECT_EQ(s.left.clock_jumps, 1u);
  EXPECT_EQ(s.right.clock_jumps, 1u);
  EXPECT_EQ(s.pairs, static_cast<std::uint64_t>(n - 3));
  EXPECT_EQ(s.left.dropped(), 3u);
  EXPECT_EQ(s.right.dropped(), 3u);
  std::set<std::uint32_t> dropped;
  for (const auto& d : c.drops) dropped.insert(d.first.buffer);
  EXPECT_EQ(dropped,
            (std::set<std::uint32_t>{50, 51, 52, kRightBufferBase + 50, kRightBufferBase + 51, kRightBufferBase + 52}));
  for (const auto& p : c.pairs) {
    EXPECT_EQ(p.right.buffer, p.left.buffer + kRightBufferBase);
    EXPECT_EQ(p.epoch, p.left.buffer < 50 ? 0u : 2u);
  }
}

// The right camera stops: the left side's pending list stays bounded and its buffers come back.
TEST(StereoPairing, StalledCameraKeepsMemoryBoundedAndReturnsBuffers) {
  std::vector<FrameDescriptor> order;
  for (int i = 0; i < 200; ++i) {
    const auto b = static_cast<std::uint32_t>(i);
    order.push_back(frame(CameraSide::Left, b, 2'000'000'000 + i * kPeriodNs, b));
    if (i < 10) order.push_back(frame(CameraSide::Right, b, 2'000'000'000 + i * kPeriodNs, kRightBufferBase + b));
  }
  PairingConfig config;
  config.capacity = 5;
  StereoPairer pairer(config);
  const Collector c = run(pairer, order);  // asserts pending <= capacity after every push
  expect_conservation(order, c);
  const PairingStats s = pairer.stats();
  EXPECT_EQ(s.pairs, 10u);
  EXPECT_EQ(s.left.dropped(), 190u);
  EXPECT_EQ(s.right.dropped(), 0u);
  EXPECT_GE(s.left.evicted, 190u - config.capacity);
}

std::int64_t reference_percentile(const std::vector<std::int64_t>& sorted, double q) {
  const auto n = static_cast<double>(sorted.size());
  const auto rank = std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(q * n)));
  return sorted[rank - 1];
}

void expect_histogram_matches(const SkewHistogram& h, const std::vector<std::int64_t>& signed_skews) {
  std::vector<std::int64_t> mags;
  double sum = 0.0;
  for (auto v : signed_skews) {
    mags.push_back(std::llabs(v));
    sum += static_cast<double>(v);
  }
  std::sort(mags.begin(), mags.end());
  ASSERT_EQ(h.count(), mags.size());
  for (double q : {0.0, 0.01, 0.1, 0.5, 0.9, 0.99, 0.999, 1.0}) {
    const std::int64_t ref = reference_percentile(mags, q);
    const std::int64_t got = h.percentile(q);
    EXPECT_GE(got, ref) << "q=" << q;
    EXPECT_LT(got, ref + h.bin_width_ns()) << "q=" << q;
  }
  EXPECT_EQ(h.max_ns(), mags.back());
  EXPECT_NEAR(h.mean_signed_ns(), sum / static_cast<double>(mags.size()), 1e-6);
}

TEST(SkewHistogram, PercentilesMatchSortedReference) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> normal(150'000.0, 120'000.0);
  std::uniform_int_distribution<std::int64_t> uniform(-kWindowNs, kWindowNs);
  SkewHistogram h(kWindowNs);
  EXPECT_EQ(h.percentile(0.5), 0);
  std::vector<std::int64_t> samples;
  for (int i = 0; i < 20000; ++i) {
    const std::int64_t v =
        (i % 10 == 0) ? uniform(rng) : std::clamp<std::int64_t>(std::llround(normal(rng)), -kWindowNs, kWindowNs);
    samples.push_back(v);
    h.record(v);
  }
  expect_histogram_matches(h, samples);
  std::printf("skew histogram: bin %lld ns, p50 %lld ns, p99 %lld ns, max %lld ns\n",
              static_cast<long long>(h.bin_width_ns()), static_cast<long long>(h.percentile(0.5)),
              static_cast<long long>(h.percentile(0.99)), static_cast<long long>(h.max_ns()));
  h.reset();
  EXPECT_EQ(h.count(), 0u);
  EXPECT_EQ(h.max_ns(), 0);
}

TEST(SkewHistogram, PairerStatsReportEmittedSkews) {
  std::mt19937_64 rng(11);
  const Streams s = make_streams(rng, 2000, 0.95, 900'000);
  StereoPairer pairer(PairingConfig{});
  const Collector c = run(pairer, arrival_order(rng, s, kPeriodNs / 2));
  std::vector<std::int64_t> skews;
  for (const auto& p : c.pairs) skews.push_back(p.skew_ns);
  ASSERT_FALSE(skews.empty());
  expect_histogram_matches(pairer.skew_histogram(), skews);
  const PairingStats st = pairer.stats();
  EXPECT_EQ(st.skew_p50_ns, pairer.skew_histogram().percentile(0.5));
  EXPECT_EQ(st.skew_p99_ns, pairer.skew_histogram().percentile(0.99));
  EXPECT_EQ(st.skew_max_ns, pairer.skew_histogram().max_ns());
  std::printf("pairs %llu, dropped L %llu R %llu, skew p50 %lld us p99 %lld us max %lld us\n",
              static_cast<unsigned long long>(st.pairs), static_cast<unsigned long long>(st.left.dropped()),
              static_cast<unsigned long long>(st.right.dropped()), static_cast<long long>(st.skew_p50_ns / 1000),
              static_cast<long long>(st.skew_p99_ns / 1000), static_cast<long long>(st.skew_max_ns / 1000));
}

TEST(StereoPairing, RejectsBadConfiguration) {
  auto field_of = [](PairingConfig c) {
    try {
      StereoPairer p(c);
    } catch (const InputError& e) {
      return e.field();
    }
    return std::string();
  };
  PairingConfig c;
  c.window_ns = 0;
  EXPECT_EQ(field_of(c), "window_ns");
  c = PairingConfig{};
  c.reorder_ns = -1;
  EXPECT_EQ(field_of(c), "reorder_ns");
  c = PairingConfig{};
  c.jump_ns = c.window_ns;
  EXPECT_EQ(field_of(c), "jump_ns");
  c = PairingConfig{};
  c.capacity = 0;
  EXPECT_EQ(field_of(c), "capacity");
  c.capacity = StereoPairer::kMaxCapacity + 1;
  EXPECT_EQ(field_of(c), "capacity");
  EXPECT_EQ(field_of(PairingConfig{}), "");
}

}  // namespace
}  // namespace rutd
