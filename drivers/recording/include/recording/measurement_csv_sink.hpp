#pragma once
// The measurement sink for the measurement CSV (the adapter between the sink interface,
// core/measurement_sink.hpp, and recording/measurement_csv.hpp): `rutd run`'s sinks.csv and `rutd
// replay --out`. Called from the publishing thread only.
#include <cstdint>
#include <string>

#include "core/io_faults.hpp"
#include "core/measurement_sink.hpp"

namespace rutd {

struct MeasurementCsvStats {
  std::uint64_t rows_written = 0;
  std::uint64_t rows_lost = 0;  // rows whose write failed (disk full, I/O error, closed pipe)
  bool stopped = false;         // a failure that cannot be undone (a partial row on a pipe): no more rows
  std::string last_error;       // "PATH: cannot write the row of seq N: REASON"; empty when none
};

// The measurement CSV (DESIGN.md, Formats), one write(2) per row, so a crash or a `tail -f` sees every
// row written so far. A row whose write fails is lost, never the rows before it: on a regular file a
// partly written row is cut off again (ftruncate), so the file stays a valid CSV and the next rows are
// tried as usual (the CSV resumes when the disk has room again; the gap shows in seq). On a pipe or
// terminal a partial row cannot be taken back, so writing stops there. The first failure is logged once
// (and the first after each resumption); every status frame after a lost row raises RecordingError
// (failed_since_last_check).
class MeasurementCsvSink final : public MeasurementSink {
 public:
  // Creates or truncates `path` ("-": standard output, not closed) and writes the header. Throws
  // InputError(path, key, ...) when it cannot. `faults`: tests only (core/io_faults.hpp,
  // IoPoint::MeasurementWrite, asked before every write()); not owned.
  // positions: also the position columns (recording/measurement_csv.hpp) from PublishedFrame::position.
  MeasurementCsvSink(const std::string& path, const std::string& key, IoFaults* faults = nullptr,
                     bool positions = false);
  ~MeasurementCsvSink() override;
  MeasurementCsvSink(const MeasurementCsvSink&) = delete;
  MeasurementCsvSink& operator=(const MeasurementCsvSink&) = delete;

  void publish(const PublishedFrame& frame) override;
  void publish_status(const SensorHealth&, std::int64_t) override {}

  // True when a row was lost since the previous call (publish thread only: CanSink asks it per status).
  bool failed_since_last_check();
  // Publish thread, or after the pipeline stopped.
  const MeasurementCsvStats& stats() const { return stats_; }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  int fd_ = -1;
  bool owns_fd_ = false;
  bool regular_file_ = false;
  bool positions_ = false;
  IoFaults* faults_;
  std::uint64_t size_ = 0;  // bytes of complete rows (and the header) in a regular file
  std::uint64_t lost_at_last_check_ = 0;
  bool failing_ = false;  // the last row failed (log the next failure only after a success)
  std::string line_;
  MeasurementCsvStats stats_;
};

}  // namespace rutd
