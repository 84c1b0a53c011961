#pragma once
// Plots of a run, drawn off the measurement path: the measurement sink for `rutd run` (the
// configuration's `sinks.plots` section) and `rutd replay --plots`.
//
// publish() never blocks and never draws: it picks frames (every `every`-th, and always the first of
// each status change, at most one per min_interval_s), copies what the plots need into one of `queue`
// preallocated slots and hands it to the plot thread through a lock-free queue. No free slot: the frame
// is dropped and counted. Every measurement also goes into a lock-free series queue (dropped and counted
// when full) for the depth-over-time plot, written by finish() and every series_period_s. Write errors
// are counted and the last one kept; none is thrown.
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "core/measurement_sink.hpp"
#include "core/stereo_calibration.hpp"
#include "plots/plots.hpp"

namespace rutd {

struct PlotConfig {
  std::string dir;                // output folder (must exist)
  std::uint64_t every = 0;        // also plot every N-th frame (seq % N == 0); 0: status changes only
  double min_interval_s = 1.0;    // at most one plotted frame per this long (wall clock); 0: no limit
  std::size_t queue = 4;          // frames waiting for the plot thread, >= 1
  double series_period_s = 30.0;  // rewrite series.png this often while running; 0: only at finish()
  // true: publish() waits for a free slot instead of dropping (replay, where no camera waits).
  bool lossless = false;
};

struct PlotSinkStats {
  std::uint64_t frames_chosen = 0;   // frames picked for plotting
  std::uint64_t frames_plotted = 0;  // frames whose files were all written
  std::uint64_t files_written = 0;
  std::uint64_t dropped = 0;         // picked but no free slot
  std::uint64_t series_dropped = 0;  // measurements lost from the series (queue full)
  std::uint64_t errors = 0;          // files that could not be written
  std::string last_error;
};

// What the plots need of the rig beyond the frames, as plain data the caller fills (the daemon, from the
// measurer's geometry): the calibration and the rectification, to rectify the whole left image for the
// overlay. Where the rut lies comes with each frame (PublishedFrame::geometry).
struct PlotContext {
  StereoCalibration calibration;
  StereoRectification rectification;
};

class PlotSink final : public MeasurementSink {
 public:
  // Throws std::invalid_argument when dir is not a writable folder or queue is 0 (start-up).
  PlotSink(PlotConfig config, PlotContext context);
  ~PlotSink() override;  // finish()
  PlotSink(const PlotSink&) = delete;
  PlotSink& operator=(const PlotSink&) = delete;

  // Frames without their detail (refused before they were measured) go into the series only.
  void publish(const PublishedFrame& frame) override;
  void publish_status(const SensorHealth&, std::int64_t) override {}

  // Plots what is queued, writes series.png, stops the thread. Idempotent. Returns the final figures.
  PlotSinkStats finish();
  PlotSinkStats stats() const;

 private:
  struct Job;
  void worker();
  void plot(Job& job);
  void write_series();
  void note(const PlotResult& r);

  PlotConfig config_;
  PlotContext context_;
  struct Queues;
  std::unique_ptr<Queues> queues_;
  std::vector<std::unique_ptr<Job>> jobs_;
  cv::Mat map_x_, map_y_;  // raw -> rectified left, whole image
  // Producer (publish thread) state.
  bool have_status_ = false;
  RutStatus last_status_ = RutStatus::NoMeasurement;
  std::int64_t last_plot_ns_ = 0;
  std::int64_t first_t_ns_ = -1;
  // Plot thread state.
  std::vector<SeriesSample> series_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
  std::atomic<std::uint64_t> chosen_{0}, plotted_{0}, written_{0}, dropped_{0}, series_dropped_{0}, errors_{0};
  mutable std::mutex error_mutex_;  // last_error_ only (plot thread writes, anyone reads)
  std::string last_error_;
  bool finished_ = false;
};

}  // namespace rutd
