#pragma once
// One gpsd JSON report (one line of gpsd's protocol: TPV, SKY, VERSION, ...) read by libgps's own parser,
// for the recorded reports (gps.jsonl) and any report text at hand. The live source uses the same
// conversion on what gps_read() parsed.
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "core/track.hpp"

namespace rutd {

enum class GpsdReportKind : std::uint8_t {
  Fix,        // a TPV report: `fix` holds its mode and whatever it carried
  Other,      // a well-formed report of another class (VERSION, DEVICES, WATCH, SKY, ...)
  Malformed,  // libgps could not parse it, or it is not a JSON object
};

// Reads reports with libgps (gps_unpack). Holds libgps's report state (about 25 kB), allocated once; not
// thread-safe: one parser per thread.
class GpsdReportParser {
 public:
  GpsdReportParser();
  ~GpsdReportParser();
  GpsdReportParser(const GpsdReportParser&) = delete;
  GpsdReportParser& operator=(const GpsdReportParser&) = delete;

  // Parses `json` (one report, no newline needed). For a TPV, `fix` is set with t_ns = rx_t_ns (the
  // receive time on the frames' clock); fields the report lacks are NaN (utc_ns 0).
  GpsdReportKind parse(std::string_view json, std::int64_t rx_t_ns, GeoFix& fix);

 private:
  struct State;
  std::unique_ptr<State> state_;
  std::string buffer_;  // libgps parses in place
};

}  // namespace rutd
