#pragma once
// PNG plots of what rutd measured (the seed paper's Fig. 12 and 13, disparity maps): drawn with PLplot
// (axes, labels, legends, colour bars) into memory and written with OpenCV, which also draws the overlays
// on camera images. Every function returns a status instead of throwing, so a plot that cannot be
// written never stops a measurement. Thread-safe: PLplot keeps global state, so figures are drawn one at
// a time (an internal mutex); the sink's single plot thread is the usual caller.
#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/cross_section.hpp"
#include "core/rut_measurement.hpp"

namespace rutd {

struct PlotResult {
  bool ok = false;
  std::string error;  // names the file when !ok
};

// The data area of a plot: which pixels of the page show which world rectangle. x grows to the right;
// y_top is the world y shown at the top edge of the area (the cross-section's Z axis points down, so
// there y_top < y_bottom).
struct PlotAxes {
  cv::Rect2d area_px;  // left, top, width, height in page pixels
  double x_left = 0, x_right = 1, y_top = 1, y_bottom = 0;
  cv::Point2d to_pixel(double x, double y) const {
    return {area_px.x + (x - x_left) / (x_right - x_left) * area_px.width,
            area_px.y + (y - y_top) / (y_bottom - y_top) * area_px.height};
  }
};

// Colours of the cross-section plot's marks (B, G, R), for readers of the images (tests).
inline const cv::Scalar kPlotGroundLineBgr{200, 90, 0};  // blue
inline const cv::Scalar kPlotDeepestBgr{0, 0, 220};      // red
inline const cv::Scalar kPlotPileBgr{0, 140, 0};         // green

// The cross-section Z(X) (Z, the distance from the camera, grows downwards so the rut looks like one),
// with the fitted ground line, both pile tops, the deepest point and a line from the ground line down to
// it, and depth, width and status in the title. `geometry` is where the rut extraction found the rut on
// this section (PublishedFrame::geometry). `axes` (optional) receives the mapping.
PlotResult plot_cross_section(const std::string& path, const CrossSection& section, const RutMeasurement& m,
                              const RutGeometry& geometry, const std::string& title, cv::Size page = {1000, 600},
                              PlotAxes* axes = nullptr);

// A disparity map (CV_32FC1 px, NaN invalid, drawn white) in a colour map with a scale bar; `row0` is the
// image row of its first row (a strip of a rectified image). Strips are stretched vertically to stay
// readable; the row axis keeps the real row numbers. An invalid pixel between two valid ones of its
// column (rows skipped by DIC's row step) is drawn as their mean.
PlotResult plot_disparity(const std::string& path, const cv::Mat& disparity, int row0, const std::string& title,
                          cv::Size page = {1000, 600});

// A rectified left image (CV_8UC1) with the measured strip outlined, the rut's crossings and deepest
// point marked where known (columns, < 0: none), and a caption. Same size as the image, at least 640 px
// wide (smaller images are scaled up).
struct ImageMarks {
  int strip_row0 = 0, strip_rows = 0;
  double left_col = -1, right_col = -1, deepest_col = -1;
  std::string caption;
};
PlotResult write_strip_overlay(const std::string& path, const cv::Mat& rectified_left, const ImageMarks& marks);

// One measurement of a run, for the depth-over-time plot.
struct SeriesSample {
  std::uint64_t seq = 0;
  double t_s = 0;  // seconds since the first sample
  RutStatus status = RutStatus::NoMeasurement;
  double depth_mm = 0, width_mm = 0, quality = 0;
};

// Depth, width and quality against time, three panels sharing the time axis; frames whose status is not
// Ok are marked below each panel's data in a colour per status, with a legend.
PlotResult plot_series(const std::string& path, const std::vector<SeriesSample>& samples, const std::string& title,
                       cv::Size page = {1000, 800});

// One drive's depth along its track, for the map's depth-by-pass plot: distance along the track (m) and
// the segment's mean depth (NaN: not measured, a gap in the line).
struct DepthAlongTrack {
  std::string label;  // e.g. "drive 2 (pass 1 on 18 m)"
  std::vector<double> distance_m, depth_mm;
};
// Depth against distance along the track, one coloured line per drive with a legend.
PlotResult plot_depth_along_track(const std::string& path, const std::vector<DepthAlongTrack>& drives,
                                  const std::string& title, cv::Size page = {1000, 600});

}  // namespace rutd
