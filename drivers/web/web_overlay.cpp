#include "web/web_overlay.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace rutd {
namespace {

const cv::Scalar kStripColour(255, 200, 0);    // BGR: the measured rows
const cv::Scalar kEdgeColour(0, 220, 255);     // the rut's edges (ground-line crossings)
const cv::Scalar kDeepestColour(40, 40, 255);  // the deepest point

// Rectified pixel of a point in the left rectified camera frame (mm) in the left or right view.
cv::Point2d project(const WebContext& c, bool left, const cv::Vec3d& p) {
  const cv::Matx34d& P = left ? c.rectification.P1 : c.rectification.P2;
  const cv::Vec3d h = P * cv::Vec4d(p[0], p[1], p[2], 1.0);
  return {h[0] / h[2], h[1] / h[2]};
}

// The rut's marks as points in the left rectified camera frame, on the middle of the measured rows.
struct RutMarks {
  bool valid = false;
  cv::Vec3d left_edge, right_edge, deepest;
};

RutMarks rut_marks(const WebContext& c, const WebFrame& f) {
  RutMarks m;
  const RutGeometry& g = f.geometry;
  if (!f.has_strips || !g.has_line || !g.has_rut) return m;
  const double fy = c.rectification.P1(1, 1), cy = c.rectification.P1(1, 2);
  const double v = f.measured_row0 + 0.5 * f.measured_rows;
  const auto at = [&](double x, double z) { return cv::Vec3d(x, (v - cy) * z / fy, z); };
  const auto line = [&](double x) { return g.line_m * x + g.line_c; };
  m.left_edge = at(g.left_x_mm, line(g.left_x_mm));
  m.right_edge = at(g.right_x_mm, line(g.right_x_mm));
  m.deepest = at(g.deepest_x_mm, deepest_z_mm(g, f.measurement.depth_mm));
  m.valid = m.left_edge[2] > 0 && m.right_edge[2] > 0 && m.deepest[2] > 0;
  return m;
}

cv::Mat to_bgr8(const cv::Mat& grey, int top) {
  cv::Mat g8, bgr;
  if (grey.depth() == CV_8U) g8 = grey;
  else grey.convertTo(g8, CV_8U, 255.0 / top);
  cv::cvtColor(g8, bgr, cv::COLOR_GRAY2BGR);
  return bgr;
}

std::string encode(const char* ext, const cv::Mat& image, std::vector<int> params) {
  std::vector<unsigned char> bytes;
  if (!cv::imencode(ext, image, bytes, params)) return "";
  return std::string(bytes.begin(), bytes.end());
}

}  // namespace

cv::Point2d raw_from_rectified(const WebContext& c, bool left, cv::Point2d r) {
  const cv::Matx34d& P = left ? c.rectification.P1 : c.rectification.P2;
  const cv::Matx33d& R = left ? c.rectification.R1 : c.rectification.R2;
  const cv::Vec3d ray_rect((r.x - P(0, 2)) / P(0, 0), (r.y - P(1, 2)) / P(1, 1), 1.0);
  const cv::Vec3d ray = R.t() * ray_rect;  // in the camera's own frame
  std::vector<cv::Point3d> in{cv::Point3d(ray[0], ray[1], ray[2])};
  std::vector<cv::Point2d> out;
  cv::projectPoints(in, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), left ? c.calibration.M1 : c.calibration.M2,
                    left ? c.calibration.D1 : c.calibration.D2, out);
  return out[0];
}

std::string camera_jpeg(const WebContext& c, const WebFrame& f, bool left, int top) {
  const cv::Mat& raw = left ? f.left_raw : f.right_raw;
  if (!f.has_images || raw.empty()) return "";
  cv::Mat bgr = to_bgr8(raw, top);
  const double scale = bgr.cols > kWebImageMaxWidth ? static_cast<double>(kWebImageMaxWidth) / bgr.cols : 1.0;
  if (scale < 1.0) cv::resize(bgr, bgr, cv::Size(), scale, scale, cv::INTER_AREA);
  const auto pt = [&](cv::Point2d raw_px) { return cv::Point(cvRound(raw_px.x * scale), cvRound(raw_px.y * scale)); };
  // Drawn only where the calibration fits the images (a replay's calibration always does).
  if (f.has_strips && raw.size() == c.calibration.image_size) {
    const int width = c.rectification.rectified_size.width;
    for (const int row : {f.measured_row0, f.measured_row0 + f.measured_rows}) {
      std::vector<cv::Point> line;
      for (int i = 0; i <= 32; ++i) line.push_back(pt(raw_from_rectified(c, left, {width * i / 32.0, double(row)})));
      cv::polylines(bgr, line, false, kStripColour, 1, cv::LINE_AA);
    }
    const RutMarks m = rut_marks(c, f);
    if (m.valid) {
      for (const auto& e : {m.left_edge, m.right_edge})
        cv::drawMarker(bgr, pt(raw_from_rectified(c, left, project(c, left, e))), kEdgeColour, cv::MARKER_TRIANGLE_UP,
                       12, 2);
      cv::circle(bgr, pt(raw_from_rectified(c, left, project(c, left, m.deepest))), 5, kDeepestColour, 2, cv::LINE_AA);
    }
  }
  return encode(".jpg", bgr, {cv::IMWRITE_JPEG_QUALITY, 80});
}

std::string strip_png(const WebContext& c, const WebFrame& f) {
  if (!f.has_strips || f.left_strip.empty()) return "";
  const int rows = f.left_strip.rows, gap = 4;
  cv::Mat both(2 * rows + gap, f.left_strip.cols, CV_8UC3, cv::Scalar(60, 60, 60));
  const RutMarks m = rut_marks(c, f);
  for (int i = 0; i < 2; ++i) {
    const bool left = i == 0;
    cv::Mat part = both.rowRange(i * (rows + gap), i * (rows + gap) + rows);
    cv::cvtColor(left ? f.left_strip : f.right_strip, part, cv::COLOR_GRAY2BGR);
    const int a = f.measured_row0 - f.strip_row0, b = a + f.measured_rows;
    cv::line(part, {0, a}, {part.cols - 1, a}, kStripColour, 1);
    cv::line(part, {0, b}, {part.cols - 1, b}, kStripColour, 1);
    if (!m.valid) continue;
    const auto col = [&](const cv::Vec3d& p) { return cvRound(project(c, left, p).x); };
    cv::line(part, {col(m.left_edge), 0}, {col(m.left_edge), rows - 1}, kEdgeColour, 1);
    cv::line(part, {col(m.right_edge), 0}, {col(m.right_edge), rows - 1}, kEdgeColour, 1);
    cv::circle(part, {col(m.deepest), (a + b) / 2}, 4, kDeepestColour, 2, cv::LINE_AA);
  }
  return encode(".png", both, {cv::IMWRITE_PNG_COMPRESSION, 1});
}

}  // namespace rutd
