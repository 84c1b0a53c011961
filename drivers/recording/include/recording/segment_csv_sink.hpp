#pragma once
// The segment CSV (`rutd run`'s trafficability.segments_csv, `rutd replay --segments`): one row per closed
// segment of the track (core/track.hpp: Segment), written and flushed as it closes (about one a second
// at walking pace), so a reader of the file sees every segment so far. Columns:
//
//   index,start_m,end_m,t_start_ns,t_end_ns,frames,refused,mean_depth_mm,max_depth_mm,p95_depth_mm,
//   depth_uncertainty_mm,mean_width_mm,mean_area_mm2,worst_status,soil_strength,soil_strength_uncertainty,
//   advisory,latitude_deg,longitude_deg,horizontal_error_m,heading_deg
//
// metres with 3 decimals, millimetres with 2, mm^2 with 0, strength with 1; a value that is not known
// (NaN: no Ok measurement on the segment, no soil table) is empty. worst_status and advisory are words
// (core/rut_measurement.hpp, core/track.hpp to_string). The position (the fix of the measurement placed
// nearest the segment's middle) is empty without a fix: degrees with 9 decimals, error in metres with 2,
// heading in degrees with 1. Called from the publishing thread only.
#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

#include "core/measurement_sink.hpp"

namespace rutd {

// One segment's row without the newline (the format above).
std::string format_segment_row(const Segment& s);
inline constexpr const char* kSegmentCsvHeader =
    "index,start_m,end_m,t_start_ns,t_end_ns,frames,refused,mean_depth_mm,max_depth_mm,p95_depth_mm,"
    "depth_uncertainty_mm,mean_width_mm,mean_area_mm2,worst_status,soil_strength,soil_strength_uncertainty,advisory,"
    "latitude_deg,longitude_deg,horizontal_error_m,heading_deg";

// Reads a whole segment CSV (tools: `rutd map`; not for the per-frame path). A row's position, when it has
// one, comes back as a 2D fix (the file keeps no fix mode). Throws InputError naming the file and "line N,
// COLUMN" for a missing file, a wrong header or field count, a number that is not one, an unknown status
// or advisory.
std::vector<Segment> read_segment_csv(const std::string& path);

class SegmentCsvSink final : public MeasurementSink {
 public:
  // Creates or truncates `path` and writes the header; throws InputError(path, key, ...) when it cannot.
  SegmentCsvSink(const std::string& path, const std::string& key);
  void publish(const PublishedFrame&) override {}
  void publish_status(const SensorHealth&, std::int64_t) override {}
  void publish_segment(const Segment& segment) override;
  std::uint64_t rows_written() const noexcept { return rows_; }
  std::uint64_t rows_lost() const noexcept { return lost_; }
  const std::string& path() const noexcept { return path_; }

 private:
  std::string path_;
  std::ofstream out_;
  std::uint64_t rows_ = 0, lost_ = 0;
};

}  // namespace rutd
