#include "daemon/replay_status.hpp"

#include <stdexcept>

namespace rutd {

ReplayStatus::ReplayStatus(std::chrono::milliseconds period, std::chrono::milliseconds no_frame_timeout)
    : period_ns_(std::chrono::nanoseconds(period).count()),
      timeout_ns_(std::chrono::nanoseconds(no_frame_timeout).count()) {
  if (period_ns_ <= 0 || timeout_ns_ <= 0)
    throw std::invalid_argument("replay status: the period and the timeout must be positive");
}

void ReplayStatus::advance(std::int64_t t_ns, MeasurementSink& sink) {
  if (!started_) {
    started_ = true;
    next_ns_ = t_ns + period_ns_;
    last_pair_ns_ = rate_t0_ns_ = t_ns;
    rate_pairs_ = 1;  // the first pair opens the first window: the rate counts the pairs after it
    return;
  }
  for (std::int64_t n = 0; next_ns_ < t_ns; ++n) {
    if (n == kMaxGapStatuses) {
      next_ns_ = t_ns + period_ns_;
      break;
    }
    send(next_ns_, sink);
    next_ns_ += period_ns_;
  }
}

void ReplayStatus::add(std::int64_t t_ns, bool fitted, RutStatus status) {
  last_pair_ns_ = t_ns;
  ++pairs_;
  (fitted ? fitted_ : rejected_) = true;
  health_.last_status = status;
}

void ReplayStatus::send(std::int64_t t_ns, MeasurementSink& sink) {
  SensorHealth& h = health_;
  h.no_camera = t_ns - last_pair_ns_ > timeout_ns_;
  // A state of the cameras, not an event: held until a pair fits again (as the pipeline holds it).
  h.calibration_invalid = rejected_ || (h.calibration_invalid && !fitted_);
  h.low_texture = h.last_status == RutStatus::TooFewPoints;
  rejected_ = fitted_ = false;
  if (t_ns - rate_t0_ns_ >= 1'000'000'000) {
    h.frame_rate_hz = static_cast<double>(pairs_ - rate_pairs_) / (static_cast<double>(t_ns - rate_t0_ns_) * 1e-9);
    rate_t0_ns_ = t_ns;
    rate_pairs_ = pairs_;
  }
  sink.publish_status(h, t_ns);
  ++sent_;
}

SensorHealth ReplayStatus::health() const { return health_; }

void ReplayStatus::finish(MeasurementSink& sink) {
  if (started_) send(last_pair_ns_, sink);
}

}  // namespace rutd
