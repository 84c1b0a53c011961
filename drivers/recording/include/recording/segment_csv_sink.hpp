#pragma once
// The segment CSV (`rutd run`'s trafficability.segments_csv, `rutd replay --segments`): one row per closed
// segment of the track (core/track.hpp: Segment), written and flushed as it closes (about one a second
// at walking pace), so a reader of the file sees every segment so far. Columns:
//
//   index,start_m,end_m,t_start_ns,t_end_ns,frames,refused,mean_depth_mm,max_depth_mm,p95_depth_mm,
//   depth_uncertainty_mm,mean_width_mm,mean_area_mm2,worst_status,soil_strength,soil_strength_uncertainty,
//   advisory
//
// metres with 3 decimals, millimetres with 2, mm^2 with 0, strength with 1; a value that is not known
// (NaN: no Ok measurement on the segment, no soil table) is empty. worst_status and advisory are words
// (core/rut_measurement.hpp, core/track.hpp to_string). Called from the publishing thread only.
#include <cstdint>
#include <fstream>
#include <string>

#include "core/measurement_sink.hpp"

namespace rutd {

// One segment's row without the newline (the format above).
std::string format_segment_row(const Segment& s);
inline constexpr const char* kSegmentCsvHeader =
    "index,start_m,end_m,t_start_ns,t_end_ns,frames,refused,mean_depth_mm,max_depth_mm,p95_depth_mm,"
    "depth_uncertainty_mm,mean_width_mm,mean_area_mm2,worst_status,soil_strength,soil_strength_uncertainty,advisory,"
    "latitude_deg,longitude_deg,horizontal_error_m,heading_deg";

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
