#pragma once
// Semi-global matching with census costs: the parameters, the stage buffers, and the plain C++ reference
// of every stage of the Vulkan matcher (vulkan_sgm.hpp). The reference does the same integer arithmetic as
// the shaders (pipeline/gpu/shaders/*.comp, whose comments state it), so every stage of the GPU must match it
// exactly; it is also a CPU engine of its own. No OpenCV: this library is used by the standalone benchmark.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace rutd::gpu {

// An 8-bit grey image the caller owns; stride in bytes.
struct ImageView {
  const std::uint8_t* data = nullptr;
  int width = 0, height = 0;
  std::size_t stride = 0;
  std::uint8_t at(int x, int y) const {
    return data[static_cast<std::size_t>(y) * stride + static_cast<std::size_t>(x)];
  }
};

// Disparities searched: min_disparity .. min_disparity + num_disparities - 1, px.
struct SgmBand {
  int min_disparity = 0;
  int num_disparities = 64;
};

struct SgmConfig {
  int paths = 8;        // 2 (horizontal), 4 (+ vertical) or 8 (+ diagonals)
  int p1 = 10;          // penalty of a 1 px disparity step between neighbours along a path (census bits)
  int p2 = 120;         // penalty of larger steps; p1 < p2 <= kMaxP2
  int uniqueness = 10;  // percent margin the best sum must keep over disparities more than 1 px away, 0..99
  int lr_max_diff = 1;  // px tolerance of the left-right check; < 0: no check
  bool median = true;   // 3x3 median after the check
  // Rows (the two horizontal directions) walked in segments of this many px, each path started afresh
  // segment_run_in px before the segment's first pixel, so that a device walks a row's segments in
  // parallel: chains of at most segment + segment_run_in steps instead of the width, for strips, whose
  // few long rows bound the aggregation by the latency of one step. The run-in lets the restarted path
  // forget its start (path costs are renormalised every step). 0: whole rows (the default).
  int segment = 0;
  int segment_run_in = 64;
};

constexpr int kMaxDisparities = 512;  // shared-memory size of aggregate.comp and wta.comp
constexpr int kMaxP2 = 191;           // keeps a path cost L <= 64 + P2 within a byte (aggregate.comp)
constexpr int kSubpixelScale = 64;    // fixed-point disparities are in 1/64 px

// Empty when `band`/`params` can be matched on width x height images, else what is wrong.
std::string check_sgm_input(int width, int height, SgmBand band, const SgmConfig& params);

// Every stage's output, row-major, width * height pixels (times disparities for the sums).
struct SgmStages {
  int width = 0, height = 0;
  SgmBand band;
  std::vector<std::uint32_t> census_left, census_right;  // two words per pixel: bits 0..31, 32..61
  std::vector<std::uint16_t> sums;                       // [y][x][d], summed path costs
  std::vector<std::int32_t> disparity_left;              // 1/64 px after WTA, uniqueness, sub-pixel; -1 invalid
  std::vector<std::int32_t> disparity_right;             // whole px, right view; -1 none
  std::vector<float> disparity;                          // px after left-right check and median, NaN invalid
  // With DIC (dic.hpp): both images' B-spline coefficients and the refined disparity (px, NaN invalid).
  std::vector<float> spline_left, spline_right, refined;
  // From raw images (VulkanSgm::compute_stages): the strips rectified on the device, 8-bit.
  std::vector<std::uint8_t> rectified_left, rectified_right;
};

// The reference stages, each from the previous one's output in `st` (census from the images). Allocates
// `st`'s vectors on the first call for a size, then reuses them. Inputs must pass check_sgm_input.
void census_reference(const ImageView& image, std::vector<std::uint32_t>& out);
void aggregate_reference(SgmStages& st, const SgmConfig& params);
void wta_reference(SgmStages& st, const SgmConfig& params);
void lr_median_reference(SgmStages& st, const SgmConfig& params);

// All stages.
void sgm_reference(const ImageView& left, const ImageView& right, SgmBand band, const SgmConfig& params, SgmStages& st);

}  // namespace rutd::gpu
