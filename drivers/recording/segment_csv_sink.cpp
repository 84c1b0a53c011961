#include "recording/segment_csv_sink.hpp"

#include <array>
#include <cmath>
#include <limits>
#include <string_view>

#include <fmt/format.h>

#include "core/csv_fields.hpp"
#include "core/input_error.hpp"

namespace rutd {
namespace {

std::string number(double v, int decimals) { return std::isfinite(v) ? fmt::format("{:.{}f}", v, decimals) : ""; }

}  // namespace

std::string format_segment_row(const Segment& s) {
  // The position columns stay empty without a valid fix; degrees with 9 decimals, as the measurement CSV.
  const bool fix = s.position.valid();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  return fmt::format("{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}", s.index, number(s.start_m, 3),
                     number(s.end_m, 3), s.t_start_ns, s.t_end_ns, s.frames, s.refused, number(s.mean_depth_mm, 2),
                     number(s.max_depth_mm, 2), number(s.p95_depth_mm, 2), number(s.depth_uncertainty_mm, 2),
                     number(s.mean_width_mm, 2), number(s.mean_area_mm2, 0), to_string(s.worst_status),
                     number(s.soil_strength, 1), number(s.soil_strength_uncertainty, 1), to_string(s.advisory),
                     number(fix ? s.position.latitude_deg : nan, 9), number(fix ? s.position.longitude_deg : nan, 9),
                     number(fix ? s.position.horizontal_error_m : nan, 2),
                     number(fix ? s.position.heading_deg : nan, 1));
}

namespace {

constexpr std::size_t kSegmentColumns = 21;

// One row's fields into a Segment; `fail` throws naming the column.
template <typename Fail>
Segment parse_segment_row(const std::array<std::string_view, kSegmentColumns>& f,
                          const std::array<std::string_view, kSegmentColumns>& names, Fail&& fail) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  auto real = [&](std::size_t i) {
    double v = nan;
    if (!f[i].empty() && !parse_csv_number(f[i], v)) fail(names[i], "not a number: '" + std::string(f[i]) + "'");
    return v;
  };
  auto whole = [&]<typename Int>(std::size_t i, Int& out) {
    if (!parse_csv_number(f[i], out)) fail(names[i], "not a whole number: '" + std::string(f[i]) + "'");
  };
  Segment s;
  whole(0, s.index);
  s.start_m = real(1);
  s.end_m = real(2);
  whole(3, s.t_start_ns);
  whole(4, s.t_end_ns);
  whole(5, s.frames);
  whole(6, s.refused);
  s.mean_depth_mm = real(7);
  s.max_depth_mm = real(8);
  s.p95_depth_mm = real(9);
  s.depth_uncertainty_mm = real(10);
  s.mean_width_mm = real(11);
  s.mean_area_mm2 = real(12);
  bool known = false;
  for (int i = 0; i < kRutStatusCount && !known; ++i) {
    known = to_string(static_cast<RutStatus>(i)) == f[13];
    if (known) s.worst_status = static_cast<RutStatus>(i);
  }
  if (!known) fail(names[13], "unknown status '" + std::string(f[13]) + "'");
  s.soil_strength = real(14);
  s.soil_strength_uncertainty = real(15);
  known = false;
  for (const Advisory a : {Advisory::Unknown, Advisory::Go, Advisory::Caution, Advisory::NoGo}) {
    if (to_string(a) == f[16]) s.advisory = a, known = true;
  }
  if (!known) fail(names[16], "unknown advisory '" + std::string(f[16]) + "'");
  s.position.latitude_deg = real(17);
  s.position.longitude_deg = real(18);
  s.position.horizontal_error_m = real(19);
  s.position.heading_deg = real(20);
  if (std::isfinite(s.position.latitude_deg) && std::isfinite(s.position.longitude_deg))
    s.position.mode = GeoFix::Mode::Fix2d;
  return s;
}

}  // namespace

std::vector<Segment> read_segment_csv(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, "line 1", "cannot open the segment CSV");
  std::string header;
  std::getline(in, header);
  if (!header.empty() && header.back() == '\r') header.pop_back();
  if (header != kSegmentCsvHeader)
    throw InputError(path, "line 1", std::string("not a segment CSV header; expected ") + kSegmentCsvHeader);
  std::array<std::string_view, kSegmentColumns> names{};
  split_csv_fields(kSegmentCsvHeader, names.data(), names.size());
  std::vector<Segment> segments;
  std::uint64_t number = 1;
  for (std::string line; std::getline(in, line);) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    auto fail = [&](std::string_view column, const std::string& what) {
      throw InputError(path, fmt::format("line {}, {}", number, column), what);
    };
    std::array<std::string_view, kSegmentColumns> f{};
    const std::size_t n = split_csv_fields(line, f.data(), f.size());
    if (n != kSegmentColumns) fail("row", fmt::format("{} fields, expected {}", n, kSegmentColumns));
    segments.push_back(parse_segment_row(f, names, fail));
  }
  return segments;
}

SegmentCsvSink::SegmentCsvSink(const std::string& path, const std::string& key) : path_(path) {
  out_.open(path, std::ios::out | std::ios::trunc);
  if (!out_) throw InputError(path, key, "cannot open for writing");
  out_ << kSegmentCsvHeader << '\n' << std::flush;
  if (!out_) throw InputError(path, key, "cannot write the header");
}

void SegmentCsvSink::publish_segment(const Segment& segment) {
  out_ << format_segment_row(segment) << '\n' << std::flush;
  if (out_) {
    ++rows_;
  } else {
    ++lost_;
    out_.clear();  // try the next row again (disk full may pass)
  }
}

}  // namespace rutd
