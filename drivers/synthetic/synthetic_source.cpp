// The synthetic live source (synthetic/synthetic_source.hpp).
#include "synthetic/synthetic_source.hpp"

#include <cerrno>
#include <cmath>
#include <ctime>

#include "camera_pop_fault.hpp"
#include "core/monotonic_clock.hpp"

namespace rutd {
namespace {

void sleep_until_ns(std::int64_t deadline_ns) {
  timespec deadline{};
  deadline.tv_sec = static_cast<time_t>(deadline_ns / 1'000'000'000);
  deadline.tv_nsec = static_cast<long>(deadline_ns % 1'000'000'000);
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &deadline, nullptr) == EINTR) {
  }
}

}  // namespace

SyntheticSource::SyntheticSource(const SyntheticRendererConfig& params, SyntheticSourceConfig options, IoFaults* faults)
    : renderer_(params), options_(options), faults_(faults) {}

void SyntheticSource::wait_for_slot() {
  const double period_ns = 1e9 / renderer_.params().fps;
  const std::int64_t now = monotonic_now_ns();
  const auto due = [&] {
    return schedule_start_ns_ + std::llround(static_cast<double>(produced_ - schedule_first_) * period_ns);
  };
  // First pair, or more than one period late: restart the schedule now rather than catch up in a burst.
  if (schedule_start_ns_ < 0 || now > due() + std::llround(period_ns)) {
    schedule_start_ns_ = now;
    schedule_first_ = produced_;
  }
  const std::int64_t slot = due();
  if (slot > now) sleep_until_ns(slot);
}

SourceStatus SyntheticSource::next(StereoFrame& frame) {
  if (options_.frame_count != 0 && produced_ >= options_.frame_count) return SourceStatus::EndOfStream;
  if (options_.paced) wait_for_slot();
  error_.clear();
  if (const SourceStatus fault = check_camera_pop_fault(faults_, error_); fault != SourceStatus::Ok) {
    ++produced_;  // this period's pair is lost, as a camera's would be: its index is skipped
    return fault;
  }
  renderer_.render(options_.first_index + produced_, frame);
  // A live pair is stamped when rendering ends: the render stands for the exposure and read-out of a
  // real camera, and its cost is the simulator's, not latency of the pipeline that measures the pair.
  if (options_.paced) frame.t_ns = monotonic_now_ns();
  frame.clock = ClockKind::Monotonic;
  ++produced_;
  return SourceStatus::Ok;
}

}  // namespace rutd
