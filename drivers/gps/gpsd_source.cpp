#include "gps/gpsd_source.hpp"

#include <pthread.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdlib>

#include <spdlog/spdlog.h>

#include "core/monotonic_clock.hpp"
#include "gpsd_fix.hpp"

namespace rutd {

// libgps's connection state (about 25 kB), allocated once for the thread's life.
struct GpsdSource::Connection {
  gps_data_t data{};
  bool open = false;
  char line[8192] = {};  // one report as gpsd sent it (gpsd's own limit is GPS_JSON_RESPONSE_MAX, 4096)
};

GpsdSource::GpsdSource(GpsConfig config, GpsJsonlWriter* record)
    : config_(std::move(config)), record_(record), thread_([this](std::stop_token stop) { run(stop); }) {}

GpsdSource::~GpsdSource() { stop(); }

void GpsdSource::stop() {
  if (!thread_.joinable()) return;
  thread_.request_stop();
  thread_.join();
}

GeoFix GpsdSource::position_at(std::int64_t t_ns) const {
  const auto max_age = static_cast<std::int64_t>(config_.max_fix_age_ms * 1e6);
  std::lock_guard lock(mutex_);
  return history_.at(t_ns, max_age);
}

GpsStats GpsdSource::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

void GpsdSource::run(std::stop_token stop) {
  pthread_setname_np(pthread_self(), "rutd-gps");
  auto connection = std::make_unique<Connection>();
  const auto min_wait = std::chrono::milliseconds(static_cast<long>(config_.reconnect_min_ms));
  const auto max_wait = std::chrono::milliseconds(static_cast<long>(config_.reconnect_max_ms));
  auto wait = min_wait;
  std::mutex sleep_mutex;
  std::condition_variable_any sleeper;
  bool reported_absent = false;
  while (!stop.stop_requested()) {
    if (gps_open(config_.host.c_str(), config_.port.c_str(), &connection->data) != 0) {
      {
        std::lock_guard lock(mutex_);
        ++stats_.connect_failures;
      }
      if (!reported_absent)
        spdlog::warn("gps: no gpsd at {}:{} ({}); measuring without positions, retrying up to every {} ms",
                     config_.host, config_.port, gps_errstr(errno), config_.reconnect_max_ms);
      reported_absent = true;
      std::unique_lock lock(sleep_mutex);
      sleeper.wait_for(lock, stop, wait, [] { return false; });
      wait = std::min(wait * 2, max_wait);
      continue;
    }
    connection->open = true;
    gps_stream(&connection->data, WATCH_ENABLE | WATCH_JSON, nullptr);
    {
      std::lock_guard lock(mutex_);
      ++stats_.connects;
      stats_.connected = true;
    }
    spdlog::info("gps: connected to gpsd at {}:{}", config_.host, config_.port);
    reported_absent = false;
    read_reports(*connection, stop);
    gps_stream(&connection->data, WATCH_DISABLE, nullptr);
    gps_close(&connection->data);
    connection->open = false;
    {
      std::lock_guard lock(mutex_);
      stats_.connected = false;
    }
    if (stop.stop_requested()) break;
    {
      std::lock_guard lock(mutex_);
      ++stats_.disconnects;
    }
    spdlog::warn("gps: gpsd at {}:{} went away; measuring without positions, reconnecting", config_.host, config_.port);
    wait = min_wait;
    std::unique_lock lock(sleep_mutex);
    sleeper.wait_for(lock, stop, wait, [] { return false; });
  }
}

// Reads until the connection fails or a stop is asked. gps_read hands back each line gpsd sent; it returns
// -1 only for a closed or broken connection (libgps 3.22 reports a line it cannot parse as read, leaving its
// state half-updated), so each line is parsed again on its own (GpsdReportParser, the same libgps parser,
// checked) to tell a malformed report from a good one, live as in replay.
void GpsdSource::read_reports(Connection& c, std::stop_token stop) {
  GpsdReportParser parser;
  while (!stop.stop_requested()) {
    if (!gps_waiting(&c.data, 100000)) continue;  // nothing within 100 ms (a dead socket reads as ready)
    c.line[0] = '\0';
    const int n = gps_read(&c.data, c.line, static_cast<int>(sizeof c.line));
    const std::int64_t rx = monotonic_now_ns();
    if (n < 0) return;                          // closed or broken
    if (n == 0 || c.line[0] == '\0') continue;  // part of a line so far
    GeoFix fix;
    const GpsdReportKind kind = parser.parse(c.line, rx, fix);
    on_report(c.line, rx, kind, fix);
  }
}

void GpsdSource::on_report(const char* line, std::int64_t rx, GpsdReportKind kind, const GeoFix& fix) {
  bool jumped = false, record_failed = false, record_recovered = false;
  std::string record_error;
  if (kind == GpsdReportKind::Fix && fix.utc_ns != 0) {
    // The fix's own clock against the receive time: a receiver restarting, a leap, a bad almanac.
    if (last_utc_ns_ != 0) {
      const double skew_s = static_cast<double>((fix.utc_ns - last_utc_ns_) - (rx - last_rx_ns_)) * 1e-9;
      jumped = std::abs(skew_s) > config_.time_jump_s;
    }
    last_utc_ns_ = fix.utc_ns;
    last_rx_ns_ = rx;
  }
  if (record_ != nullptr) {
    if (record_->append(rx, line)) {
      record_recovered = record_failing_;
      record_failing_ = false;
    } else {
      record_failed = !record_failing_;
      record_failing_ = true;
      record_error = record_->error();
    }
  }
  {
    std::lock_guard lock(mutex_);
    switch (kind) {
      case GpsdReportKind::Malformed: ++stats_.malformed; break;
      case GpsdReportKind::Other: ++stats_.reports; break;
      case GpsdReportKind::Fix:
        ++stats_.reports;
        ++(fix.valid() ? stats_.fixes : stats_.no_fix_reports);
        history_.add(fix);
        break;
    }
    if (jumped) ++stats_.time_jumps;
    if (record_ != nullptr) ++(record_failing_ ? stats_.record_errors : stats_.recorded);
  }
  // Logged outside the lock, once per change.
  if (kind == GpsdReportKind::Malformed) spdlog::warn("gps: a report libgps cannot parse, skipped: {:.200}", line);
  if (jumped) spdlog::warn("gps: the receiver's time jumped (positions stay joined by receive time)");
  if (kind == GpsdReportKind::Fix && fix.valid() != had_fix_) {
    had_fix_ = fix.valid();
    if (had_fix_) spdlog::info("gps: fix ({})", fix.mode == GeoFix::Mode::Fix3d ? "3D" : "2D");
    else spdlog::warn("gps: no fix; measurements go on without positions");
  }
  if (record_failed) spdlog::error("gps: {}; positions are not recorded until it can be written again", record_error);
  if (record_recovered) spdlog::info("gps: recording positions again to {}", record_->path());
}

}  // namespace rutd
