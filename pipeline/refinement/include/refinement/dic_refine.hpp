#pragma once
// Sub-pixel disparity refinement by digital image correlation (DIC).
//
// Why: the sub-pixel disparities of block matchers and SGM are biased toward whole pixels ("pixel
// locking", tenths of a pixel), which at rut depths means millimetres. DIC removes that bias: for each
// pixel, the window around it in the left strip is matched in the right strip by inverse-compositional
// Gauss-Newton minimisation of the zero-normalised SSD (invariant to gain and offset between the
// cameras) over a first-order horizontal warp
//     x_right = x + u + ux * xi + uy * eta      (xi, eta: offsets from the pixel within the window)
// so the disparity is d = -u and its gradients -ux, -uy absorb sloped terrain (rut walls) that would
// otherwise distort the window match. The right strip is sampled with a cubic B-spline interpolant
// along rows (rows stay integer: the strips are rectified), which unlike bilinear interpolation does not
// itself lock to whole pixels.
#include <vector>

#include <opencv2/core.hpp>

namespace rutd {

struct DicConfig {
  int half_window = 5;         // px, 1..15; the window is (2h+1) wide and (2 half_height+1) tall, clipped to the strip
  int half_height = 0;         // px; 0: same as half_window. Taller windows cost no lateral resolution (the
                               // cross-section averages along rows anyway) and tame low-texture noise
  int max_iterations = 20;     // a pixel that has not converged by then is rejected
  double tolerance_px = 1e-3;  // converged when the warp update moves the window's corners less, px
  int step = 1;                // refine pixels with x % step == 0 and row % row_step == 0; others become NaN
  int row_step = 0;            // 0: same as step
  int row_begin = 0;           // refine rows [row_begin, row_end) only; others become NaN
  int row_end = -1;            // -1: to the last row
  bool parallel = true;        // split rows across OpenCV's worker threads
  bool first_order = true;     // fit ux, uy (disparity gradients); false: pure shift
  double max_shift_px = 2.0;   // reject when |refined - initial disparity| exceeds this, px
  double max_gradient = 0.5;   // reject when |ux| or |uy| exceed this, px/px (warp degenerates)
  double min_gradient = 1.0;   // reject windows whose RMS horizontal intensity gradient is lower, grey/px
  double min_zncc = 0.8;       // reject when the final zero-normalised cross-correlation is lower
  // Reject when the estimated standard deviation of the refined disparity exceeds this, px; <= 0: off.
  // The estimate is the Gauss-Newton covariance: residual variance per sample times the shift term of
  // the inverse Hessian, i.e. the precision the window's texture and noise actually allow.
  double max_sigma_px = 0.0;
  // The strips' noise, standard deviation in grey levels (8-bit strips); <= 0: unknown, min_zncc alone
  // judges. Known, a window whose correlation is under min_zncc is still accepted where that is what the
  // noise leaves of its texture: a correct match's residual is the two views' noise, sum (f' - k g')^2 =
  // 2 sum f'^2 (1 - zncc) ~ 2 n sigma^2, so it is kept when (1 - zncc) sum f'^2 <= noise_tolerance n sigma^2
  // and zncc >= min_noise_zncc (where the noise is nearly all of the window, a false match fits as well).
  // Low-texture ground (snow) under gain correlates at 0.4-0.7 where it matches; textured ground, whose
  // correct matches correlate near 1, keeps min_zncc's bound. This CPU refinement only: the GPU engine's
  // DIC has no such field (StereoMeasurer::read_low_texture calls this one for any engine).
  double noise_grey = 0.0;
  double noise_tolerance = 1.5;
  double min_noise_zncc = 0.3;
  // Sample with 8-lane AVX2 vectors on x86 CPUs that have them (chosen at run time); the results are
  // bit for bit those of the 4-lane path. false: always the 4-lane path (tests compare the two).
  bool allow_avx2 = true;
  // Strip mode: one window per column, spanning rows [row_begin, row_end) whole, instead of one per
  // pixel. The cross-section averages along rows anyway, and the first-order warp already fits the
  // disparity's slope down the column, so a column needs one solve where per-pixel windows need one per
  // row (measured: the same depths on rendered ruts, a quarter of the time). Every row of the column
  // gets the fitted d(y) = -(u + uy (y - yc)), yc the middle row; the solve starts from the median of
  // the column's valid initial disparities (a column with fewer than a quarter valid is rejected).
  // half_height, step and row_step are ignored; half_window still sets the width.
  bool column_windows = false;
  // With column_windows: rows [row_begin, row_end) split into blocks of about this many rows (at least
  // this many), one window per column and block, each block's rows fitted by its own warp (full frame,
  // surface maps: every pixel gets a refined disparity at a twentieth of per-pixel windows' cost).
  // 0: one block.
  int column_block_rows = 0;
};

struct DicStats {
  int refined = 0;             // pixels with a refined disparity
  int rejected = 0;            // pixels with an initial disparity that were set NaN (texture, divergence,
                               // bound, correlation, window leaving the right strip)
  double mean_iterations = 0;  // Gauss-Newton iterations per refined pixel
};

// The buffers of one thread (one row stripe).
struct DicScratch {
  std::vector<float> row_buffer;   // prefilter scratch: spline coefficients of four rows, interleaved
  std::vector<float> column_sums;  // per grid row: sums over the window's rows of each strip column
  std::vector<float> target_sums;  // the same for the right strip under the last sampled warp
  std::vector<float> starts;       // per window row: sample position of the window's first column
  DicStats stats;                  // of this thread's rows in the current call
  long iterations = 0;
};

// Scratch reused between frames; grows to the largest strip, window and thread count seen, then never
// allocates. One per calling thread. The tables cover only the rows the refined windows read.
struct DicWorkspace {
  cv::Mat left_ref;                  // CV_32F: left strip minus 128 (exact), zero-padded columns
  cv::Mat left_dx;                   // CV_32F: x derivative of the left interpolant at the pixels, zero-padded columns
  cv::Mat right_poly;                // CV_32F, 4 floats per pixel interval: the right interpolant's cubic, power basis
  std::vector<DicScratch> scratch;   // one per row stripe (column stripe with column_windows)
  std::vector<float> column_start;   // column_windows: initial disparity per column, NaN = none
  std::vector<float> column_values;  // column_windows: one column's valid initial disparities
};

// Refines `disparity` (CV_32FC1, size of the strips, px, NaN = invalid) in place. left/right: rectified
// CV_8UC1 strips of equal size. Valid pixels on the `step` grid are refined or rejected (NaN); pixels
// off the grid become NaN; NaN input stays NaN. Per-frame: no exceptions, no allocation in steady state.
// Not thread-safe for one workspace.
DicStats refine_disparity_dic(const cv::Mat& left_strip, const cv::Mat& right_strip, cv::Mat& disparity,
                              const DicConfig& params, DicWorkspace& ws);

}  // namespace rutd
