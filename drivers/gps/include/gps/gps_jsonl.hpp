#pragma once
// gps.jsonl, a recording's positions (DESIGN.md, Formats): gpsd's own JSON reports, one per line, each
// wrapped with the time it was received on the frames' clock:
//
//   {"t_ns":1234567890123,"report":{"class":"TPV","device":"/dev/ttyACM0","mode":3,"lat":-25.7545,...}}
//
// "report" is the line gpsd sent, byte for byte, so any gpsd client can read it again; `t_ns` is
// CLOCK_MONOTONIC like frames.csv's t_ns, which is what joins positions to pairs. Written by the gpsd
// source's own thread, one write(2) per line, so a crash leaves at most the last line cut off (the reader
// skips it). Reports that are not TPVs are kept too (VERSION, DEVICES, SKY): they say what the receiver was.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "core/track.hpp"

namespace rutd {

inline constexpr const char* kGpsJsonlFile = "gps.jsonl";

// Appends lines to a new gps.jsonl. Not thread-safe: one writer thread.
class GpsJsonlWriter {
 public:
  // Creates `path`; throws InputError(path, "file", ...) when it cannot or when it exists already (a
  // recording is never overwritten).
  explicit GpsJsonlWriter(const std::string& path);
  ~GpsJsonlWriter();
  GpsJsonlWriter(const GpsJsonlWriter&) = delete;
  GpsJsonlWriter& operator=(const GpsJsonlWriter&) = delete;

  // One line; false (and error()) when the write failed: the line is lost, later lines are tried again.
  bool append(std::int64_t t_ns, std::string_view report);
  const std::string& error() const { return error_; }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  int fd_ = -1;
  std::string line_;
  std::string error_;
};

struct GpsJsonlLine {
  std::int64_t t_ns = 0;
  std::string report;  // gpsd's line
};

struct GpsJsonl {
  std::vector<GpsJsonlLine> lines;
  std::uint64_t malformed = 0;  // lines that are not `{"t_ns":N,"report":{...}}` (skipped)
  bool truncated_tail = false;  // the last line had no newline and was skipped
};

// Reads a whole gps.jsonl (replay and map; not for the per-frame path). Throws InputError when it cannot
// be opened; malformed lines are counted and skipped, so one bad line does not cost the rest.
GpsJsonl read_gps_jsonl(const std::string& path);

// The fixes of a gps.jsonl in receive order, read with libgps (GpsdReportParser): one per TPV report.
struct RecordedFixes {
  std::vector<GeoFix> fixes;
  std::uint64_t reports = 0, malformed = 0;  // malformed: lines or reports that did not parse
};
RecordedFixes read_recorded_fixes(const std::string& path);

}  // namespace rutd
