#include "synthetic/cycling_source.hpp"

#include <stdexcept>
#include <thread>

#include "camera_pop_fault.hpp"
#include "core/monotonic_clock.hpp"

namespace rutd {

CyclingSource::CyclingSource(StereoCalibration calibration, std::vector<StereoFrame> frames,
                             std::chrono::nanoseconds period, IoFaults* faults)
    : calibration_(std::move(calibration)), frames_(std::move(frames)), period_(period), faults_(faults) {
  if (frames_.empty()) throw std::invalid_argument("CyclingSource needs at least one stereo pair");
}

SourceStatus CyclingSource::next(StereoFrame& f) {
  if (period_.count() > 0) {
    const auto now = std::chrono::steady_clock::now();
    // A late caller restarts the schedule instead of catching up in a burst.
    due_ = due_ == std::chrono::steady_clock::time_point{} || due_ + period_ < now ? now : due_ + period_;
    std::this_thread::sleep_until(due_);
  }
  error_.clear();
  if (const SourceStatus fault = check_camera_pop_fault(faults_, error_); fault != SourceStatus::Ok) {
    ++seq_;  // the pair of this period is lost, as a camera's would be; the sequence number still advances
    return fault;
  }
  const StereoFrame& src = frames_[seq_ % frames_.size()];
  src.left.copyTo(f.left);
  src.right.copyTo(f.right);
  f.seq = seq_++;
  f.t_ns = monotonic_now_ns();
  f.skew_ns = src.skew_ns;
  f.clock = ClockKind::Monotonic;
  return SourceStatus::Ok;
}

}  // namespace rutd
