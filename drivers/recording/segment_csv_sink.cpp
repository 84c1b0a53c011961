#include "recording/segment_csv_sink.hpp"

#include <cmath>
#include <limits>

#include <fmt/format.h>

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
