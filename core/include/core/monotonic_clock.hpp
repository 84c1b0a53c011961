#pragma once
// The one clock of rutd's per-frame path: CLOCK_MONOTONIC, in nanoseconds. Frame ages, latencies,
// pacing, stall detection and the watchdog all compare times taken with it (DESIGN.md, Units and
// conventions). std::chrono::steady_clock is the same clock on Linux; this form needs no conversion
// and is async-signal-safe.
#include <time.h>

#include <cstdint>

namespace rutd {

inline std::int64_t monotonic_now_ns() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

// The wall clock (CLOCK_REALTIME, UTC, ns since 1970), for what leaves the machine with a date: candump
// logs as candump writes them, the uplink's messages. Never for intervals: it jumps when set.
inline std::int64_t unix_now_ns() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

}  // namespace rutd
