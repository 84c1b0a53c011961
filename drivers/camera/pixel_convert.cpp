#include "pixel_convert.hpp"

#include <array>
#include <bit>
#include <cstring>
#include <utility>

#include <opencv2/imgproc.hpp>

namespace rutd {

namespace {

// The 16-bit layouts are copied as they are: the camera sends little-endian words and cv::Mat holds
// native ones. Every platform rutd targets (x86-64, little-endian AArch64) is little-endian.
static_assert(std::endian::native == std::endian::little, "16-bit pixel copy assumes a little-endian host");

constexpr std::array<std::pair<std::string_view, CameraPixelLayout>, 8> kNames{{
    {"Mono8", CameraPixelLayout::Mono8},
    {"Mono10", CameraPixelLayout::Mono10},
    {"Mono12", CameraPixelLayout::Mono12},
    {"Mono16", CameraPixelLayout::Mono16},
    {"BayerRG8", CameraPixelLayout::BayerRG8},
    {"BayerGR8", CameraPixelLayout::BayerGR8},
    {"BayerBG8", CameraPixelLayout::BayerBG8},
    {"BayerGB8", CameraPixelLayout::BayerGB8},
}};

// OpenCV's Bayer conversion code for a GenICam Bayer layout, or -1 for a mono layout.
//
// The two standards name the same sensor differently. GenICam (PFNC) names a pattern after the top-left
// 2x2 tile read along the first row: BayerRG8 is
//     row 0: R G R G ...
//     row 1: G B G B ...
// OpenCV names its COLOR_BayerXY2* codes after the second row's second and third pixels, i.e. the tile
// that starts at (row 1, column 1). For the sensor above that tile is B G / G R, so GenICam's BayerRG8 is
// OpenCV's BayerBG. In general the shift by one row and one column turns the tile [a b / c d] into
// [d c / b a], so OpenCV's name is GenICam's second row read backwards: RG -> BG, GR -> GB, BG -> RG,
// GB -> GR. (The unit test checks this against a mosaic built by hand from a colour image.)
int opencv_bayer_code(CameraPixelLayout layout) noexcept {
  switch (layout) {
    case CameraPixelLayout::BayerRG8: return cv::COLOR_BayerBG2GRAY;
    case CameraPixelLayout::BayerGR8: return cv::COLOR_BayerGB2GRAY;
    case CameraPixelLayout::BayerBG8: return cv::COLOR_BayerRG2GRAY;
    case CameraPixelLayout::BayerGB8: return cv::COLOR_BayerGR2GRAY;
    case CameraPixelLayout::Mono8:
    case CameraPixelLayout::Mono10:
    case CameraPixelLayout::Mono12:
    case CameraPixelLayout::Mono16: break;
  }
  return -1;
}

}  // namespace

std::optional<CameraPixelLayout> pixel_layout_from_name(std::string_view pfnc_name) noexcept {
  for (const auto& [name, layout] : kNames) {
    if (name == pfnc_name) return layout;
  }
  return std::nullopt;
}

std::string_view pixel_layout_name(CameraPixelLayout layout) noexcept {
  for (const auto& [name, l] : kNames) {
    if (l == layout) return name;
  }
  return {};
}

std::size_t bytes_per_pixel(CameraPixelLayout layout) noexcept {
  switch (layout) {
    case CameraPixelLayout::Mono10:
    case CameraPixelLayout::Mono12:
    case CameraPixelLayout::Mono16: return 2;
    case CameraPixelLayout::Mono8:
    case CameraPixelLayout::BayerRG8:
    case CameraPixelLayout::BayerGR8:
    case CameraPixelLayout::BayerBG8:
    case CameraPixelLayout::BayerGB8: break;
  }
  return 1;
}

bool convert_to_grey(CameraPixelLayout layout, const void* data, std::size_t bytes, int width, int height,
                     cv::Mat& out) noexcept {
  const int bayer_code = opencv_bayer_code(layout);
  const int min_side = bayer_code >= 0 ? 2 : 1;  // a Bayer tile needs at least 2x2 pixels
  if (data == nullptr || width < min_side || height < min_side) return false;
  const std::size_t bpp = bytes_per_pixel(layout);
  const std::size_t row_bytes = static_cast<std::size_t>(width) * bpp;
  if (bytes / row_bytes < static_cast<std::size_t>(height)) return false;

  try {
    // The source is only read; cv::Mat has no const-data constructor.
    const cv::Mat src(height, width, bpp == 2 ? CV_16UC1 : CV_8UC1, const_cast<void*>(data), row_bytes);
    if (bayer_code >= 0) {
      cv::cvtColor(src, out, bayer_code);  // reuses out's buffer when size and type fit
      return out.type() == CV_8UC1 && out.rows == height && out.cols == width;
    }
    out.create(height, width, src.type());  // no-op when size and type already fit
    if (out.isContinuous()) {
      std::memcpy(out.data, data, row_bytes * static_cast<std::size_t>(height));
    } else {
      for (int y = 0; y < height; ++y) std::memcpy(out.ptr(y), src.ptr(y), row_bytes);
    }
    return true;
  } catch (...) {  // cv::Exception or std::bad_alloc: report, never throw on the per-frame path
    return false;
  }
}

}  // namespace rutd
