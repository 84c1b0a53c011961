#include "can/can_sink.hpp"

#include <ostream>
#include <utility>

#include "core/monotonic_clock.hpp"

namespace rutd {
namespace {

constexpr std::int64_t kVersionPeriodNs = 1'000'000'000;

}  // namespace

CanSink::CanSink(const CanIdConfig& ids, SocketCanBus* bus, CandumpLogWriter* log, std::ostream* log_stream,
                 std::function<bool()> recording_failed, CandumpTime log_time, std::optional<SoftwareVersion> version)
    : encoder_(ids),
      bus_(bus),
      log_(log),
      log_stream_(log_stream),
      recording_failed_(std::move(recording_failed)),
      log_time_(log_time),
      version_(version) {}

void CanSink::emit(const CanFrame& frame, std::int64_t frame_t_ns) {
  if (bus_ != nullptr && !bus_->send(frame)) return;
  if (log_ != nullptr) log_->write(frame, log_time_ == CandumpTime::FrameClock ? frame_t_ns : unix_now_ns());
}

void CanSink::publish(const PublishedFrame& frame) {
  const int n = encoder_.encode_measurement(frame.measurement, frames_);
  for (int i = 0; i < n; ++i) emit(frames_[static_cast<std::size_t>(i)], frame.t_ns);
  emit(encoder_.encode_conditions(frame.measurement), frame.t_ns);
  if (motion_) emit(encoder_.encode_motion(frame.motion, frame.position), frame.t_ns);
  if (log_stream_ != nullptr) log_stream_->flush();
}

void CanSink::publish_segment(const Segment& segment) {
  const int n = encoder_.encode_segment(segment, frames_);
  for (int i = 0; i < n; ++i) emit(frames_[static_cast<std::size_t>(i)], segment.t_end_ns);
  if (log_stream_ != nullptr) log_stream_->flush();
}

void CanSink::publish_status(const SensorHealth& health, std::int64_t t_ns) {
  SensorHealth h = health;
  if (bus_ != nullptr) {
    bus_->poll_errors();
    h.bus_off = bus_->bus_off();
    // Raised for the period in which frames were not sent, like the pipeline's frame_drops: refused by a
    // full queue (dropped) or by a failed write (interface down: write_errors).
    const std::uint64_t not_sent = bus_->stats().dropped + bus_->stats().write_errors;
    h.can_tx_drops = not_sent != not_sent_at_last_status_;
    not_sent_at_last_status_ = not_sent;
  }
  // The caller's answer: raised for good once the raw recording failed (the recorder does not resume by
  // itself), and for each status period in which a measurement CSV row was lost.
  if (recording_failed_ && recording_failed_()) h.recording_error = true;
  emit(encoder_.encode_status(h), t_ns);
  if (h.uplink.enabled) emit(encoder_.encode_uplink(h.uplink), t_ns);
  if (version_ && (!version_sent_ns_ || t_ns - *version_sent_ns_ >= kVersionPeriodNs)) {
    emit(encoder_.encode_version(*version_), t_ns);
    version_sent_ns_ = t_ns;
  }
  if (log_stream_ != nullptr) log_stream_->flush();
}

}  // namespace rutd
