#include "runtime/latency_stats.hpp"

#include <algorithm>
#include <bit>
#include <cmath>

namespace rutd {
namespace {

constexpr auto kRelaxed = std::memory_order_relaxed;

// Single-writer increment: no locked instruction needed, readers see either value.
void bump(std::atomic<std::uint64_t>& a) noexcept { a.store(a.load(kRelaxed) + 1, kRelaxed); }

}  // namespace

LatencyHistogram::LatencyHistogram() noexcept {
  for (auto& c : counts_) c.store(0, kRelaxed);
}

std::size_t LatencyHistogram::bucket_of(std::uint64_t ns) noexcept {
  if (ns < kSubBuckets) return static_cast<std::size_t>(ns);
  const int e = std::bit_width(ns) - 1;  // >= kSubBits
  if (e >= kMaxExponent) return kBuckets - 1;
  const int shift = e - kSubBits;
  const std::size_t sub = static_cast<std::size_t>(ns >> shift) & (kSubBuckets - 1);
  return kSubBuckets + static_cast<std::size_t>(shift) * kSubBuckets + sub;
}

std::uint64_t LatencyHistogram::bucket_low(std::size_t bucket) noexcept {
  if (bucket < kSubBuckets) return bucket;
  const std::size_t shift = (bucket - kSubBuckets) / kSubBuckets;
  const std::uint64_t sub = (bucket - kSubBuckets) % kSubBuckets;
  return (kSubBuckets + sub) << shift;
}

std::uint64_t LatencyHistogram::bucket_high(std::size_t bucket) noexcept {
  if (bucket < kSubBuckets) return bucket;
  const std::size_t shift = (bucket - kSubBuckets) / kSubBuckets;
  return bucket_low(bucket) + (std::uint64_t{1} << shift) - 1;
}

void LatencyHistogram::record(std::int64_t ns) noexcept {
  const std::int64_t v = std::max<std::int64_t>(ns, 0);
  bump(counts_[bucket_of(static_cast<std::uint64_t>(v))]);
  const std::uint64_t n = count_.load(kRelaxed);
  if (n == 0 || v < min_ns_.load(kRelaxed)) min_ns_.store(v, kRelaxed);
  if (n == 0 || v > max_ns_.load(kRelaxed)) max_ns_.store(v, kRelaxed);
  sum_ns_.store(sum_ns_.load(kRelaxed) + v, kRelaxed);
  count_.store(n + 1, kRelaxed);
}

void LatencyHistogram::reset() noexcept {
  for (auto& c : counts_) c.store(0, kRelaxed);
  count_.store(0, kRelaxed);
  sum_ns_.store(0, kRelaxed);
  min_ns_.store(0, kRelaxed);
  max_ns_.store(0, kRelaxed);
}

void LatencyHistogram::copy_counts(Counts& out, std::uint64_t& total) const noexcept {
  total = 0;
  for (std::size_t i = 0; i < kBuckets; ++i) {
    out[i] = counts_[i].load(kRelaxed);
    total += out[i];
  }
}

std::int64_t LatencyHistogram::percentile_of(const Counts& counts, std::uint64_t total, double q, std::int64_t min_ns,
                                             std::int64_t max_ns) const noexcept {
  if (total == 0) return 0;
  const double clamped = std::clamp(std::isnan(q) ? 0.0 : q, 0.0, 1.0);
  const auto rank = std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::ceil(clamped * total)));
  std::uint64_t seen = 0;
  std::size_t bucket = kBuckets - 1;
  for (std::size_t i = 0; i < kBuckets; ++i) {
    seen += counts[i];
    if (seen >= rank) {
      bucket = i;
      break;
    }
  }
  if (bucket == kBuckets - 1) return max_ns;  // the overflow bucket has no upper bound
  const std::uint64_t low = bucket_low(bucket);
  const auto mid = static_cast<std::int64_t>(low + (bucket_high(bucket) - low) / 2);
  return std::clamp(mid, min_ns, std::max(min_ns, max_ns));
}

std::int64_t LatencyHistogram::percentile(double q) const noexcept {
  Counts counts;
  std::uint64_t total = 0;
  copy_counts(counts, total);
  return percentile_of(counts, total, q, min_ns_.load(kRelaxed), max_ns_.load(kRelaxed));
}

LatencySummary LatencyHistogram::summary() const noexcept {
  Counts counts;
  LatencySummary s;
  copy_counts(counts, s.count);
  if (s.count == 0) return s;
  s.min_ns = min_ns_.load(kRelaxed);
  s.max_ns = max_ns_.load(kRelaxed);
  s.p50_ns = percentile_of(counts, s.count, 0.50, s.min_ns, s.max_ns);
  s.p90_ns = percentile_of(counts, s.count, 0.90, s.min_ns, s.max_ns);
  s.p99_ns = percentile_of(counts, s.count, 0.99, s.min_ns, s.max_ns);
  const std::uint64_t n = count_.load(kRelaxed);
  s.mean_ns = n > 0 ? static_cast<double>(sum_ns_.load(kRelaxed)) / static_cast<double>(n) : 0.0;
  return s;
}

}  // namespace rutd
