#pragma once
// For tests only (`rutd run --test-stall-match-after N`, hidden from --help): the real stages, except
// that the match stage stops returning after N pairs, as a stage stuck in a driver or
// library call would. It lets a test check what a vehicle relies on: the watchdog pings stop and systemd
// kills and restarts rutd. The stalled call returns when the process is asked to stop (SIGTERM), so a
// `systemctl stop` still ends cleanly.
#include <chrono>
#include <cstdint>
#include <thread>

#include "daemon/stop_signal.hpp"
#include "runtime/realtime_pipeline.hpp"

namespace rutd {

class StallingStages final : public PipelineStages {
 public:
  // `stages` must outlive this object. Counts only the pairs the pipeline's own threads match: the
  // slots' priming runs on the thread that calls RealtimePipeline::start() (the one constructing this)
  // and does not count. Arming after start() instead let a pair through before the stall on a loaded
  // machine, and the unit became ready, then was killed by the watchdog, where it should have waited.
  StallingStages(PipelineStages& stages, std::uint64_t stall_after)
      : stages_(stages), owner_(std::this_thread::get_id()), left_(stall_after) {}
  bool rectify(FrameWork& work) override { return stages_.rectify(work); }
  void match(FrameWork& work) override {
    if (std::this_thread::get_id() != owner_ && left_-- == 0) {
      while (!stop_requested()) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    stages_.match(work);
  }
  void extract(FrameWork& work) override { stages_.extract(work); }

 private:
  PipelineStages& stages_;
  const std::thread::id owner_;
  std::uint64_t left_;  // the match thread's only
};

}  // namespace rutd
