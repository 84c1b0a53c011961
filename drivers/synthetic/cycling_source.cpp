#include "synthetic/cycling_source.hpp"

#include <cstring>
#include <stdexcept>
#include <thread>

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
  if (const int fault = faults_ != nullptr ? faults_->check(IoPoint::CameraPop) : 0) {
    // The pair of this period is lost, as a camera's would be; the sequence number still advances.
    ++seq_;
    if (fault == io_fault::kTimeout) return SourceStatus::Timeout;
    error_ = fault == io_fault::kShort     ? "synthetic camera: short buffer"
             : fault == io_fault::kCorrupt ? "synthetic camera: corrupt buffer"
                                           : std::string("synthetic camera: ") + std::strerror(fault);
    return SourceStatus::Error;
  }
  const StereoFrame& src = frames_[seq_ % frames_.size()];
  src.left.copyTo(f.left);
  src.right.copyTo(f.right);
  f.seq = seq_++;
  f.t_ns = monotonic_now_ns();
  f.clock = ClockKind::Monotonic;
  return SourceStatus::Ok;
}

}  // namespace rutd
