#pragma once
// The aiming aids of the live view: what an installer watches while turning a lens or an exposure
// setting. Pure functions on one image; the view thread computes them for each pair it shows.
#include <array>
#include <cstdint>
#include <limits>

#include <opencv2/core.hpp>

namespace rutd {

inline constexpr int kHistogramBins = 64;

struct CameraAiming {
  // Sharpness: the variance of the Laplacian (3x3 aperture) over the measured rows of the rectified
  // strip, 8-bit grey levels squared. Higher is sharper; only comparisons on the same scene mean anything
  // (texture raises it too), which is how it is used: turn the focus ring to its maximum. NaN when the
  // pair was not measured (no strip).
  double focus = std::numeric_limits<double>::quiet_NaN();
  // Exposure, over the whole raw image. `top` is the sensor's full scale as the image shows it: 255 for
  // 8-bit images; for 16-bit containers the smallest 2^k - 1 at or above the brightest pixel (4095 for a
  // 12-bit sensor), at least 255.
  int top = 255;
  double mean = 0.0;                                      // mean grey level as a fraction of top, 0..1
  double saturated_share = 0.0;                           // pixels at top
  double dark_share = 0.0;                                // pixels at or below 2 % of top
  std::array<std::uint32_t, kHistogramBins> histogram{};  // pixel counts in equal bins of 0..top
};

// Variance of the 3x3 Laplacian of rows [row0, row0 + rows) of a CV_8UC1 image (clamped to the image);
// NaN when fewer than 3 rows or columns remain.
double focus_measure(const cv::Mat& grey8, int row0, int rows);

// The exposure figures of a CV_8UC1 or CV_16UC1 image (focus left NaN).
CameraAiming exposure_figures(const cv::Mat& raw);

}  // namespace rutd
