#pragma once
// Positions from gpsd, the GNSS daemon of Linux vehicle PCs, read through libgps on a thread of its own
// (`rutd-gps`): gps_open, gps_stream(WATCH_ENABLE | WATCH_JSON), then gps_waiting (100 ms at most) and
// gps_read per report. Each TPV report becomes a GeoFix stamped with its receive time on CLOCK_MONOTONIC
// (the frames' clock) in a FixHistory; the publish thread asks position_at() for each frame. Nothing here
// ever waits on the pipeline or makes it wait: the lock guards a copy of a few fixes.
//
// Faults, counted in GpsStats and logged once per change, never thrown after start: gpsd absent (connect
// refused: retried after reconnect_min_ms, doubling to reconnect_max_ms), gpsd going away mid-run (the
// same), a report libgps cannot parse (counted, skipped, the connection kept), a receiver without a fix
// (its TPVs have mode 1: frames get Mode::NoFix), the fix's own clock jumping against the receive time
// (counted; joining uses the receive time, which does not jump), and silence (fixes age out: stale).
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "gps/fix_history.hpp"
#include "gps/gps_config.hpp"
#include "gps/gps_jsonl.hpp"
#include "gps/gpsd_report.hpp"
#include "gps/position_source.hpp"

namespace rutd {

struct GpsStats {
  bool connected = false;
  std::uint64_t connects = 0;          // connections made to gpsd
  std::uint64_t connect_failures = 0;  // attempts that found no gpsd
  std::uint64_t disconnects = 0;       // connections lost mid-run
  std::uint64_t reports = 0;           // well-formed reports of any class
  std::uint64_t fixes = 0;             // TPVs with a 2D or 3D fix
  std::uint64_t no_fix_reports = 0;    // TPVs without one
  std::uint64_t malformed = 0;         // lines libgps could not parse
  std::uint64_t time_jumps = 0;        // fixes whose own time jumped against the receive time
  std::uint64_t recorded = 0;          // lines written to gps.jsonl
  std::uint64_t record_errors = 0;     // lines that could not be
};

class GpsdSource final : public PositionSource {
 public:
  // Starts the thread; connecting happens there (gpsd may start later than rutd). `record`: where to
  // write every report (gps.jsonl), or null; not owned, used by the gps thread only, must outlive this.
  explicit GpsdSource(GpsConfig config, GpsJsonlWriter* record = nullptr);
  ~GpsdSource() override;  // stop()
  GpsdSource(const GpsdSource&) = delete;
  GpsdSource& operator=(const GpsdSource&) = delete;

  // Thread-safe. See PositionSource; stale beyond config.max_fix_age_ms.
  GeoFix position_at(std::int64_t t_ns) const override;
  GpsStats stats() const;  // thread-safe
  // Stops and joins the thread (within about 100 ms plus a connect in progress). Idempotent.
  void stop();

 private:
  struct Connection;
  void run(std::stop_token stop);
  void read_reports(Connection& connection, std::stop_token stop);
  // Counts, records and keeps one report (gps thread).
  void on_report(const char* line, std::int64_t rx_t_ns, GpsdReportKind kind, const GeoFix& fix);

  GpsConfig config_;
  GpsJsonlWriter* record_;
  mutable std::mutex mutex_;  // guards history_ and stats_
  FixHistory history_;
  GpsStats stats_;
  // Last fix with a time, for the time-jump check (gps thread only).
  std::int64_t last_utc_ns_ = 0, last_rx_ns_ = 0;
  bool record_failing_ = false;
  bool had_fix_ = false;
  std::jthread thread_;
};

}  // namespace rutd
