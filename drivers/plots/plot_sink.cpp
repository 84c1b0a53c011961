#include "plots/plot_sink.hpp"

#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <stdexcept>

#include <boost/lockfree/spsc_queue.hpp>
#include <fmt/format.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "core/monotonic_clock.hpp"
#include "core/slot_queue.hpp"

namespace rutd {

// One picked frame: copies of what the plots draw. Buffers are reused slot to slot.
struct PlotSink::Job {
  std::uint64_t seq = 0;
  double t_s = 0;
  cv::Mat left_raw, disparity;
  int strip_row0 = 0;  // rectified row of the disparity's first row
  CrossSection section;
  RutGeometry geometry;
  RutMeasurement measurement;
};

// The slot loop of the jobs (each queue holds every job, so a push never fails), and the measurements
// for the series by value (bounded: full drops).
struct PlotSink::Queues {
  explicit Queues(std::size_t n) : ready(n), free(n), series(8192) {}
  SlotQueue<Job> ready;  // publish thread -> plot thread
  SlotQueue<Job> free;   // plot thread -> publish thread
  boost::lockfree::spsc_queue<SeriesSample> series;
};

PlotSink::PlotSink(PlotConfig config, PlotContext context) : config_(std::move(config)), context_(std::move(context)) {
  if (config_.queue == 0) throw std::invalid_argument("plot queue: must be at least 1");
  std::error_code ec;
  if (!std::filesystem::is_directory(config_.dir, ec)) throw std::invalid_argument(config_.dir + ": not a folder");
  if (::access(config_.dir.c_str(), W_OK) != 0) throw std::invalid_argument(config_.dir + ": not writable");
  queues_ = std::make_unique<Queues>(config_.queue);
  for (std::size_t i = 0; i < config_.queue; ++i) {
    jobs_.push_back(std::make_unique<Job>());
    queues_->free.push(jobs_.back().get());
  }
  const StereoRectification& r = context_.rectification;
  cv::initUndistortRectifyMap(context_.calibration.M1, context_.calibration.D1, r.R1, r.P1, r.rectified_size, CV_32FC1,
                              map_x_, map_y_);
  thread_ = std::thread([this] { worker(); });
}

PlotSink::~PlotSink() { finish(); }

void PlotSink::publish(const PublishedFrame& f) {
  const RutMeasurement& m = f.measurement;
  if (first_t_ns_ < 0) first_t_ns_ = f.t_ns;
  const double t_s = static_cast<double>(f.t_ns - first_t_ns_) * 1e-9;
  if (!queues_->series.push(SeriesSample{f.seq, t_s, m.status, m.depth_mm, m.width_mm, m.quality}))
    series_dropped_.fetch_add(1, std::memory_order_relaxed);

  const bool changed = !have_status_ || m.status != last_status_;
  have_status_ = true;
  last_status_ = m.status;
  const bool periodic = config_.every > 0 && f.seq % config_.every == 0;
  if (!changed && !periodic) return;
  if (f.section == nullptr || f.geometry == nullptr || f.disparity == nullptr) return;  // nothing to draw
  const std::int64_t now = monotonic_now_ns();
  if (config_.min_interval_s > 0 && last_plot_ns_ != 0 &&
      now - last_plot_ns_ < static_cast<std::int64_t>(config_.min_interval_s * 1e9))
    return;
  chosen_.fetch_add(1, std::memory_order_relaxed);
  Job* job = nullptr;
  for (;;) {
    const std::uint64_t since = queues_->free.mark();
    if ((job = queues_->free.pop()) != nullptr) break;
    if (!config_.lossless || stop_.load(std::memory_order_acquire)) {
      dropped_.fetch_add(1, std::memory_order_relaxed);
      return;
    }
    queues_->free.wait(since, std::chrono::milliseconds(100));
  }
  last_plot_ns_ = now;
  job->seq = f.seq;
  job->t_s = t_s;
  if (f.left_raw != nullptr) f.left_raw->copyTo(job->left_raw);
  else job->left_raw.release();
  f.disparity->copyTo(job->disparity);
  job->strip_row0 = f.strip_row0;
  job->section.x0_mm = f.section->x0_mm;
  job->section.dx_mm = f.section->dx_mm;
  job->section.z_mm = f.section->z_mm;
  job->section.count = f.section->count;
  job->geometry = *f.geometry;
  job->measurement = m;
  queues_->ready.push(job);  // cannot fail: at most `queue` jobs exist; wakes the plot thread
}

void PlotSink::note(const PlotResult& r) {
  if (r.ok) {
    written_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  errors_.fetch_add(1, std::memory_order_relaxed);
  const std::lock_guard lock(error_mutex_);
  last_error_ = r.error;
}

void PlotSink::plot(Job& job) {
  const RutMeasurement& m = job.measurement;
  const std::string stem = fmt::format("{}/frame_{:06d}_", config_.dir, job.seq);
  const RutGeometry& geo = job.geometry;
  const std::string title = fmt::format("Cross-section, frame {} (t = {:.2f} s)", job.seq, job.t_s);
  bool all = true;
  const auto keep = [&](const PlotResult& r) {
    note(r);
    all = all && r.ok;
  };
  keep(plot_cross_section(stem + "section.png", job.section, m, geo, title));
  keep(plot_disparity(stem + "disparity.png", job.disparity, job.strip_row0,
                      fmt::format("Refined disparity of the measured strip, frame {}", job.seq)));
  if (!job.left_raw.empty()) {
    cv::Mat rectified, grey;
    if (job.left_raw.depth() == CV_16U) {
      double hi = 0;
      cv::minMaxLoc(job.left_raw, nullptr, &hi);
      job.left_raw.convertTo(grey, CV_8U, hi > 255 ? 255.0 / hi : 1.0);
    } else {
      grey = job.left_raw;
    }
    if (grey.size() == context_.calibration.image_size) {
      cv::remap(grey, rectified, map_x_, map_y_, cv::INTER_LINEAR);
      ImageMarks marks;
      marks.strip_row0 = job.strip_row0;
      marks.strip_rows = job.disparity.rows;
      // Columns of points on the strip's middle row: u = fx X / Z + cx on the rectified image.
      if (geo.has_rut) {
        const double fx = context_.rectification.P1(0, 0), cx = context_.rectification.P1(0, 2);
        const auto col = [&](double x) {
          const double z = geo.line_m * x + geo.line_c;
          return z > 0 ? fx * x / z + cx : -1.0;
        };
        marks.left_col = col(geo.left_x_mm);
        marks.right_col = col(geo.right_x_mm);
        marks.deepest_col = col(geo.deepest_x_mm);
      }
      marks.caption = fmt::format("frame {}  {}  depth {:.2f} mm  width {:.1f} mm", job.seq, to_string(m.status),
                                  m.depth_mm, m.width_mm);
      keep(write_strip_overlay(stem + "left.png", rectified, marks));
    }
  }
  if (all) plotted_.fetch_add(1, std::memory_order_relaxed);
}

void PlotSink::write_series() {
  SeriesSample s;
  while (queues_->series.pop(s)) series_.push_back(s);
  if (series_.empty()) return;
  note(plot_series(config_.dir + "/series.png", series_, fmt::format("Rut over the run: {} frames", series_.size())));
}

void PlotSink::worker() {
  auto next_series = std::chrono::steady_clock::now() + std::chrono::duration<double>(config_.series_period_s);
  for (;;) {
    // Read before the queue: a job pushed after mark() makes wait() return at once, and finish() sets
    // stop_ after the last publish(), so a stop seen here leaves no job unseen by the pops below.
    const std::uint64_t since = queues_->ready.mark();
    const bool stopping = stop_.load(std::memory_order_acquire);
    bool any = false;
    while (Job* job = queues_->ready.pop()) {
      any = true;
      plot(*job);
      queues_->free.push(job);
    }
    SeriesSample s;
    while (queues_->series.pop(s)) series_.push_back(s);
    if (stopping) break;
    if (config_.series_period_s > 0 && std::chrono::steady_clock::now() >= next_series) {
      write_series();
      next_series = std::chrono::steady_clock::now() + std::chrono::duration<double>(config_.series_period_s);
    }
    // Measurements arrive without a wake-up (they are many and need no hurry): the series is read at
    // least every 100 ms.
    if (!any) queues_->ready.wait(since, std::chrono::milliseconds(100));
  }
  write_series();
}

PlotSinkStats PlotSink::finish() {
  if (!finished_) {
    finished_ = true;
    stop_.store(true, std::memory_order_release);
    queues_->ready.wake();
    if (thread_.joinable()) thread_.join();
  }
  return stats();
}

PlotSinkStats PlotSink::stats() const {
  PlotSinkStats s;
  s.frames_chosen = chosen_.load(std::memory_order_relaxed);
  s.frames_plotted = plotted_.load(std::memory_order_relaxed);
  s.files_written = written_.load(std::memory_order_relaxed);
  s.dropped = dropped_.load(std::memory_order_relaxed);
  s.series_dropped = series_dropped_.load(std::memory_order_relaxed);
  s.errors = errors_.load(std::memory_order_relaxed);
  const std::lock_guard lock(error_mutex_);
  s.last_error = last_error_;
  return s;
}

}  // namespace rutd
