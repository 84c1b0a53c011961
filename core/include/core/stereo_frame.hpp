#pragma once
// One synchronised stereo pair as it leaves a frame source: raw (unrectified) camera images.
#include <cstdint>

#include <opencv2/core.hpp>

namespace rutd {

// Where t_ns comes from (DESIGN.md, Units and conventions).
enum class ClockKind : std::uint8_t {
  Monotonic,  // CLOCK_MONOTONIC of this machine, or a recording's own time base
  Hardware,   // the cameras' hardware timestamp (PTP or trigger-synchronised)
};

struct StereoFrame {
  std::uint64_t seq = 0;  // sequence number from the source, increasing by one per pair produced
  std::int64_t t_ns = 0;  // capture time of the pair, nanoseconds
  // The right camera's capture time minus the left's, ns, where the source knows it (cameras' hardware
  // timestamps, a renderer, a recording that kept it); 0 when synchronised or unknown. Free-running
  // cameras at vehicle speed see the ground move by speed x skew between the two images.
  std::int64_t skew_ns = 0;
  ClockKind clock = ClockKind::Monotonic;
  // CV_8UC1 or CV_16UC1, same size and type in both. Sources reuse these buffers when size and type
  // already fit, so a frame kept in a pool is refilled without allocation.
  cv::Mat left;
  cv::Mat right;
};

// The sensor's full scale for an image whose brightest pixel is `brightest`: 255 for 8-bit pixels; for
// 16-bit ones the smallest 2^k - 1 at or above it (4095 for a 12-bit sensor, whose values fill 16-bit
// pixels only up to there). Exposure figures and noise are fractions of this.
inline int sensor_full_scale(int depth, double brightest) {
  int top = 255;
  if (depth == CV_16U)
    while (top < brightest && top < 65535) top = top * 2 + 1;
  return top;
}

}  // namespace rutd
