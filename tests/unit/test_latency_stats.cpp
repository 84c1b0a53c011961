// LatencyHistogram against a sorted-array reference: nearest-rank percentiles of the same samples.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "runtime/latency_stats.hpp"

namespace rutd {
namespace {

// Nearest-rank percentile of sorted samples: the smallest v with at least q of the samples <= v.
std::int64_t reference_percentile(const std::vector<std::int64_t>& sorted, double q) {
  const auto n = static_cast<double>(sorted.size());
  const auto rank = std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(q * n)));
  return sorted[rank - 1];
}

void expect_matches_reference(const LatencyHistogram& h, std::vector<std::int64_t> samples) {
  std::sort(samples.begin(), samples.end());
  for (double q : {0.0, 0.01, 0.1, 0.25, 0.5, 0.75, 0.9, 0.95, 0.99, 0.999, 1.0}) {
    const std::int64_t ref = reference_percentile(samples, q);
    const std::int64_t got = h.percentile(q);
    // Bucket midpoint: at most half a bucket (1/64 of the value) away, or exact below 32 ns.
    EXPECT_LE(std::abs(got - ref), ref / 64 + 1) << "q=" << q << " ref=" << ref << " got=" << got;
  }
  const LatencySummary s = h.summary();
  EXPECT_EQ(s.count, samples.size());
  EXPECT_EQ(s.min_ns, samples.front());
  EXPECT_EQ(s.max_ns, samples.back());
  EXPECT_EQ(s.p50_ns, h.percentile(0.5));
  EXPECT_EQ(s.p90_ns, h.percentile(0.9));
  EXPECT_EQ(s.p99_ns, h.percentile(0.99));
  double sum = 0;
  for (auto v : samples) sum += static_cast<double>(v);
  EXPECT_NEAR(s.mean_ns, sum / static_cast<double>(samples.size()), 1e-9 * sum);
}

TEST(LatencyHistogram, EmptyReportsZeros) {
  LatencyHistogram h;
  const LatencySummary s = h.summary();
  EXPECT_EQ(s.count, 0u);
  EXPECT_EQ(s.p50_ns, 0);
  EXPECT_EQ(s.max_ns, 0);
  EXPECT_EQ(h.percentile(0.99), 0);
}

TEST(LatencyHistogram, LogNormalLatenciesMatchSortedReference) {
  std::mt19937_64 rng(42);
  // Around 5 ms with a long tail, as frame latencies look.
  std::lognormal_distribution<double> dist(std::log(5e6), 0.8);
  LatencyHistogram h;
  std::vector<std::int64_t> samples;
  for (int i = 0; i < 100000; ++i) {
    const auto v = static_cast<std::int64_t>(dist(rng));
    samples.push_back(v);
    h.record(v);
  }
  expect_matches_reference(h, samples);
}

TEST(LatencyHistogram, UniformOverManyDecadesMatchesSortedReference) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> exponent(0.0, 12.0);  // 1 ns .. 1 s, log-uniform
  LatencyHistogram h;
  std::vector<std::int64_t> samples;
  for (int i = 0; i < 50000; ++i) {
    const auto v = static_cast<std::int64_t>(std::pow(10.0, exponent(rng)));
    samples.push_back(v);
    h.record(v);
  }
  expect_matches_reference(h, samples);
}

TEST(LatencyHistogram, SmallValuesAreExact) {
  LatencyHistogram h;
  std::vector<std::int64_t> samples;
  for (std::int64_t v = 0; v < 32; ++v)
    for (int k = 0; k <= v % 5; ++k) {
      samples.push_back(v);
      h.record(v);
    }
  std::sort(samples.begin(), samples.end());
  for (double q : {0.05, 0.3, 0.5, 0.77, 0.9, 1.0}) EXPECT_EQ(h.percentile(q), reference_percentile(samples, q));
}

TEST(LatencyHistogram, NegativeSamplesCountAsZeroAndHugeOnesKeepExactMax) {
  LatencyHistogram h;
  h.record(-5);
  h.record(std::int64_t{1} << 50);  // beyond the last bucket's range
  EXPECT_EQ(h.summary().min_ns, 0);
  EXPECT_EQ(h.summary().max_ns, std::int64_t{1} << 50);
  EXPECT_EQ(h.percentile(1.0), std::int64_t{1} << 50);  // clamped to the exact max
  EXPECT_EQ(h.percentile(0.5), 0);
}

TEST(LatencyHistogram, BucketsTileTheRangeWithBoundedRelativeWidth) {
  EXPECT_EQ(LatencyHistogram::bucket_low(0), 0u);
  for (std::size_t b = 0; b + 1 < LatencyHistogram::kBuckets; ++b) {
    ASSERT_EQ(LatencyHistogram::bucket_high(b) + 1, LatencyHistogram::bucket_low(b + 1)) << b;
    const auto low = LatencyHistogram::bucket_low(b), high = LatencyHistogram::bucket_high(b);
    EXPECT_EQ(LatencyHistogram::bucket_of(low), b);
    EXPECT_EQ(LatencyHistogram::bucket_of(high), b);
    EXPECT_LE(static_cast<double>(high - low), static_cast<double>(low) / 32.0 + 1e-9) << b;
  }
}

TEST(LatencyHistogram, ResetForgetsEverything) {
  LatencyHistogram h;
  for (int i = 1; i <= 100; ++i) h.record(i * 1000);
  h.reset();
  EXPECT_EQ(h.count(), 0u);
  h.record(777);
  EXPECT_EQ(h.summary().min_ns, 777);
  EXPECT_EQ(h.summary().max_ns, 777);
  EXPECT_EQ(h.summary().count, 1u);
}

// One writer, one reader at the same time (run under ThreadSanitizer too): snapshots never report more
// samples than were recorded and stay ordered.
TEST(LatencyHistogram, ConcurrentReaderSeesConsistentSnapshots) {
  LatencyHistogram h;
  constexpr int kSamples = 200000;
  std::jthread writer([&] {
    for (int i = 0; i < kSamples; ++i) h.record(1000 + (i % 997) * 1000);
  });
  std::uint64_t last = 0;
  for (int i = 0; i < 200; ++i) {
    const LatencySummary s = h.summary();
    EXPECT_GE(s.count, last);
    EXPECT_LE(s.count, static_cast<std::uint64_t>(kSamples));
    if (s.count > 0) {
      EXPECT_LE(s.p50_ns, s.p99_ns);
      EXPECT_LE(s.p99_ns, s.max_ns);
    }
    last = s.count;
  }
  writer.join();
  EXPECT_EQ(h.summary().count, static_cast<std::uint64_t>(kSamples));
}

}  // namespace
}  // namespace rutd
