#pragma once
// The measurement sink for CAN (the adapter between the sink interface, core/measurement_sink.hpp,
// and the CAN transport of this folder): what `rutd run` sends on the bus and logs, and what `rutd
// replay --candump` writes. Called from the publishing thread only.
#include <array>
#include <cstdint>
#include <functional>
#include <iosfwd>
#include <optional>

#include "can/can_encoder.hpp"
#include "can/candump_log.hpp"
#include "can/socketcan_bus.hpp"
#include "core/measurement_sink.hpp"

namespace rutd {

// Where the candump log's timestamps come from.
enum class CandumpTime : std::uint8_t {
  // The moment of sending, as candump itself stamps frames (live: the log lines up with other logs).
  WallClock,
  // The frame's capture time (PublishedFrame::t_ns) and the status's own time (publish_status's t_ns):
  // replay, where the log is then what the vehicle would have sent, on the recording's clock.
  FrameClock,
};

// CAN: every measurement and status is encoded once; each frame goes to the bus (when configured) and
// to the candump log (when configured), so the log is exactly what the bus got. With a bus, frames the
// kernel refused (full queue, failed write) are counted, reported in the status message (CanTxDrops) and
// not logged. RecordingError is whatever recording_failed answers at each status (the daemon: the raw
// recording has failed, or a measurement CSV row was lost since the last status). The software version
// goes out as RutSoftwareVersion with the first status frame and then once a second (status time), so a
// receiver that joins the bus late learns within a second what is sending. With enable_motion, RutMotion
// says per measurement whether the speed was known and where the vehicle was.
class CanSink final : public MeasurementSink {
 public:
  // bus and log may be null (not configured); neither is owned, both must outlive the sink. log_stream
  // is flushed per call so a reader of a pipe sees frames as they are sent. recording_failed, when set,
  // is asked on the publish thread at every status (FrameRecorder::failed, which is thread-safe): the
  // CAN library knows nothing of recordings. version: what RutSoftwareVersion says (the daemon:
  // daemon/build_info.hpp's software_version()); none: the frame is not sent (tests of other frames).
  CanSink(const CanIdConfig& ids, SocketCanBus* bus, CandumpLogWriter* log, std::ostream* log_stream,
          std::function<bool()> recording_failed = {}, CandumpTime log_time = CandumpTime::WallClock,
          std::optional<SoftwareVersion> version = {});
  // From now on, RutMotion follows every measurement's RutConditions (the frame's motion and position).
  // Off by default: only a daemon with a vehicle speed source or a positioning source has anything to say
  // there.
  void enable_motion() noexcept { motion_ = true; }
  void publish(const PublishedFrame& frame) override;
  void publish_status(const SensorHealth& health, std::int64_t t_ns) override;
  // RutSegment and RutSegmentStats, stamped (FrameClock) with the segment's last frame's time.
  void publish_segment(const Segment& segment) override;

 private:
  // frame_t_ns: the time CandumpTime::FrameClock logs.
  void emit(const CanFrame& frame, std::int64_t frame_t_ns);

  CanEncoder encoder_;
  SocketCanBus* bus_;
  CandumpLogWriter* log_;
  std::ostream* log_stream_;
  std::function<bool()> recording_failed_;
  CandumpTime log_time_;
  std::array<CanFrame, 2> frames_{};
  std::uint64_t not_sent_at_last_status_ = 0;
  std::optional<SoftwareVersion> version_;
  bool motion_ = false;
  std::optional<std::int64_t> version_sent_ns_;  // status time of the last RutSoftwareVersion frame
};

}  // namespace rutd
