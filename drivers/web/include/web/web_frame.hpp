#pragma once
// One published pair as the live view keeps it: copies of what the page shows, taken on the publish
// thread (PublishedFrame's pointers are valid only during the call) and read on the view thread. The
// buffers are reused slot to slot, so once their sizes fit a copy allocates nothing.
#include <cstdint>

#include <opencv2/core.hpp>

#include "core/measurement_sink.hpp"

namespace rutd {

struct WebFrame {
  std::uint64_t seq = 0;
  std::int64_t t_ns = 0;
  std::int64_t skew_ns = 0;
  RutMeasurement measurement;
  SensorHealth health;
  VehicleMotion motion;
  GeoFix position;
  StageTimes times;
  bool has_images = false;  // left_raw, right_raw hold this pair's raw images
  cv::Mat left_raw, right_raw;
  bool has_strips = false;  // the pair was measured: strips, section and geometry hold its detail
  cv::Mat left_strip, right_strip;
  int strip_row0 = 0, measured_row0 = 0, measured_rows = 0;
  CrossSection section;
  RutGeometry geometry;
};

// Copies `from` into `to` (publish thread). The images are copied as they are (raw depth and size).
void web_frame_copy(const PublishedFrame& from, WebFrame& to);

}  // namespace rutd
