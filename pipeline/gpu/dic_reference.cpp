#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "gpu/dic.hpp"

// Compiled with -ffp-contract=off (CMakeLists.txt): no fused multiply-adds, as the shader's `precise`.
namespace rutd::gpu {
namespace {

constexpr float kZ = -0.26794919243112270f;   // sqrt(3) - 2
constexpr float kGain = 1.7320508075688772f;  // sqrt(3)

int mirror(int k, int n) { return k < 0 ? -k : k > n - 1 ? 2 * (n - 1) - k : k; }

}  // namespace

std::string check_dic_kernel_config(const DicKernelConfig& p) {
  if (p.half_window < 1 || p.half_window > 15 || p.half_height < 1 || p.half_height > 15)
    return "DIC half window and height must be 1..15";
  if (p.step < 1 || p.row_step < 1) return "DIC steps must be >= 1";
  if (p.column_block_rows < 0) return "DIC column block rows must be >= 0";
  if (p.max_iterations < 1) return "DIC needs at least one iteration";
  return {};
}

void bspline_reference(const ImageView& im, std::vector<float>& coef) {
  // The prefilter's impulse response sqrt(3) z^|j|, 18 taps each side, on the mirrored rows (bspline.comp).
  const int n = im.width;
  const auto mirrored = [n](int k) {
    if (n == 1) return 0;
    const int period = 2 * (n - 1);
    int m = k % period;
    if (m < 0) m += period;
    return m < n ? m : period - m;
  };
  coef.resize(static_cast<std::size_t>(n) * static_cast<std::size_t>(im.height));
  for (int y = 0; y < im.height; ++y) {
    for (int x = 0; x < n; ++x) {
      float w = kGain;
      float sum = w * static_cast<float>(im.at(x, y));
      for (int j = 1; j <= 18; ++j) {
        w = w * kZ;
        sum = sum + w * (static_cast<float>(im.at(mirrored(x - j), y)) + static_cast<float>(im.at(mirrored(x + j), y)));
      }
      coef[static_cast<std::size_t>(y) * static_cast<std::size_t>(n) + static_cast<std::size_t>(x)] = sum;
    }
  }
}

ColumnBlocks::ColumnBlocks(const DicKernelConfig& p, int height) {
  row_begin = std::clamp(p.row_begin, 0, height);
  rows = std::clamp(p.row_end, row_begin, height) - row_begin;
  count = rows == 0 ? 0 : p.column_block_rows > 0 ? std::max(1, rows / p.column_block_rows) : 1;
}

int ColumnBlocks::begin(int b) const {
  return row_begin + static_cast<int>(static_cast<long>(rows) * b / std::max(count, 1));
}

int ColumnBlocks::half_height() const {
  int hh = 1;
  for (int b = 0; b < count; ++b) {
    const int y0 = begin(b), y1 = begin(b + 1) - 1, yc = centre(y0, y1);
    hh = std::max({hh, yc - y0, y1 - yc});
  }
  return hh;
}

namespace {

// The images one refinement reads.
struct Images {
  const ImageView& left;
  const std::vector<float>& coef_l;
  const std::vector<float>& coef_r;
  int w;
  std::size_t at(int x, int y) const {
    return static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x);
  }
  float fx(int cx, int r) const { return 0.5f * (coef_l[at(mirror(cx + 1, w), r)] - coef_l[at(mirror(cx - 1, w), r)]); }
  // The right spline at position X of row r, minus 128.
  float sample_right(int r, float X) const {
    const int k = std::min(static_cast<int>(std::floor(X)), w - 1);
    const float t = X - static_cast<float>(k);
    const float cm = coef_r[at(mirror(k - 1, w), r)], c0 = coef_r[at(k, r)], c1 = coef_r[at(mirror(k + 1, w), r)],
                c2 = coef_r[at(mirror(k + 2, w), r)];
    const float p0 = (cm + (4.0f * c0 + c1)) * (1.0f / 6.0f) - 128.0f;
    const float p1 = 0.5f * (c1 - cm);
    const float p2 = 0.5f * (cm - 2.0f * c0 + c1);
    const float p3 = (3.0f * (c0 - c1) + (c2 - cm)) * (1.0f / 6.0f);
    return p0 + t * (p1 + t * (p2 + t * p3));
  }
};

// One window, columns [x0, x1] and rows [y0, y1] around (x, y), from disparity d0: true when it
// converged and passed every test, with the warp x_right = x + c + a xi + b eta in (b, c). hh: the half
// height the convergence test weighs the row slope with.
bool refine_window(const Images& im, int x, int y, int x0, int x1, int y0, int y1, int hh, float d0,
                   const DicKernelConfig& p, float& b_out, float& c_out) {
  const auto n = static_cast<float>((x1 - x0 + 1) * (y1 - y0 + 1));
  float f_sum = 0, ff = 0;
  float hm[6] = {};  // H00 H01 H02 H11 H12 H22
  float sd_sum[3] = {}, sd_fs[3] = {};
  for (int r = y0; r <= y1; ++r) {
    const auto eta = static_cast<float>(r - y);
    for (int cx = x0; cx <= x1; ++cx) {
      const auto xi = static_cast<float>(cx - x);
      const float f = static_cast<float>(im.left.at(cx, r)) - 128.0f;
      const float fx = im.fx(cx, r);
      f_sum += f;
      ff += f * f;
      const float wgt = fx * fx;
      hm[0] += wgt;
      hm[1] += wgt * xi;
      hm[2] += wgt * eta;
      hm[3] += wgt * xi * xi;
      hm[4] += wgt * xi * eta;
      hm[5] += wgt * eta * eta;
      sd_sum[0] += fx;
      sd_sum[1] += fx * xi;
      sd_sum[2] += fx * eta;
      sd_fs[0] += fx * f;
      sd_fs[1] += fx * f * xi;
      sd_fs[2] += fx * f * eta;
    }
  }
  const float f_mean = f_sum / n;
  const float f2 = ff - f_sum * f_mean;
  if (hm[0] < p.min_gradient * p.min_gradient * n || !(f2 > 0.0f)) return false;
  const float norm = std::sqrt(f2);
  float sd_f[3];
  for (int k = 0; k < 3; ++k) sd_f[k] = sd_fs[k] - f_mean * sd_sum[k];
  float inv[6] = {};
  if (p.first_order) {
    const float c00 = hm[3] * hm[5] - hm[4] * hm[4];
    const float c01 = hm[4] * hm[2] - hm[1] * hm[5];
    const float c02 = hm[1] * hm[4] - hm[3] * hm[2];
    const float det = hm[0] * c00 + hm[1] * c01 + hm[2] * c02;
    if (!(det > 1e-12f * hm[0] * hm[3] * hm[5])) return false;
    const float s = 1.0f / det;
    inv[0] = c00 * s;
    inv[1] = c01 * s;
    inv[2] = c02 * s;
    inv[3] = (hm[0] * hm[5] - hm[2] * hm[2]) * s;
    inv[4] = (hm[2] * hm[1] - hm[0] * hm[4]) * s;
    inv[5] = (hm[0] * hm[3] - hm[1] * hm[1]) * s;
  } else {
    inv[0] = 1.0f / hm[0];
  }
  float a = 1.0f, b = 0.0f, c = -d0;
  const auto last = static_cast<float>(im.w - 1);
  for (int it = 1; it <= p.max_iterations; ++it) {
    for (int corner = 0; corner < 4; ++corner) {
      const float X = static_cast<float>(x) + c + a * static_cast<float>((corner & 1) == 0 ? x0 - x : x1 - x) +
                      b * static_cast<float>((corner & 2) == 0 ? y0 - y : y1 - y);
      if (!(X >= 0.0f && X <= last)) return false;
    }
    float g_sum = 0, gg = 0, fg = 0, sd_g[3] = {};
    for (int r = y0; r <= y1; ++r) {
      const auto eta = static_cast<float>(r - y);
      for (int cx = x0; cx <= x1; ++cx) {
        const auto xi = static_cast<float>(cx - x);
        const float X = static_cast<float>(x) + c + a * xi + b * eta;
        const float g = im.sample_right(r, X);
        const float f = static_cast<float>(im.left.at(cx, r)) - 128.0f;
        const float fx = im.fx(cx, r);
        g_sum += g;
        gg += g * g;
        fg += f * g;
        sd_g[0] += fx * g;
        sd_g[1] += fx * g * xi;
        sd_g[2] += fx * g * eta;
      }
    }
    const float g_mean = g_sum / n;
    const float g2 = gg - g_sum * g_mean;
    if (!(g2 > 1e-6f)) return false;
    const float fgc = fg - f_sum * g_mean;
    const float inv_g_norm = 1.0f / std::sqrt(g2);
    const float kk = norm * inv_g_norm;
    float bv[3];
    for (int k = 0; k < 3; ++k) bv[k] = sd_f[k] - kk * (sd_g[k] - g_mean * sd_sum[k]);
    const float zncc = fgc * inv_g_norm / norm;
    const float du = -(inv[0] * bv[0] + inv[1] * bv[1] + inv[2] * bv[2]);
    const float dux = -(inv[1] * bv[0] + inv[3] * bv[1] + inv[4] * bv[2]);
    const float duy = -(inv[2] * bv[0] + inv[4] * bv[1] + inv[5] * bv[2]);
    const float ai = 1.0f / (1.0f + dux);
    const float na = a * ai, nb = b - a * duy * ai, nc = c - a * du * ai;
    a = na;
    b = nb;
    c = nc;
    if (!std::isfinite(c) || std::abs(a - 1.0f) > p.max_gradient || std::abs(b) > p.max_gradient ||
        std::abs(-c - d0) > p.max_shift_px)
      return false;
    const float corner2 = du * du + static_cast<float>(p.half_window * p.half_window) * dux * dux +
                          static_cast<float>(hh * hh) * duy * duy;
    if (p.tolerance_px > 0.0f && corner2 < p.tolerance_px * p.tolerance_px) {
      bool ok = zncc >= p.min_zncc;
      if (p.max_sigma_px > 0.0f) {
        const float unknowns = p.first_order ? 3.0f : 1.0f;
        const float r2 = std::max(0.0f, 2.0f * f2 * (1.0f - zncc));
        ok = ok && n > unknowns && r2 / (n - unknowns) * inv[0] <= p.max_sigma_px * p.max_sigma_px;
      }
      b_out = b;
      c_out = c;
      return ok;
    }
  }
  return false;
}

// The start of the column window at x over rows [y0, y1]: the median of the valid initial disparities
// (nth_element at n / 2, as dic_refine.cpp), false when fewer than a quarter of the rows are valid.
bool column_start(const std::vector<float>& initial, int w, int x, int y0, int y1, std::vector<float>& values,
                  float& start) {
  values.clear();
  for (int y = y0; y <= y1; ++y) {
    const float d = initial[static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x)];
    if (std::isfinite(d)) values.push_back(d);
  }
  const int n = static_cast<int>(values.size());
  if (n == 0 || 4 * n < y1 - y0 + 1) return false;
  const auto mid = values.begin() + n / 2;
  std::nth_element(values.begin(), mid, values.end());
  start = *mid;
  return true;
}

}  // namespace

void dic_reference(const ImageView& left, const std::vector<float>& coef_l, const std::vector<float>& coef_r,
                   const std::vector<float>& initial, const DicKernelConfig& p, std::vector<float>& refined) {
  const int w = left.width, h = left.height;
  refined.assign(initial.size(), std::numeric_limits<float>::quiet_NaN());
  if (w < 4) return;
  const Images im{left, coef_l, coef_r, w};
  float b = 0, c = 0;
  if (p.column_windows) {
    const ColumnBlocks blocks(p, h);
    const int hh = blocks.half_height();
    std::vector<float> values;
    for (int k = 0; k < blocks.count; ++k) {
      const int y0 = blocks.begin(k), y1 = blocks.begin(k + 1) - 1, yc = ColumnBlocks::centre(y0, y1);
      for (int x = 0; x < w; ++x) {
        float d0 = 0;
        if (!column_start(initial, w, x, y0, y1, values, d0)) continue;
        const int x0 = std::max(0, x - p.half_window), x1 = std::min(w - 1, x + p.half_window);
        if (!refine_window(im, x, yc, x0, x1, y0, y1, hh, d0, p, b, c)) continue;
        for (int y = y0; y <= y1; ++y) refined[im.at(x, y)] = -(c + b * static_cast<float>(y - yc));
      }
    }
    return;
  }
  for (int y = std::max(0, p.row_begin); y < std::min(h, p.row_end); ++y) {
    if (y % p.row_step != 0) continue;
    for (int x = 0; x < w; x += p.step) {
      const float d0 = initial[im.at(x, y)];
      if (std::isnan(d0)) continue;
      const int x0 = std::max(0, x - p.half_window), x1 = std::min(w - 1, x + p.half_window);
      const int y0 = std::max(0, y - p.half_height), y1 = std::min(h - 1, y + p.half_height);
      if (refine_window(im, x, y, x0, x1, y0, y1, p.half_height, d0, p, b, c)) refined[im.at(x, y)] = -c;
    }
  }
}

}  // namespace rutd::gpu
