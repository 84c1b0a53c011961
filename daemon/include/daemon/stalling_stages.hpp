#pragma once
// For tests only (`rutd run --test-stall-match-after N`, hidden from --help): the real stages, except
// that once armed, the match stage stops returning after N more pairs, as a stage stuck in a driver or
// library call would. It lets a test check what a vehicle relies on: the watchdog pings stop and systemd
// kills and restarts rutd. The stalled call returns when the process is asked to stop (SIGTERM), so a
// `systemctl stop` still ends cleanly.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <thread>

#include "daemon/stop_signal.hpp"
#include "runtime/realtime_pipeline.hpp"

namespace rutd {

class StallingStages final : public PipelineStages {
 public:
  // `stages` must outlive this object.
  StallingStages(PipelineStages& stages, std::uint64_t stall_after) : stages_(stages), left_(stall_after) {}
  // Starts counting; call after RealtimePipeline::start(), so the slot priming does not count.
  void arm() { armed_.store(true); }
  bool rectify(FrameWork& work) override { return stages_.rectify(work); }
  void match(FrameWork& work) override {
    if (armed_.load() && left_-- == 0) {
      while (!stop_requested()) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    stages_.match(work);
  }
  void extract(FrameWork& work) override { stages_.extract(work); }

 private:
  PipelineStages& stages_;
  std::atomic<bool> armed_{false};
  std::uint64_t left_;  // match thread only
};

}  // namespace rutd
