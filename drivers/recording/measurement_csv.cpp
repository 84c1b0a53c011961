// Measurement CSV writer and reader (DESIGN.md, Formats). std::to_chars/from_chars keep the text
// independent of the global locale, which could otherwise turn the decimal point into a comma.
#include "recording/measurement_csv.hpp"

#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <limits>
#include <ostream>

#include "core/csv_fields.hpp"
#include "core/input_error.hpp"

namespace rutd {
namespace {

constexpr int kStatusCount = kRutStatusCount;
constexpr int kColumnCount = 3 + kMeasurementFieldCount;
constexpr int kPositionColumnCount = 6;

struct FieldSpec {
  const char* name;
  int decimals;
  double RutMeasurement::*member;
};

// In file order, matching MeasurementField.
constexpr std::array<FieldSpec, kMeasurementFieldCount> kFields{{
    {"rut_depth_mm", 3, &RutMeasurement::depth_mm},
    {"rut_width_mm", 3, &RutMeasurement::width_mm},
    {"left_pile_mm", 3, &RutMeasurement::left_pile_mm},
    {"right_pile_mm", 3, &RutMeasurement::right_pile_mm},
    {"area_mm2", 3, &RutMeasurement::area_mm2},
    {"ground_slope_deg", 3, &RutMeasurement::ground_slope_deg},
    {"center_x_mm", 3, &RutMeasurement::center_x_mm},
    {"quality", 4, &RutMeasurement::quality},
    {"valid_fraction", 4, &RutMeasurement::valid_fraction},
}};

// Appends `value` with fixed decimals; "-0.000" becomes "0.000" so a tiny negative does not read as a sign.
void append_fixed(std::string& line, double value, int decimals) {
  char text[400];  // enough for any double in fixed notation
  const auto result = std::to_chars(text, text + sizeof text, value, std::chars_format::fixed, decimals);
  const char* begin = text;
  if (*begin == '-') {
    bool all_zero = true;
    for (const char* p = begin + 1; p != result.ptr; ++p) all_zero = all_zero && (*p == '0' || *p == '.');
    if (all_zero) ++begin;
  }
  line.append(begin, static_cast<std::size_t>(result.ptr - begin));
}

template <typename Int>
void append_integer(std::string& line, Int value) {
  char text[24];
  const auto result = std::to_chars(text, text + sizeof text, value);
  line.append(text, result.ptr);
}

bool parse_status(std::string_view text, RutStatus& status) {
  for (int i = 0; i < kStatusCount; ++i) {
    const auto candidate = static_cast<RutStatus>(i);
    if (to_string(candidate) == text) {
      status = candidate;
      return true;
    }
  }
  return false;
}

class RowParser {
 public:
  RowParser(const std::string& path, std::uint64_t line_number, bool positions)
      : path_(path), line_(line_number), positions_(positions) {}

  [[noreturn]] void fail(const std::string& message) const {
    throw InputError(path_, "line " + std::to_string(line_), message);
  }

  MeasurementRow parse(std::string_view line) const {
    std::string_view f[kColumnCount + kPositionColumnCount];
    const std::size_t columns = kColumnCount + (positions_ ? kPositionColumnCount : 0);
    const std::size_t count = split_csv_fields(line, f, columns);
    if (count != columns) fail("expected " + std::to_string(columns) + " fields, found " + std::to_string(count));
    MeasurementRow row;
    if (!parse_csv_number(f[0], row.seq)) fail("seq '" + std::string(f[0]) + "' is not a non-negative integer");
    if (!parse_csv_number(f[1], row.t_ns)) fail("t_ns '" + std::string(f[1]) + "' is not an integer");
    if (!parse_status(f[2], row.measurement.status)) fail("unknown status '" + std::string(f[2]) + "'");
    for (int i = 0; i < kMeasurementFieldCount; ++i) {
      row.measurement.*kFields[i].member = parse_field(f[3 + i], row.measurement.status, i);
    }
    if (positions_) row.position = parse_position(f + kColumnCount);
    return row;
  }

 private:
  double parse_field(std::string_view text, RutStatus status, int index) const {
    if (text.empty()) return std::numeric_limits<double>::quiet_NaN();
    const std::string name = kFields[index].name;
    double value = 0.0;
    if (!parse_csv_number(text, value) || !std::isfinite(value)) {
      fail(name + " '" + std::string(text) + "' is not a finite number");
    }
    if (!measurement_field_valid(status, static_cast<MeasurementField>(index))) {
      fail(name + " holds a value but must be empty when status is " + std::string(to_string(status)));
    }
    return value;
  }

  GeoFix parse_position(const std::string_view* f) const {
    GeoFix p;
    bool known = false;
    for (auto mode : {GeoFix::Mode::None, GeoFix::Mode::NoFix, GeoFix::Mode::Fix2d, GeoFix::Mode::Fix3d}) {
      if (to_csv_text(mode) == f[0]) {
        p.mode = mode;
        known = true;
      }
    }
    if (!known) fail("unknown fix_mode '" + std::string(f[0]) + "'");
    static constexpr const char* names[] = {"latitude_deg", "longitude_deg", "altitude_m", "horizontal_error_m",
                                            "heading_deg"};
    double* members[] = {&p.latitude_deg, &p.longitude_deg, &p.altitude_m, &p.horizontal_error_m, &p.heading_deg};
    for (int i = 0; i < 5; ++i) {
      if (f[1 + i].empty()) continue;
      if (!p.valid()) fail(std::string(names[i]) + " holds a value but must be empty without a fix");
      if (!parse_csv_number(f[1 + i], *members[i]) || !std::isfinite(*members[i]))
        fail(std::string(names[i]) + " '" + std::string(f[1 + i]) + "' is not a finite number");
    }
    if (p.valid() && (!std::isfinite(p.latitude_deg) || !std::isfinite(p.longitude_deg)))
      fail("a fix needs latitude_deg and longitude_deg");
    if (p.valid() && (std::abs(p.latitude_deg) > 90.0 || std::abs(p.longitude_deg) > 180.0))
      fail("latitude_deg or longitude_deg out of range");
    return p;
  }

  const std::string& path_;
  std::uint64_t line_;
  bool positions_;
};

}  // namespace

bool measurement_field_valid(RutStatus status, MeasurementField field) noexcept {
  switch (field) {
    case MeasurementField::Quality:
    case MeasurementField::ValidFraction: return status != RutStatus::NoMeasurement;
    case MeasurementField::GroundSlopeDeg:
      return status == RutStatus::Ok || status == RutStatus::NoRut || status == RutStatus::RutAtEdge;
    default: return status == RutStatus::Ok;
  }
}

MeasurementCsvWriter::MeasurementCsvWriter(std::ostream& out, bool flush_each_line)
    : out_(out), flush_each_line_(flush_each_line) {
  line_.reserve(256);
  out_.write(kMeasurementCsvHeader.data(), static_cast<std::streamsize>(kMeasurementCsvHeader.size()));
  out_.put('\n');
  if (flush_each_line_) out_.flush();
}

std::string_view to_csv_text(GeoFix::Mode mode) noexcept {
  switch (mode) {
    case GeoFix::Mode::None: return "NONE";
    case GeoFix::Mode::NoFix: return "NO_FIX";
    case GeoFix::Mode::Fix2d: return "2D";
    case GeoFix::Mode::Fix3d: return "3D";
  }
  return "NONE";
}

namespace {

void append_position(std::string& line, const GeoFix& p) {
  line.push_back(',');
  line.append(to_csv_text(p.mode));
  const double values[] = {p.latitude_deg, p.longitude_deg, p.altitude_m, p.horizontal_error_m, p.heading_deg};
  static constexpr int decimals[] = {9, 9, 3, 3, 2};
  for (int i = 0; i < 5; ++i) {
    line.push_back(',');
    if (p.valid() && std::isfinite(values[i])) append_fixed(line, values[i], decimals[i]);
  }
}

}  // namespace

void format_measurement_row(std::string& line, std::uint64_t seq, std::int64_t t_ns, const RutMeasurement& measurement,
                            const GeoFix* position) {
  line.clear();
  append_integer(line, seq);
  line.push_back(',');
  append_integer(line, t_ns);
  line.push_back(',');
  line.append(to_string(measurement.status));
  for (int i = 0; i < kMeasurementFieldCount; ++i) {
    line.push_back(',');
    const double value = measurement.*kFields[i].member;
    if (measurement_field_valid(measurement.status, static_cast<MeasurementField>(i)) && std::isfinite(value)) {
      append_fixed(line, value, kFields[i].decimals);
    }
  }
  if (position != nullptr) append_position(line, *position);
  line.push_back('\n');
}

bool MeasurementCsvWriter::write(std::uint64_t seq, std::int64_t t_ns, const RutMeasurement& measurement) {
  format_measurement_row(line_, seq, t_ns, measurement);
  out_.write(line_.data(), static_cast<std::streamsize>(line_.size()));
  if (flush_each_line_) out_.flush();
  if (!out_) return false;
  ++rows_written_;
  return true;
}

MeasurementCsv read_measurement_csv(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "file", "cannot open");
  return read_measurement_csv(in, path);
}

MeasurementCsv read_measurement_csv(std::istream& in, const std::string& path) {
  std::string line;
  if (!std::getline(in, line)) throw InputError(path, "line 1", "missing header (file is empty)");
  if (!line.empty() && line.back() == '\r') line.pop_back();
  MeasurementCsv csv;
  const std::string with_positions =
      std::string(kMeasurementCsvHeader) + "," + std::string(kMeasurementCsvPositionColumns);
  csv.has_positions = line == with_positions;
  if (line != kMeasurementCsvHeader && !csv.has_positions) {
    throw InputError(path, "line 1",
                     "header is '" + line + "' but must be '" + std::string(kMeasurementCsvHeader) + "'");
  }
  std::uint64_t line_number = 1;
  while (std::getline(in, line)) {
    ++line_number;
    const bool cut_off = in.eof();  // no terminating newline
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    try {
      csv.rows.push_back(RowParser(path, line_number, csv.has_positions).parse(line));
    } catch (const InputError&) {
      if (!cut_off) throw;
      csv.truncated_tail = true;
    }
  }
  if (in.bad()) throw InputError(path, "line " + std::to_string(line_number + 1), "read error");
  return csv;
}

}  // namespace rutd
