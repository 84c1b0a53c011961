#include "daemon/run_sources.hpp"

#include <algorithm>
#include <chrono>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "camera/aravis_stereo_source.hpp"
#include "camera/camera_error.hpp"
#include "core/input_error.hpp"
#include "recording/calibration_file.hpp"
#include "recording/recording.hpp"
#include "synthetic/cycling_source.hpp"
#include "synthetic/synthetic_source.hpp"

namespace rutd {
namespace {

// A recording played back as if live: at its own timestamps (paced) and, if asked, over and over. Sequence
// numbers and timestamps keep increasing across loops so that neither the pipeline nor a recording of
// the replay sees them go backwards.
class PacedReplaySource final : public FrameSource {
 public:
  PacedReplaySource(std::string dir, bool paced, bool loop, IoFaults* faults)
      : dir_(std::move(dir)),
        paced_(paced),
        loop_(loop),
        faults_(faults),
        reader_(std::make_unique<ReplaySource>(dir_, faults_)) {}

  SourceStatus next(StereoFrame& frame) override {
    SourceStatus s = reader_->next(frame);
    if (s == SourceStatus::EndOfStream && loop_ && reader_->pairs_read() > 0) {
      seq_offset_ = last_seq_ + 1;
      // The next loop continues the time line one frame step later (recordings need it increasing).
      t_offset_ns_ = last_t_ns_ + std::max<std::int64_t>(last_t_ns_ - previous_t_ns_, 1);
      first_of_loop_ = true;
      reader_ = std::make_unique<ReplaySource>(dir_, faults_);
      started_ = false;
      s = reader_->next(frame);
    }
    if (s != SourceStatus::Ok) return s;
    if (paced_) pace(frame.t_ns);
    if (first_of_loop_) {
      loop_base_ns_ = frame.t_ns;  // this loop's first pair lands just after the previous loop's last
      first_of_loop_ = false;
    }
    frame.seq += seq_offset_;
    frame.t_ns = frame.t_ns - loop_base_ns_ + t_offset_ns_;
    last_seq_ = frame.seq;
    previous_t_ns_ = last_t_ns_;
    last_t_ns_ = frame.t_ns;
    return s;
  }
  const StereoCalibration& calibration() const override { return reader_->calibration(); }
  const std::string& error_message() const override { return reader_->error_message(); }

 private:
  void pace(std::int64_t t_ns) {
    const auto now = std::chrono::steady_clock::now();
    if (!started_) {
      started_ = true;
      first_t_ns_ = t_ns;
      start_ = now;
      return;
    }
    std::this_thread::sleep_until(start_ + std::chrono::nanoseconds(t_ns - first_t_ns_));
  }

  std::string dir_;
  bool paced_, loop_;
  IoFaults* faults_;
  std::unique_ptr<ReplaySource> reader_;
  bool started_ = false;
  std::int64_t first_t_ns_ = 0;
  std::chrono::steady_clock::time_point start_;
  std::uint64_t seq_offset_ = 0, last_seq_ = 0;
  // Timestamps of later loops: shifted so that they keep increasing (0 for the first loop).
  bool first_of_loop_ = false;
  std::int64_t loop_base_ns_ = 0, t_offset_ns_ = 0, last_t_ns_ = 0, previous_t_ns_ = 0;
};

// Cameras: a configuration the cameras refuse is a start-up error naming the source.aravis key at fault.
std::unique_ptr<FrameSource> make_camera_source(const RutdConfig& c, IoFaults* faults) {
  StereoCalibration calibration = load_calibration(c.calibration);  // throws InputError naming the file
  try {
    auto source = std::make_unique<AravisStereoSource>(
        c.aravis, std::move(calibration), std::chrono::milliseconds(static_cast<long>(c.logging.stats_period_s * 1000)),
        faults);
    for (const auto& w : source->warnings()) spdlog::warn("{}", w);
    return source;
  } catch (const CameraError& e) {
    throw InputError(c.file, e.field().empty() ? "source.aravis" : "source.aravis." + e.field(), e.what());
  } catch (const std::invalid_argument& e) {
    throw InputError(c.file, "source.aravis", e.what());
  }
}

// The synthetic rig: rendered live, or a short cycle rendered once and played at the camera rate.
// Impossible scene parameters are a start-up error naming source.synthetic.
std::unique_ptr<FrameSource> make_synthetic_source(const RutdConfig& c, IoFaults* faults) {
  try {
    if (c.synthetic_cycle_frames <= 0)
      return std::make_unique<SyntheticSource>(c.synthetic, SyntheticSourceConfig{}, faults);
    const SyntheticRenderer renderer(c.synthetic);
    const auto period = std::chrono::nanoseconds(static_cast<std::int64_t>(1e9 / c.synthetic.fps));
    return std::make_unique<CyclingSource>(renderer.calibration(),
                                           renderer.render_pairs(static_cast<std::size_t>(c.synthetic_cycle_frames)),
                                           period, faults);
  } catch (const std::invalid_argument& e) {
    throw InputError(c.file, "source.synthetic", e.what());
  }
}

}  // namespace

std::unique_ptr<FrameSource> make_source(const RutdConfig& c, IoFaults* faults) {
  switch (c.source) {
    case SourceKind::Synthetic: return make_synthetic_source(c, faults);
    case SourceKind::Replay:
      return std::make_unique<PacedReplaySource>(c.replay.dir, c.replay.paced, c.replay.loop, faults);
    case SourceKind::Aravis: return make_camera_source(c, faults);
  }
  throw InputError(c.file, "source.type", "unknown source");
}

std::string describe_source(const RutdConfig& c) {
  switch (c.source) {
    case SourceKind::Synthetic:
      return fmt::format("synthetic {}x{} at {} fps{}", c.synthetic.rig.image_size.width,
                         c.synthetic.rig.image_size.height, c.synthetic.fps,
                         c.synthetic_cycle_frames > 0
                             ? fmt::format(" ({} pairs rendered once, cycled)", c.synthetic_cycle_frames)
                             : std::string());
    case SourceKind::Replay:
      return "recording " + c.replay.dir + (c.replay.paced ? " (paced)" : "") + (c.replay.loop ? " (loop)" : "");
    case SourceKind::Aravis:
      return fmt::format("cameras {} / {} at {} fps ({})", c.aravis.left, c.aravis.right, c.aravis.fps,
                         c.aravis.sync == CameraSync::FreeRun ? "free run"
                         : c.aravis.sync == CameraSync::SoftwareTrigger
                             ? "software trigger"
                             : "hardware trigger on " + c.aravis.trigger_line);
  }
  return "?";
}

}  // namespace rutd
