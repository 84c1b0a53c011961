#pragma once
// Measurements as text (DESIGN.md, Formats): the replay output and the CSV sink. One header line, then
// one line per stereo pair:
//
//   seq,t_ns,status,rut_depth_mm,rut_width_mm,left_pile_mm,right_pile_mm,area_mm2,ground_slope_deg,
//   center_x_mm,quality,valid_fraction            (one line, no spaces)
//
// status is the to_string name (OK, NO_RUT, ...). Lengths in mm and area in mm^2 with 3 decimals, the
// slope in degrees with 3, quality and valid_fraction with 4. A field that is not valid for the status
// (measurement_field_valid) or not finite is left empty, so a consumer never mistakes "not measured"
// for a zero. Numbers are written and read locale-independently ('.' decimal point).
//
// With positions (sinks.csv_positions, `rutd replay --positions`) each line goes on with the position of
// the pair (core/track.hpp GeoFix, joined at capture time):
//
//   ...,valid_fraction,fix_mode,latitude_deg,longitude_deg,altitude_m,horizontal_error_m,heading_deg
//
// fix_mode is NONE (no positioning source), NO_FIX (none in force: gpsd absent, no fix, or stale), 2D or 3D; the other
// fields are empty unless there is a fix (and the receiver gave them): degrees WGS84 with 9 decimals (gpsd
// reports 9; 1e-9 degree is 0.1 mm), altitude and error in metres with 3, heading in degrees with 2.
#include <cstdint>
#include <iosfwd>
#include <string>
#include <string_view>
#include <vector>

#include "core/rut_measurement.hpp"
#include "core/track.hpp"

namespace rutd {

inline constexpr std::string_view kMeasurementCsvHeader =
    "seq,t_ns,status,rut_depth_mm,rut_width_mm,left_pile_mm,right_pile_mm,area_mm2,ground_slope_deg,"
    "center_x_mm,quality,valid_fraction";

inline constexpr std::string_view kMeasurementCsvPositionColumns =
    "fix_mode,latitude_deg,longitude_deg,altitude_m,horizontal_error_m,heading_deg";

// The value columns after seq,t_ns,status, in file order.
enum class MeasurementField : std::uint8_t {
  DepthMm,
  WidthMm,
  LeftPileMm,
  RightPileMm,
  AreaMm2,
  GroundSlopeDeg,
  CenterXMm,
  Quality,
  ValidFraction,
};
inline constexpr int kMeasurementFieldCount = 9;

// Which fields carry a value for a status: rut geometry (depth, width, piles, area, center) only when
// Ok; the ground slope when a ground line was fitted (Ok, NoRut, RutAtEdge); quality and valid_fraction
// for every status except NoMeasurement.
bool measurement_field_valid(RutStatus status, MeasurementField field) noexcept;

// One row of the CSV, '\n' included, into `line` (replaced; its capacity is reused, so a reserved line
// allocates nothing). `position`: also the position columns (a file whose header has them).
void format_measurement_row(std::string& line, std::uint64_t seq, std::int64_t t_ns, const RutMeasurement& measurement,
                            const GeoFix* position = nullptr);
std::string_view to_csv_text(GeoFix::Mode mode) noexcept;

// Writes the CSV to a stream it does not own (which must outlive the writer). Not thread-safe: one
// writer thread. Steady state allocates nothing (one reused line buffer).
class MeasurementCsvWriter {
 public:
  // Writes the header line. flush_each_line: flush the stream after every row, so a tail -f or a crash
  // sees every measurement written so far (costs a write syscall per row on a file stream).
  explicit MeasurementCsvWriter(std::ostream& out, bool flush_each_line = false);

  // Appends one row. Returns false when the stream has failed (disk full, closed pipe); the caller
  // keeps measuring and the stream's state tells the rest.
  bool write(std::uint64_t seq, std::int64_t t_ns, const RutMeasurement& measurement);

  std::uint64_t rows_written() const { return rows_written_; }

 private:
  std::ostream& out_;
  bool flush_each_line_;
  std::uint64_t rows_written_ = 0;
  std::string line_;
};

struct MeasurementRow {
  std::uint64_t seq = 0;
  std::int64_t t_ns = 0;
  // Empty fields read back as quiet NaN; the status is exact.
  RutMeasurement measurement;
  GeoFix position;  // from the position columns; Mode::None in a file without them
};

struct MeasurementCsv {
  std::vector<MeasurementRow> rows;
  // True when the last line had no terminating newline and did not parse (a writer killed mid-line):
  // that line is dropped instead of failing the whole file.
  bool truncated_tail = false;
  bool has_positions = false;  // the header has the position columns
};

// Reads a whole measurement CSV (tests and tools; not for the per-frame path). Throws InputError naming
// the file and "line N" for a missing file, a wrong header, a wrong field count, an unknown status, a
// field that is not a number, or a value present where the status says it cannot be.
MeasurementCsv read_measurement_csv(const std::string& path);
// The same from a stream the caller opened; `path` names it in messages.
MeasurementCsv read_measurement_csv(std::istream& in, const std::string& path);

}  // namespace rutd
