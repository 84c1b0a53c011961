#pragma once
// Two Aravis cameras as one FrameSource of synchronised pairs (DESIGN.md, step 1).
//
// - Acquisition (the pipeline's acquire thread, the only caller of next()) pops finished buffers from both
//   streams, pairs them with StereoPairer (by hardware timestamp when free-running, by frame id when
//   triggered; a pair whose skew exceeds pairing_window_ms never comes out), converts the pair to grey
//   and gives the buffers straight back to their streams. Buffers are preallocated; nothing is allocated
//   per frame once the frame's images have their size.
// - Software trigger: next() fires TriggerSoftware on both cameras, one after the other, at `fps`.
// - Faults: a camera whose heartbeat fails (Aravis "control-lost") or that delivers nothing for
//   stall_timeout_ms is declared lost: next() returns Error at once (the pipeline raises no_camera in the
//   status message), the other camera keeps streaming (its frames are dropped as unmatched), and a
//   connector thread reopens the lost one with backoff (reconnect_min_ms doubling to reconnect_max_ms; a
//   USB3 Vision arrival reported by libusb hot-plug triggers an attempt at once). Once it is back and
//   configured, pairs resume; the daemon never exits because a camera went away.
// - A camera that starts sending images of another size than configured (reconfigured by another
//   program, binning, a new ROI) is delivered as it is: the pipeline compares each pair with the
//   calibration and raises CalibrationInvalid instead of measuring.
// - Releasing a camera that no longer answers blocks in Aravis for seconds (register timeouts), so lost
//   cameras are released on a reaper thread, never on the acquisition thread.
#include <array>
#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "camera/aravis_config.hpp"
#include "camera/camera_error.hpp"
#include "camera/stereo_pairing.hpp"
#include "core/frame_source.hpp"
#include "core/io_faults.hpp"
#include "core/stereo_calibration.hpp"

namespace rutd {

struct AravisSourceStats {
  PairingStats pairing;
  std::array<std::uint64_t, 2> incomplete{};  // buffers with missing packets, requeued (left, right)
  std::array<std::uint64_t, 2> losses{};      // times each camera was declared lost
  std::array<std::uint64_t, 2> reconnects{};  // times each camera came back
  std::uint64_t convert_failures = 0;         // pairs with a buffer shorter than its image
  std::uint64_t triggers = 0;                 // software trigger rounds fired
  std::uint64_t trigger_failures = 0;         // TriggerSoftware commands a camera refused
};

// One line for the log: pairs, skew p50/p99/max, drops per side and why, faults.
std::string describe(const AravisSourceStats& stats);

class AravisStereoSource final : public FrameSource {
 public:
  static constexpr int kMaxBuffers = 64;

  // Finds both cameras (by id, serial or address), configures and starts them. Throws CameraError when a
  // camera is found but refuses the configuration, or delivers images of another size than the
  // calibration's; the error's field() is the `source.aravis` key at fault. A camera that is not found
  // is not an error: the source starts without it (warning logged), next() reports Error and the
  // connector keeps looking for it. Throws std::invalid_argument ("field: why") for an unusable
  // configuration. The pairing and fault counters are logged every log_period (0: only at destruction).
  // faults: tests only (core/io_faults.hpp), IoPoint::CameraPop at each buffer taken from a stream: a
  // timeout (the buffer is lost unseen), a corrupt buffer (handled as incomplete) or a short one (fails
  // conversion). Not owned.
  AravisStereoSource(const AravisSourceConfig& config, StereoCalibration calibration,
                     std::chrono::milliseconds log_period = std::chrono::milliseconds(10000),
                     IoFaults* faults = nullptr);
  ~AravisStereoSource() override;
  AravisStereoSource(const AravisStereoSource&) = delete;
  AravisStereoSource& operator=(const AravisStereoSource&) = delete;

  // Waits at most ~100 ms: Ok with a pair (raw grey images, t_ns = the left camera's hardware timestamp,
  // shifted after a camera clock reset so that it never goes backwards; clock Hardware), Timeout when none came, Error
  // while a camera is lost (error_message() says which and why). Acquisition thread only.
  SourceStatus next(StereoFrame& frame) override;
  const StereoCalibration& calibration() const override;
  const std::string& error_message() const override;

  // Acquisition thread, or any thread once next() is no longer called.
  AravisSourceStats stats() const;
  // Warnings gathered while configuring (missing PTP, small kernel buffers, ...), for the start-up log.
  const std::vector<std::string>& warnings() const noexcept;

 private:
  // Aravis, GLib and libusb stay out of this header: the cameras, streams and threads live in Impl.
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rutd
