#include "pipeline/dic_refine.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace rutd {
namespace {

constexpr int kPad = 2;  // coefficient margin: the cubic kernel reads pixels i-1 .. i+2
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr double kWarmStartAgreementPx = 0.75;

// Cubic B-spline interpolation coefficients of one row (Unser's recursive prefilter, mirror boundary),
// written to out[kPad .. kPad + n - 1] with mirrored margins. n >= 4.
void prefilter_row(const std::uint8_t* in, int n, float* out, double* tmp) {
  const double z = std::sqrt(3.0) - 2.0;
  for (int k = 0; k < n; ++k) tmp[k] = 6.0 * in[k];
  // Causal initial value: the mirrored sum truncated where z^k < 1e-10 (|z| ~ 0.27: 18 terms).
  const int horizon = std::min(n, 18);
  double sum = tmp[0];
  double zk = z;
  for (int k = 1; k < horizon; ++k, zk *= z) sum += zk * tmp[k];
  tmp[0] = sum;
  for (int k = 1; k < n; ++k) tmp[k] += z * tmp[k - 1];
  tmp[n - 1] = (z / (z * z - 1.0)) * (tmp[n - 1] + z * tmp[n - 2]);
  for (int k = n - 2; k >= 0; --k) tmp[k] = z * (tmp[k + 1] - tmp[k]);
  float* c = out + kPad;
  for (int k = 0; k < n; ++k) c[k] = static_cast<float>(tmp[k]);
  c[-1] = c[1];
  c[-2] = c[2];
  c[n] = c[n - 2];
  c[n + 1] = c[n - 3];
}

void prepare_splines(const cv::Mat& left, const cv::Mat& right, DicWorkspace& ws) {
  const int n = left.cols;
  ws.left_coeff.create(left.rows, n + 2 * kPad, CV_32FC1);
  ws.right_coeff.create(left.rows, n + 2 * kPad, CV_32FC1);
  ws.left_dx.create(left.rows, n, CV_32FC1);
  ws.row_buffer.resize(static_cast<std::size_t>(n));
  for (int r = 0; r < left.rows; ++r) {
    prefilter_row(left.ptr<std::uint8_t>(r), n, ws.left_coeff.ptr<float>(r), ws.row_buffer.data());
    prefilter_row(right.ptr<std::uint8_t>(r), n, ws.right_coeff.ptr<float>(r), ws.row_buffer.data());
    // Derivative of the interpolant at the knots: (c[k+1] - c[k-1]) / 2.
    const float* c = ws.left_coeff.ptr<float>(r) + kPad;
    float* dx = ws.left_dx.ptr<float>(r);
    for (int k = 0; k < n; ++k) dx[k] = 0.5f * (c[k + 1] - c[k - 1]);
  }
}

struct Window {
  int x0, x1, y0, y1;  // inclusive, clipped to the strip
  int size() const { return (x1 - x0 + 1) * (y1 - y0 + 1); }
};

// The reference (left) side of one window: mean-free intensities, steepest-descent images and the
// inverse Gauss-Newton Hessian, constant over the iterations (the point of the inverse-compositional
// form). Returns false for too little texture or a singular Hessian.
struct Reference {
  double norm = 0.0;  // sqrt(sum f^2), f mean-free
  double h_inv[3][3] = {};
};

bool invert_symmetric3(const double h[3][3], double inv[3][3]) {
  const double c00 = h[1][1] * h[2][2] - h[1][2] * h[2][1];
  const double c01 = h[1][2] * h[2][0] - h[1][0] * h[2][2];
  const double c02 = h[1][0] * h[2][1] - h[1][1] * h[2][0];
  const double det = h[0][0] * c00 + h[0][1] * c01 + h[0][2] * c02;
  if (!(det > 1e-12 * h[0][0] * h[1][1] * h[2][2])) return false;
  const double s = 1.0 / det;
  inv[0][0] = c00 * s;
  inv[0][1] = inv[1][0] = c01 * s;
  inv[0][2] = inv[2][0] = c02 * s;
  inv[1][1] = (h[0][0] * h[2][2] - h[0][2] * h[2][0]) * s;
  inv[1][2] = inv[2][1] = (h[0][2] * h[1][0] - h[0][0] * h[1][2]) * s;
  inv[2][2] = (h[0][0] * h[1][1] - h[0][1] * h[1][0]) * s;
  return true;
}

bool prepare_reference(const cv::Mat& left, const cv::Mat& left_dx, int x, int y, const Window& w, const DicConfig& p,
                       DicScratch& ws, Reference& ref) {
  double sum = 0.0;
  int i = 0;
  for (int yy = w.y0; yy <= w.y1; ++yy) {
    const std::uint8_t* f = left.ptr<std::uint8_t>(yy);
    const float* fx = left_dx.ptr<float>(yy);
    const float eta = static_cast<float>(yy - y);
    for (int xx = w.x0; xx <= w.x1; ++xx, ++i) {
      ws.f[i] = f[xx];
      sum += f[xx];
      ws.sd_x[i] = fx[xx];
      ws.sd_xi[i] = fx[xx] * static_cast<float>(xx - x);
      ws.sd_eta[i] = fx[xx] * eta;
    }
  }
  const int n = i;
  const float mean = static_cast<float>(sum / n);
  double f2 = 0.0;
  double h[3][3] = {};
  for (i = 0; i < n; ++i) {
    ws.f[i] -= mean;
    f2 += static_cast<double>(ws.f[i]) * ws.f[i];
    const double s0 = ws.sd_x[i], s1 = ws.sd_xi[i], s2 = ws.sd_eta[i];
    h[0][0] += s0 * s0;
    h[0][1] += s0 * s1;
    h[0][2] += s0 * s2;
    h[1][1] += s1 * s1;
    h[1][2] += s1 * s2;
    h[2][2] += s2 * s2;
  }
  if (h[0][0] < p.min_gradient * p.min_gradient * n || f2 <= 0.0) return false;
  ref.norm = std::sqrt(f2);
  if (!p.first_order) {
    ref.h_inv[0][0] = 1.0 / h[0][0];
    return true;
  }
  h[1][0] = h[0][1];
  h[2][0] = h[0][2];
  h[2][1] = h[1][2];
  return invert_symmetric3(h, ref.h_inv);
}

// The warp x_right = x + c + a * xi + b * eta (a = 1 + ux, b = uy, c = u).
struct Warp {
  double a = 1.0, b = 0.0, c = 0.0;
};

// Samples the right strip under the warp into ws.g; false when the window leaves the strip. Positions,
// weights and sums run in separate loops over ws.pos / ws.t so the compiler vectorises all but the
// coefficient gather.
bool sample_target(const cv::Mat& right_coeff, int x, int y, const Window& w, const Warp& wp, int cols,
                   DicScratch& ws) {
  const float a = static_cast<float>(wp.a);
  const float last = static_cast<float>(cols - 1);
  const int width = w.x1 - w.x0 + 1;
  float* pos = ws.pos.data();
  int* index = ws.index.data();
  float* c0 = ws.taps[0].data();
  float* c1 = ws.taps[1].data();
  float* c2 = ws.taps[2].data();
  float* c3 = ws.taps[3].data();
  float* g = ws.g.data();
  for (int yy = w.y0; yy <= w.y1; ++yy, g += width) {
    const float* c = right_coeff.ptr<float>(yy) + kPad;
    const float start = static_cast<float>(x + wp.c + wp.b * (yy - y)) + a * static_cast<float>(w.x0 - x);
    if (!(start >= 0.0f && start + a * static_cast<float>(width - 1) <= last)) return false;  // a > 0
    for (int j = 0; j < width; ++j) {
      pos[j] = start + a * static_cast<float>(j);
      index[j] = static_cast<int>(pos[j]);
      pos[j] -= static_cast<float>(index[j]);
    }
    for (int j = 0; j < width; ++j) {
      const float* cj = c + index[j];
      c0[j] = cj[-1];
      c1[j] = cj[0];
      c2[j] = cj[1];
      c3[j] = cj[2];
    }
    for (int j = 0; j < width; ++j) {
      const float t = pos[j];
      const float t2 = t * t;
      const float t3 = t2 * t;
      const float s = 1.0f - t;
      g[j] = (s * s * s * c0[j] + (3.0f * t3 - 6.0f * t2 + 4.0f) * c1[j] +
              (-3.0f * t3 + 3.0f * t2 + 3.0f * t + 1.0f) * c2[j] + t3 * c3[j]) *
             (1.0f / 6.0f);
    }
  }
  return true;
}

struct PixelResult {
  float disparity = kNaN;
  int iterations = 0;
  Warp warp;  // the converged warp, a warm start for the next pixel of the row
};

// Inverse-compositional Gauss-Newton on the ZNSSD criterion (Pan et al., 2013) from disparity d0.
// `start` is the warp to begin from (the previous pixel's, moved here, or the engine's shift).
bool refine_pixel(const cv::Mat& left, const cv::Mat& right_coeff, const cv::Mat& left_dx, int x, int y, float d0,
                  const Warp& start, const DicConfig& p, DicScratch& ws, PixelResult& out) {
  const int h = p.half_window;
  const int hh = p.half_height > 0 ? p.half_height : h;
  const Window w{std::max(0, x - h), std::min(left.cols - 1, x + h), std::max(0, y - hh),
                 std::min(left.rows - 1, y + hh)};
  const int n = w.size();
  Reference ref;
  if (!prepare_reference(left, left_dx, x, y, w, p, ws, ref)) return false;
  Warp wp = start;
  double zncc = -1.0;
  for (int it = 1; it <= p.max_iterations; ++it) {
    if (!sample_target(right_coeff, x, y, w, wp, left.cols, ws)) return false;
    double g_sum = 0.0;
    for (int i = 0; i < n; ++i) g_sum += ws.g[i];
    const float g_mean = static_cast<float>(g_sum / n);
    double g2 = 0.0;
    for (int i = 0; i < n; ++i) {
      ws.g[i] -= g_mean;
      g2 += static_cast<double>(ws.g[i]) * ws.g[i];
    }
    if (!(g2 > 1e-6)) return false;
    const float k = static_cast<float>(ref.norm / std::sqrt(g2));
    double b0 = 0.0, b1 = 0.0, b2 = 0.0, r2 = 0.0;
    for (int i = 0; i < n; ++i) {
      const float r = ws.f[i] - k * ws.g[i];
      b0 += ws.sd_x[i] * r;
      b1 += ws.sd_xi[i] * r;
      b2 += ws.sd_eta[i] * r;
      r2 += static_cast<double>(r) * r;
    }
    zncc = 1.0 - 0.5 * r2 / (ref.norm * ref.norm);
    double du = 0.0, dux = 0.0, duy = 0.0;
    if (p.first_order) {
      du = -(ref.h_inv[0][0] * b0 + ref.h_inv[0][1] * b1 + ref.h_inv[0][2] * b2);
      dux = -(ref.h_inv[1][0] * b0 + ref.h_inv[1][1] * b1 + ref.h_inv[1][2] * b2);
      duy = -(ref.h_inv[2][0] * b0 + ref.h_inv[2][1] * b1 + ref.h_inv[2][2] * b2);
    } else {
      du = -ref.h_inv[0][0] * b0;
    }
    // W <- W o W(dp)^-1 ; W(dp)^-1: xi' = (xi - duy * eta - du) / (1 + dux).
    const double ai = 1.0 / (1.0 + dux);
    wp = Warp{wp.a * ai, wp.b - wp.a * duy * ai, wp.c - wp.a * du * ai};
    if (!std::isfinite(wp.c) || std::abs(wp.a - 1.0) > p.max_gradient || std::abs(wp.b) > p.max_gradient ||
        std::abs(-wp.c - d0) > p.max_shift_px) {
      return false;
    }
    if (std::sqrt(du * du + h * h * dux * dux + hh * hh * duy * duy) < p.tolerance_px) {
      out.disparity = static_cast<float>(-wp.c);
      out.iterations = it;
      out.warp = wp;
      if (p.max_sigma_px > 0.0) {
        const int unknowns = p.first_order ? 3 : 1;
        if (n <= unknowns) return false;
        // r2 is the residual of this iteration's warp, which the converged update no longer changes.
        const double variance = r2 / (n - unknowns) * ref.h_inv[0][0];
        if (!(variance <= p.max_sigma_px * p.max_sigma_px)) return false;
      }
      return zncc >= p.min_zncc;
    }
  }
  return false;
}

// Refines rows [row_begin, row_end) of the grid with one thread's scratch.
void refine_rows(const cv::Mat& left_strip, const DicWorkspace& ws, cv::Mat& disparity, const DicConfig& params,
                 int row_begin, int row_end, DicScratch& scratch) {
  const int row_step = params.row_step > 0 ? params.row_step : params.step;
  for (int y = row_begin; y < row_end; ++y) {
    float* d = disparity.ptr<float>(y);
    if (y % row_step != 0) {
      std::fill(d, d + disparity.cols, kNaN);
      continue;
    }
    bool have_previous = false;
    Warp previous;  // converged warp of pixel x - step, moved to x
    for (int x = 0; x < disparity.cols; ++x) {
      if (x % params.step != 0) {
        d[x] = kNaN;
        continue;
      }
      const float d0 = d[x];
      if (!std::isfinite(d0)) {
        have_previous = false;
        continue;
      }
      // Warm start from the neighbour when it agrees with the engine: fewer iterations, same optimum.
      Warp start{1.0, 0.0, -static_cast<double>(d0)};
      if (have_previous && std::abs(-previous.c - d0) < kWarmStartAgreementPx) start = previous;
      PixelResult result;
      have_previous = refine_pixel(left_strip, ws.right_coeff, ws.left_dx, x, y, d0, start, params, scratch, result);
      if (have_previous) {
        d[x] = result.disparity;
        ++scratch.stats.refined;
        scratch.iterations += result.iterations;
        previous = result.warp;
        previous.c += (previous.a - 1.0) * params.step;
      } else {
        d[x] = kNaN;
        ++scratch.stats.rejected;
      }
    }
  }
}

}  // namespace

DicStats refine_disparity_dic(const cv::Mat& left_strip, const cv::Mat& right_strip, cv::Mat& disparity,
                              const DicConfig& params, DicWorkspace& ws) {
  CV_Assert(left_strip.type() == CV_8UC1 && right_strip.type() == CV_8UC1 && disparity.type() == CV_32FC1);
  CV_Assert(left_strip.size() == right_strip.size() && disparity.size() == left_strip.size());
  CV_Assert(left_strip.cols >= 4 && params.half_window >= 1 && params.step >= 1 && params.row_step >= 0);
  prepare_splines(left_strip, right_strip, ws);
  const int row_begin = std::clamp(params.row_begin, 0, disparity.rows);
  const int row_end = params.row_end < 0 ? disparity.rows : std::clamp(params.row_end, row_begin, disparity.rows);
  disparity.rowRange(0, row_begin).setTo(kNaN);
  disparity.rowRange(row_end, disparity.rows).setTo(kNaN);

  const int stripes = params.parallel ? std::max(1, std::min(cv::getNumThreads(), row_end - row_begin)) : 1;
  if (ws.scratch.size() < static_cast<std::size_t>(stripes)) ws.scratch.resize(static_cast<std::size_t>(stripes));
  const int half_height = params.half_height > 0 ? params.half_height : params.half_window;
  const auto window = static_cast<std::size_t>((2 * params.half_window + 1) * (2 * half_height + 1));
  for (int s = 0; s < stripes; ++s) {
    DicScratch& sc = ws.scratch[static_cast<std::size_t>(s)];
    for (auto* v :
         {&sc.f, &sc.sd_x, &sc.sd_xi, &sc.sd_eta, &sc.g, &sc.pos, &sc.taps[0], &sc.taps[1], &sc.taps[2], &sc.taps[3]}) {
      if (v->size() < window) v->resize(window);
    }
    if (sc.index.size() < window) sc.index.resize(window);
    sc.stats = DicStats{};
    sc.iterations = 0;
  }
  // Interleaved rows per stripe would share cache lines of `disparity`; contiguous blocks do not.
  const auto run = [&](const cv::Range& range) {
    for (int s = range.start; s < range.end; ++s) {
      const int a = row_begin + (row_end - row_begin) * s / stripes;
      const int b = row_begin + (row_end - row_begin) * (s + 1) / stripes;
      refine_rows(left_strip, ws, disparity, params, a, b, ws.scratch[static_cast<std::size_t>(s)]);
    }
  };
  if (stripes > 1) {
    cv::parallel_for_(cv::Range(0, stripes), run, stripes);
  } else {
    run(cv::Range(0, 1));
  }
  DicStats stats;
  long iterations = 0;
  for (int s = 0; s < stripes; ++s) {
    const DicScratch& sc = ws.scratch[static_cast<std::size_t>(s)];
    stats.refined += sc.stats.refined;
    stats.rejected += sc.stats.rejected;
    iterations += sc.iterations;
  }
  stats.mean_iterations = stats.refined > 0 ? static_cast<double>(iterations) / stats.refined : 0.0;
  return stats;
}

}  // namespace rutd
