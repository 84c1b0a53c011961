#pragma once
// Rectification as the Vulkan matcher runs it (shaders/rectify.comp) and its plain C++ reference: each
// strip pixel samples the raw image at its map position (the float maps of cv::initUndistortRectifyMap,
// as rutd::StereoGeometry computes them) with the cubic B-spline smoothing kernel of
// pipeline/stereo_geometry.cpp (why that kernel: the comment on make_taps there). The arithmetic is fixed
// so that device and reference agree bit for bit: positions clamped to the raw image, weights
// (u^3, 3t^3 - 6t^2 + 4, -3t^3 + 3t^2 + 3t + 1, t^3) times 1/6 with no fused multiply-adds, each row of
// four taps summed left to right and the rows top to bottom, rounded half to even. The CPU rectifier
// sums its taps in SIMD order, so its strips may differ from these by 1 grey level at rounding ties.
// 8-bit raw images only. No OpenCV.
#include <array>
#include <string>
#include <vector>

#include "gpu/sgm.hpp"

namespace rutd::gpu {

// Where every strip pixel of both cameras samples its raw image.
struct RectifyMaps {
  int raw_width = 0, raw_height = 0;  // px, the size of both raw images
  int width = 0, height = 0;          // px, the strip
  // Per strip pixel, row-major: x then y of the raw position it samples, px (pixel centres at integers).
  std::vector<float> left, right;
};

// Empty when `maps` are well-formed for a strip of width x height, else what is wrong.
std::string check_rectify_maps(const RectifyMaps& maps, int width, int height);

// The raw rows [first, last + 1) that rectifying through `maps` reads (both cameras): the 4x4 blocks of
// the clamped positions. maps must pass check_rectify_maps.
std::array<int, 2> rectify_rows(const RectifyMaps& maps);

// Rectifies one raw image through `map` (2 * width * height floats, as RectifyMaps::left) into `out`
// (width x height, row-major, no padding). raw is raw_width x raw_height.
void rectify_reference(const ImageView& raw, const std::vector<float>& map, int width, int height,
                       std::vector<std::uint8_t>& out);

// The band estimate's coarse pass (rutd::BandEstimator): the strips averaged over blocks of `scale`
// columns by `row_factor` rows (2 for strips of at least 10 rows, else 1), trailing columns and rows that
// fill no block dropped; each coarse pixel is (block sum + area / 2) / area in integers
// (shaders/downsample.comp).
struct CoarseGrid {
  int scale = 1, row_factor = 1;
  int width = 0, height = 0;  // px of the coarse images
};
CoarseGrid coarse_grid(int width, int height, int scale);
void downsample_reference(const ImageView& strip, const CoarseGrid& grid, std::vector<std::uint8_t>& out);

}  // namespace rutd::gpu
