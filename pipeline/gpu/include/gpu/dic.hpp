#pragma once
// Sub-pixel refinement by digital image correlation as the Vulkan matcher runs it (shaders/bspline.comp,
// shaders/dic.comp), and its plain C++ reference: the DIC of pipeline/dic_refine.hpp (inverse-
// compositional Gauss-Newton on the ZNSSD, first-order warp, cubic B-spline along rows, the same
// rejections), in float, one window independent of the next (no warm start), in the order the shader
// computes. The GPU's float division and square root may differ from the CPU's by an ulp or two, so the
// two agree to far better than 1/64 px, not bit for bit. No OpenCV.
#include <vector>

#include "gpu/sgm.hpp"

namespace rutd::gpu {

// The fields of rutd::DicConfig the refinement uses, resolved (half_height and row_step given, row_end
// a row index).
struct DicKernelConfig {
  int half_window = 5;  // px, the window is 2 h + 1 columns wide, clipped to the image
  int half_height = 5;  // px, 2 hh + 1 rows
  int max_iterations = 20;
  float tolerance_px = 1e-3f;            // converged when the update moves the window's corners less
  int step = 1, row_step = 1;            // refine pixels with x % step == 0 and y % row_step == 0
  int row_begin = 0, row_end = 1 << 30;  // rows [row_begin, row_end)
  bool first_order = true;
  float max_shift_px = 2.0f;  // reject when |refined - initial| exceeds this
  float max_gradient = 0.5f;  // reject when |ux| or |uy| exceed this
  float min_gradient = 1.0f;  // reject windows with a lower RMS horizontal gradient, grey/px
  float min_zncc = 0.8f;      // reject a lower final correlation
  float max_sigma_px = 0.0f;  // reject a larger Gauss-Newton standard deviation; <= 0: off
  // Column windows (rutd::DicConfig::column_windows, the geometry of pipeline/dic_refine.cpp): rows
  // [row_begin, row_end) in ColumnBlocks, one window per column and block, half_window wide and as tall
  // as the block, centred on the block's middle row yc; it starts from the median of the column's valid
  // initial disparities in the block (the upper one of an even count; none when fewer than a quarter of
  // the block's rows are valid) and writes -(c + b (y - yc)) into every row y of the block. half_height,
  // step and row_step are ignored.
  bool column_windows = false;
  int column_block_rows = 0;  // blocks of about this many rows (at least this many); 0: one block
};

// The row blocks of column windows on an image of `height` rows, as pipeline/dic_refine.cpp splits them:
// `count` blocks of nearly equal height, block b rows [begin(b), begin(b + 1)). count is 0 when no row is
// refined.
struct ColumnBlocks {
  int row_begin = 0, rows = 0, count = 0;
  ColumnBlocks(const DicKernelConfig& p, int height);
  int begin(int b) const;
  static int centre(int y0, int y1) { return (y0 + y1) / 2; }  // middle row yc of rows [y0, y1]
  // The half height the convergence test weighs the row slope with: the largest distance from a
  // block's middle row to its ends, at least 1.
  int half_height() const;
};

// Empty when `p` is usable, else what is wrong.
std::string check_dic_kernel_config(const DicKernelConfig& p);

// Cubic B-spline coefficients of every row of `image`, row-major: the interpolation prefilter as its
// impulse response sqrt(3) z^|j| (z = sqrt(3) - 2) truncated at |j| <= 18, on the row mirrored at its ends
// (the CPU DIC's recursive filter to float rounding; in parallel on the GPU).
void bspline_reference(const ImageView& image, std::vector<float>& coefficients);

// Refines `initial` (width x height px, NaN invalid) into `refined` (resized), NaN off the grid and where
// rejected; per pixel, or per column and row block with p.column_windows. coef_left/coef_right:
// bspline_reference of the images.
void dic_reference(const ImageView& left, const std::vector<float>& coef_left, const std::vector<float>& coef_right,
                   const std::vector<float>& initial, const DicKernelConfig& p, std::vector<float>& refined);

}  // namespace rutd::gpu
