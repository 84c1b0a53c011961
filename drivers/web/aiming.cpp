#include "web/aiming.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "core/stereo_frame.hpp"

namespace rutd {

double focus_measure(const cv::Mat& grey8, int row0, int rows) {
  CV_Assert(grey8.type() == CV_8UC1);
  const int a = std::clamp(row0, 0, grey8.rows), b = std::clamp(row0 + rows, 0, grey8.rows);
  if (b - a < 3 || grey8.cols < 3) return std::numeric_limits<double>::quiet_NaN();
  // The rows around the band feed its border pixels, so the band's edges are not artefacts of a border rule.
  const int pa = std::max(0, a - 1), pb = std::min(grey8.rows, b + 1);
  cv::Mat lap;
  cv::Laplacian(grey8.rowRange(pa, pb), lap, CV_32F, 1, 1.0, 0.0, cv::BORDER_REPLICATE);
  // Interior only: the replicated borders have no true neighbours.
  const cv::Mat inner =
      lap(cv::Rect(1, a - pa + (a == pa ? 1 : 0), lap.cols - 2, (b - a) - (a == pa ? 1 : 0) - (b == pb ? 1 : 0)));
  if (inner.rows < 1) return std::numeric_limits<double>::quiet_NaN();
  cv::Scalar mean, sd;
  cv::meanStdDev(inner, mean, sd);
  return sd[0] * sd[0];
}

CameraAiming exposure_figures(const cv::Mat& raw) {
  CV_Assert(raw.type() == CV_8UC1 || raw.type() == CV_16UC1);
  CameraAiming a;
  if (raw.empty()) return a;
  double hi = 0;
  if (raw.depth() == CV_16U) cv::minMaxLoc(raw, nullptr, &hi);
  const int top = sensor_full_scale(raw.depth(), hi);
  a.top = top;
  const double dark = 0.02 * top;
  std::uint64_t saturated = 0, darkn = 0;
  double sum = 0;
  const auto count = [&](auto* row, int n) {
    for (int x = 0; x < n; ++x) {
      const int v = row[x];
      sum += v;
      saturated += v >= top;
      darkn += v <= dark;
      ++a.histogram[std::min(kHistogramBins - 1,
                             static_cast<int>(static_cast<std::int64_t>(v) * kHistogramBins / (top + 1)))];
    }
  };
  for (int y = 0; y < raw.rows; ++y) {
    if (raw.depth() == CV_8U) count(raw.ptr<std::uint8_t>(y), raw.cols);
    else count(raw.ptr<std::uint16_t>(y), raw.cols);
  }
  const double n = static_cast<double>(raw.total());
  a.mean = sum / n / top;
  a.saturated_share = static_cast<double>(saturated) / n;
  a.dark_share = static_cast<double>(darkn) / n;
  return a;
}

}  // namespace rutd
