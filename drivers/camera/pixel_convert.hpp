#pragma once
// Camera image buffers as the cameras deliver them, and their conversion to the grey image the stereo
// pipeline measures on (the measurement needs intensity only, so colour sensors are demosaiced straight
// to grey).
//
// Contract
// - Layouts are named as in GenICam's Pixel Format Naming Convention (PFNC): rows are packed with no
//   padding, Mono10/Mono12/Mono16 pixels are unpacked 16-bit little-endian words (the packed variants
//   Mono10p, Mono12p, ... are not accepted).
// - Thread safety: every function is pure apart from writing `out`; calls on different `out` matrices may
//   run concurrently.
// - No allocation in steady state: `out` keeps its buffer when its size and type already fit.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string_view>

#include <opencv2/core.hpp>

namespace rutd {

// A camera's pixel format. BayerXY8: 8-bit colour-filter-array image whose top-left 2x2 tile reads
// X Y on the first row (GenICam's definition: BayerRG8 is R G R G... / G B G B...).
enum class CameraPixelLayout : std::uint8_t {
  Mono8,
  Mono10,  // values 0..1023 in 16-bit words
  Mono12,  // values 0..4095 in 16-bit words
  Mono16,
  BayerRG8,
  BayerGR8,
  BayerBG8,
  BayerGB8,
};

// The layout named by a GenICam PFNC name ("Mono8", "BayerRG8", ...; exact, case-sensitive), or nullopt
// for any other format, including the packed and 10/12-bit Bayer ones rutd does not convert.
std::optional<CameraPixelLayout> pixel_layout_from_name(std::string_view pfnc_name) noexcept;

// The PFNC name of a layout (the inverse of pixel_layout_from_name).
std::string_view pixel_layout_name(CameraPixelLayout layout) noexcept;

// Bytes one pixel occupies in the camera buffer: 1 or 2.
std::size_t bytes_per_pixel(CameraPixelLayout layout) noexcept;

// Converts one camera image (`width` x `height` pixels at `data`, `bytes` long) to grey in `out`:
// CV_8UC1 for Mono8 and the Bayer layouts, CV_16UC1 for Mono10/12/16 with the values exactly as the
// camera gave them (no rescaling). Mono images are copied byte for byte; Bayer images are demosaiced by
// OpenCV's bilinear Bayer-to-grey conversion (grey = 0.299 R + 0.587 G + 0.114 B at every pixel).
// `out` is reused in place when its size and type fit, else reallocated; it must not alias `data`.
// Returns false, leaving `out` unspecified, when width or height is not positive (Bayer: below 2), when
// `bytes` is smaller than width * height * bytes_per_pixel, or when OpenCV fails.
bool convert_to_grey(CameraPixelLayout layout, const void* data, std::size_t bytes, int width, int height,
                     cv::Mat& out) noexcept;

}  // namespace rutd
