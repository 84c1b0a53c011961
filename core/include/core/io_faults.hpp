#pragma once
// Fault injection at the lowest I/O calls, for tests only. A driver given an IoFaults asks it just
// before its system call (or library call) whether this call fails, and how; it then behaves exactly as
// if the call had failed that way. Drivers take a nullable pointer: production code never creates an
// IoFaults (no configuration key, option or environment variable reaches one), so there the cost is one
// predictable branch per call. Tests create one and hand it to the drivers they build, or run the daemon
// through the test-only program tests/fault/rutd_faults.cpp.
//
// Thread safety: set() before the drivers start using it; check() and the counters from any thread.
#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <limits>

namespace rutd {

// Where a fault is injected.
enum class IoPoint {
  CameraPop,         // taking the next buffer/pair from a camera or a synthetic/replay source
  CanWrite,          // write() of a frame on the CAN socket
  RecordWrite,       // write() of an image or a frames.csv line of a recording
  ImageDecode,       // decoding a recorded image (PNG) when replaying
  MeasurementWrite,  // write() of a row of the measurement CSV (sinks.csv)
};
inline constexpr std::size_t kIoPointCount = 5;

// What the call does instead of its work: a positive value is an errno (ENOSPC, EIO, ENOBUFS ...); the
// others are the non-errno failures below.
namespace io_fault {
inline constexpr int kTimeout = -1;  // the wait ran out with nothing delivered
inline constexpr int kCorrupt = -2;  // a buffer/file arrived but its content is unusable
inline constexpr int kShort = -3;    // fewer bytes than asked for (a short buffer, a short write)
}  // namespace io_fault

struct IoFaultRule {
  int fault = 0;            // 0: never
  std::uint64_t every = 1;  // the Nth, 2Nth ... call inside the window fails (1: every call)
  // Active window in seconds since the first call at this point (steady clock), so that a window lands
  // in the same place of a run whatever its start-up took (rendering, priming): the fault stops at
  // until_s.
  double from_s = 0.0;
  double until_s = std::numeric_limits<double>::infinity();
};

class IoFaults {
 public:
  void set(IoPoint point, IoFaultRule rule) noexcept { at(point).rule = rule; }

  // 0: do the call. Otherwise the fault to behave as.
  int check(IoPoint point) noexcept {
    Point& p = at(point);
    if (p.rule.fault == 0) return 0;
    const std::int64_t now = std::chrono::steady_clock::now().time_since_epoch().count();
    std::int64_t first = 0;
    if (p.first_call.compare_exchange_strong(first, now, std::memory_order_relaxed)) first = now;
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::duration(now - first)).count();
    if (t < p.rule.from_s || t >= p.rule.until_s) return 0;
    const std::uint64_t n = p.calls_in_window.fetch_add(1, std::memory_order_relaxed) + 1;
    if (p.rule.every > 1 && n % p.rule.every != 0) return 0;
    p.injected.fetch_add(1, std::memory_order_relaxed);
    return p.rule.fault;
  }

  std::uint64_t injected(IoPoint point) const noexcept { return at(point).injected.load(std::memory_order_relaxed); }

 private:
  struct Point {
    IoFaultRule rule;
    std::atomic<std::int64_t> first_call{0};  // steady clock ticks; 0: no call yet
    std::atomic<std::uint64_t> calls_in_window{0};
    std::atomic<std::uint64_t> injected{0};
  };
  Point& at(IoPoint point) noexcept { return points_[static_cast<std::size_t>(point)]; }
  const Point& at(IoPoint point) const noexcept { return points_[static_cast<std::size_t>(point)]; }

  std::array<Point, kIoPointCount> points_{};
};

}  // namespace rutd
