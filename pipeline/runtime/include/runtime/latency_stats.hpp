#pragma once
// Latency histograms for the real-time pipeline: fixed-size, log-linear buckets (no allocation, ever),
// one writer thread and any number of reader threads.
//
// Buckets: values 0..31 ns have one bucket each (exact); above, every power of two [2^e, 2^(e+1)) is
// split into 32 equal buckets, up to 2^kMaxExponent ns (about 2.4 hours); larger values land in the last
// bucket. A percentile is reported as the midpoint of its bucket clamped to the recorded min/max (the
// last, overflow bucket reports the exact max), so below 2^kMaxExponent ns its relative error is at most
// 1/64 (1.6 %) of the true nearest-rank value.
#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>

namespace rutd {

struct LatencySummary {
  std::uint64_t count = 0;
  std::int64_t min_ns = 0;  // all fields 0 when count == 0
  std::int64_t p50_ns = 0;
  std::int64_t p90_ns = 0;
  std::int64_t p99_ns = 0;
  std::int64_t max_ns = 0;
  double mean_ns = 0.0;
};

class LatencyHistogram {
 public:
  static constexpr int kSubBits = 5;
  static constexpr std::size_t kSubBuckets = std::size_t{1} << kSubBits;  // 32
  static constexpr int kMaxExponent = 43;
  static constexpr std::size_t kBuckets = kSubBuckets + (kMaxExponent - kSubBits) * kSubBuckets;

  LatencyHistogram() noexcept;

  // Adds one sample in nanoseconds (negative values count as 0). Wait-free, no allocation. Only one
  // thread may call record() (or reset()) on a histogram; readers may run concurrently.
  void record(std::int64_t ns) noexcept;
  // Forgets every sample. Same single-writer rule as record().
  void reset() noexcept;

  // Any thread. Nearest-rank percentile, q in [0, 1] (the smallest recorded value v such that at least
  // q of the samples are <= v), within the bucket error above; 0 when empty.
  std::int64_t percentile(double q) const noexcept;
  // Any thread. A snapshot taken while record() runs may miss the newest samples but is self-consistent
  // (percentiles computed from one copy of the buckets).
  LatencySummary summary() const noexcept;
  std::uint64_t count() const noexcept { return count_.load(std::memory_order_relaxed); }

  // Bucket geometry, for tests: bucket_of(v) is the bucket holding v; it covers [low, high] inclusive.
  static std::size_t bucket_of(std::uint64_t ns) noexcept;
  static std::uint64_t bucket_low(std::size_t bucket) noexcept;
  static std::uint64_t bucket_high(std::size_t bucket) noexcept;

 private:
  using Counts = std::array<std::uint64_t, kBuckets>;
  void copy_counts(Counts& out, std::uint64_t& total) const noexcept;
  std::int64_t percentile_of(const Counts& counts, std::uint64_t total, double q, std::int64_t min_ns,
                             std::int64_t max_ns) const noexcept;

  // Single writer: plain load + store (no read-modify-write) on relaxed atomics.
  std::array<std::atomic<std::uint64_t>, kBuckets> counts_;
  std::atomic<std::uint64_t> count_{0};
  std::atomic<std::int64_t> sum_ns_{0};
  std::atomic<std::int64_t> min_ns_{0};
  std::atomic<std::int64_t> max_ns_{0};
};

}  // namespace rutd
