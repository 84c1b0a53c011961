#pragma once
// The pipeline's measurement sink for CAN (the adapter between pipeline/measurement_sink.hpp and the
// CAN transport of this folder). Called from the pipeline's publish thread only.
#include <array>
#include <cstdint>
#include <functional>
#include <iosfwd>
#include <optional>

#include "can/can_encoder.hpp"
#include "can/candump_log.hpp"
#include "can/socketcan_bus.hpp"
#include "pipeline/measurement_sink.hpp"

namespace rutd {

// CAN: every measurement and status is encoded once; each frame goes to the bus (when configured) and
// to the candump log (when configured), so the log is exactly what the bus got. With a bus, frames the
// kernel refused (full queue, failed write) are counted, reported in the status message (CanTxDrops) and
// not logged. RecordingError is whatever recording_failed answers at each status (the daemon: the raw
// recording has failed, or a measurement CSV row was lost since the last status). The software version
// goes out as RutSoftwareVersion with the first status frame and then once a second (status time), so a
// receiver that joins the bus late learns within a second what is sending.
class CanSink final : public MeasurementSink {
 public:
  // bus and log may be null (not configured); neither is owned, both must outlive the sink. log_stream
  // is flushed per call so a reader of a pipe sees frames as they are sent. recording_failed, when set,
  // is asked on the publish thread at every status (FrameRecorder::failed, which is thread-safe): the
  // CAN library knows nothing of recordings. version: what RutSoftwareVersion says (the daemon:
  // daemon/build_info.hpp's software_version()); none: the frame is not sent (tests of other frames).
  CanSink(const CanIdConfig& ids, SocketCanBus* bus, CandumpLogWriter* log, std::ostream* log_stream,
          std::function<bool()> recording_failed = {}, std::optional<SoftwareVersion> version = {});
  void publish(const FrameWork& work, const SensorHealth& health) override;
  void publish_status(const SensorHealth& health, std::int64_t t_ns) override;

 private:
  void emit(const CanFrame& frame);

  CanEncoder encoder_;
  SocketCanBus* bus_;
  CandumpLogWriter* log_;
  std::ostream* log_stream_;
  std::function<bool()> recording_failed_;
  std::array<CanFrame, 2> frames_{};
  std::uint64_t not_sent_at_last_status_ = 0;
  std::optional<SoftwareVersion> version_;
  std::optional<std::int64_t> version_sent_ns_;  // status time of the last RutSoftwareVersion frame
};

}  // namespace rutd
