#include "refinement/dic_refine.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>

#include <opencv2/core/hal/intrin.hpp>

#if (defined(__x86_64__) || defined(__i386__)) && (defined(__GNUC__) || defined(__clang__))
#define RUTD_DIC_AVX2 1
#include <immintrin.h>
#else
#define RUTD_DIC_AVX2 0
#endif

// How the work is laid out (the maths is in the header):
// - Once per call, for the rows the windows read: the left strip (minus 128) and its interpolant's x
//   derivative as zero-padded float rows, and for the right strip the cubic of every pixel interval in
//   power form (4 floats), so one sample is one 16-byte load and a Horner step.
// - Once per grid row: for every strip column, sums over the window's rows of the products the
//   reference side needs (intensity, its square, the squared gradient with its row-offset moments ...).
//   A window's reference sums, Hessian included, are then a few dot products over its columns.
// - Per Gauss-Newton iteration: one pass over the window that samples the right strip and accumulates,
//   per window column, the five sums the ZNSSD update needs, in 4-wide float lanes (OpenCV universal
//   intrinsics: SSE2, NEON, ... or plain C++; 8-wide AVX2 where the CPU has it), reduced in double.
//   The per-column sums stay in a cache: the next pixel, warm-started from this one's last sampled
//   warp, finds the columns the two windows share already sampled, so its first iteration is nearly
//   free and a pixel costs about one full pass.
// Window columns map to SIMD lanes: lane j of a pixel x is strip column x - h + j; lanes past the
// window or outside the strip are masked out.

namespace rutd {
namespace {

using cv::v_float32x4;
using cv::v_int32x4;

constexpr int kPad = 2;         // spline coefficient margin: the cubic kernel reads pixels i-1 .. i+2
constexpr int kMaxVectors = 8;  // window of up to 32 columns: half_window <= 15
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kGrey = 128.0f;  // subtracted from the left strip: exact, and keeps float sums small
constexpr double kWarmStartAgreementPx = 0.75;

// Cubic B-spline interpolation coefficients of four rows at once, one per lane (Unser's recursive
// prefilter, mirror boundary, in float): coefficient k of the rows at c + 4 k, for k in [0, n) and the
// mirrored margins -2, -1, n, n + 1. n >= 4.
void prefilter_rows(const std::uint8_t* const in[4], int n, float* c) {
  const auto at = [c](int k) { return cv::v_load(c + 4 * k); };
  const auto set = [c](int k, const v_float32x4& v) { cv::v_store(c + 4 * k, v); };
  const float z = static_cast<float>(std::sqrt(3.0) - 2.0);
  const v_float32x4 vz = cv::v_setall_f32(z), six = cv::v_setall_f32(6.0f);
  for (int k = 0; k < n; ++k) set(k, cv::v_float32x4(in[0][k], in[1][k], in[2][k], in[3][k]) * six);
  // Causal initial value: the mirrored sum truncated where z^k < 1e-10 (|z| ~ 0.27: 18 terms).
  const int horizon = std::min(n, 18);
  v_float32x4 sum = at(0);
  float zk = z;
  for (int k = 1; k < horizon; ++k, zk *= z) sum = cv::v_muladd(cv::v_setall_f32(zk), at(k), sum);
  v_float32x4 previous = sum;
  set(0, sum);
  for (int k = 1; k < n; ++k) set(k, previous = cv::v_muladd(vz, previous, at(k)));
  const v_float32x4 tail = cv::v_setall_f32(z / (z * z - 1.0f)) * cv::v_muladd(vz, at(n - 2), at(n - 1));
  set(n - 1, previous = tail);
  for (int k = n - 2; k >= 0; --k) set(k, previous = vz * (previous - at(k)));
  set(-1, at(1));
  set(-2, at(2));
  set(n, at(n - 2));
  set(n + 1, at(n - 3));
}

#if RUTD_DIC_AVX2
bool cpu_has_avx2() {
  static const bool has = __builtin_cpu_supports("avx2");
  return has;
}
#endif

// The layout of one call.
struct Layout {
  int cols = 0;
  int h = 0, hh = 0;   // half window width and height
  int vectors = 0;     // 4-lane vectors per window row
  int table_row0 = 0;  // first strip row held in the tables
  int table_rows = 0;
  int stride = 0;     // floats per padded left row and per column-sum array; strip column X is at X + h
  bool avx2 = false;  // sample with 8-lane AVX2 vectors
};

// The middle row of a column window over rows [row_begin, row_end).
int column_centre(int row_begin, int row_end) { return (row_begin + row_end - 1) / 2; }

// Column windows: rows [row_begin, row_end) in `count` blocks of nearly equal height (one block when
// column_block_rows is 0); block b is rows [begin(b), begin(b + 1)).
struct ColumnBlocks {
  int row_begin, rows, count;
  ColumnBlocks(const DicConfig& p, int row_begin_, int row_end)
      : row_begin(row_begin_),
        rows(row_end - row_begin_),
        count(p.column_block_rows > 0 ? std::max(1, rows / p.column_block_rows) : 1) {}
  int begin(int b) const { return row_begin + static_cast<int>(static_cast<long>(rows) * b / count); }
};

Layout make_layout(const cv::Mat& strip, const DicConfig& p, int row_begin, int row_end) {
  Layout l;
  l.cols = strip.cols;
  l.h = p.half_window;
  l.vectors = (2 * l.h + 1 + 3) / 4;
  if (p.column_windows) {
    // The windows are the measured rows (in blocks): nothing outside them is read.
    const ColumnBlocks blocks(p, row_begin, row_end);
    l.hh = 1;
    for (int b = 0; b < blocks.count; ++b) {
      const int y0 = blocks.begin(b), y1 = blocks.begin(b + 1) - 1, yc = column_centre(y0, y1 + 1);
      l.hh = std::max({l.hh, yc - y0, y1 - yc});
    }
    l.table_row0 = row_begin;
    l.table_rows = row_end - row_begin;
  } else {
    l.hh = p.half_height > 0 ? p.half_height : p.half_window;
    l.table_row0 = std::max(0, row_begin - l.hh);
    l.table_rows = std::max(0, std::min(strip.rows, row_end + l.hh) - l.table_row0);
  }
  // Lane j of pixel x reads index x + j < cols + 4 vectors.
  l.stride = (l.cols + l.h + 4 * l.vectors + 3) / 4 * 4;
#if RUTD_DIC_AVX2
  l.avx2 = p.allow_avx2 && cpu_has_avx2();
#endif
  return l;
}

// Table rows [r, r + count) (strip rows table_row0 + r ...) of both strips, count <= 4: one row per lane.
void build_table_rows(const cv::Mat& left, const cv::Mat& right, int r, int count, const Layout& l, DicWorkspace& ws,
                      float* buffer) {
  const int n = l.cols;
  float* c = buffer + 4 * kPad;
  const auto at = [c](int k) { return cv::v_load(c + 4 * k); };
  const std::uint8_t* in[4];
  for (int i = 0; i < 4; ++i) in[i] = left.ptr<std::uint8_t>(l.table_row0 + r + std::min(i, count - 1));
  prefilter_rows(in, n, c);
  float* ref[4];
  float* dx[4];
  for (int i = 0; i < 4; ++i) {
    // Rows past `count` repeat the last: their writes land on it with the same values.
    ref[i] = ws.left_ref.ptr<float>(r + std::min(i, count - 1));
    dx[i] = ws.left_dx.ptr<float>(r + std::min(i, count - 1));
  }
  for (int i = 0; i < count; ++i) {
    std::fill(ref[i], ref[i] + l.stride, 0.0f);
    std::fill(dx[i], dx[i] + l.stride, 0.0f);
    for (int k = 0; k < n; ++k) ref[i][l.h + k] = static_cast<float>(in[i][k]) - kGrey;
  }
  const v_float32x4 half = cv::v_setall_f32(0.5f);
  for (int k = 0; k < n; ++k) {
    float d[4];  // derivative of the interpolant at k
    cv::v_store(d, half * (at(k + 1) - at(k - 1)));
    for (int i = 0; i < 4; ++i) dx[i][l.h + k] = d[i];
  }
  for (int i = 0; i < 4; ++i) in[i] = right.ptr<std::uint8_t>(l.table_row0 + r + std::min(i, count - 1));
  prefilter_rows(in, n, c);
  // On [k, k+1): g(k + t) = sum_i c[k-1+i] B_i(t) = 128 + p0 + p1 t + p2 t^2 + p3 t^3 (the offset as for
  // the left strip). A 4x4 transpose turns the lanes (rows) into each row's 4 coefficients.
  float* poly[4];
  for (int i = 0; i < 4; ++i) poly[i] = ws.right_poly.ptr<float>(r + std::min(i, count - 1));
  const v_float32x4 sixth = cv::v_setall_f32(1.0f / 6.0f), four = cv::v_setall_f32(4.0f), two = cv::v_setall_f32(2.0f);
  const v_float32x4 three = cv::v_setall_f32(3.0f), grey = cv::v_setall_f32(kGrey);
  for (int k = 0; k < n; ++k) {
    const v_float32x4 cm = at(k - 1), c0 = at(k), c1 = at(k + 1), c2 = at(k + 2);
    const v_float32x4 p0 = (cm + cv::v_muladd(four, c0, c1)) * sixth - grey;
    const v_float32x4 p1 = half * (c1 - cm);
    const v_float32x4 p2 = half * (cm - two * c0 + c1);
    const v_float32x4 p3 = cv::v_muladd(three, c0 - c1, c2 - cm) * sixth;
    v_float32x4 q[4];
    cv::v_transpose4x4(p0, p1, p2, p3, q[0], q[1], q[2], q[3]);
    for (int i = 0; i < 4; ++i) cv::v_store(poly[i] + 4 * k, q[i]);
  }
}

// Column sums of one grid row, each an array of `stride` floats (padding columns sum to zero). With
// f the left strip minus 128, fx its derivative and eta = row - y the row offset in the window:
enum ColumnSum { kF, kFF, kW, kWE, kWEE, kD, kDE, kDF, kDFE, kColumnSums };
//   f, f^2, fx^2, fx^2 eta, fx^2 eta^2, fx, fx eta, fx f, fx f eta.
// Each is a sum of at most 2 hh + 1 terms; those of f are whole numbers and exact in float.
void column_sums(const DicWorkspace& ws, const Layout& l, int y0, int y1, int y, float* sums) {
  for (int i = 0; i < l.stride; i += 4) {
    v_float32x4 acc[kColumnSums];
    for (auto& a : acc) a = cv::v_setzero_f32();
    for (int yy = y0; yy <= y1; ++yy) {
      const int r = yy - l.table_row0;
      const v_float32x4 eta = cv::v_setall_f32(static_cast<float>(yy - y));
      const v_float32x4 f = cv::v_load(ws.left_ref.ptr<float>(r) + i);
      const v_float32x4 d = cv::v_load(ws.left_dx.ptr<float>(r) + i);
      const v_float32x4 w = d * d, we = w * eta, de = d * eta;
      acc[kF] += f;
      acc[kFF] = cv::v_muladd(f, f, acc[kFF]);
      acc[kW] += w;
      acc[kWE] += we;
      acc[kWEE] = cv::v_muladd(we, eta, acc[kWEE]);
      acc[kD] += d;
      acc[kDE] += de;
      acc[kDF] = cv::v_muladd(d, f, acc[kDF]);
      acc[kDFE] = cv::v_muladd(de, f, acc[kDFE]);
    }
    for (int s = 0; s < kColumnSums; ++s) cv::v_store(sums + s * l.stride + i, acc[s]);
  }
}

struct Window {
  int x0, x1, y0, y1;  // inclusive, clipped to the strip
  int size() const { return (x1 - x0 + 1) * (y1 - y0 + 1); }
};

// Per-lane constants of a window row: xi = j - h inside the window, 0 past it; inside: 1 or all bits.
template <int V>
struct Lanes {
  v_float32x4 xi[V], inside[V];
  v_int32x4 column[V];  // j - h
  explicit Lanes(int h) {
    for (int k = 0; k < V; ++k) {
      float xi_[4], in_[4];
      int col_[4];
      for (int i = 0; i < 4; ++i) {
        const int j = 4 * k + i;
        in_[i] = j <= 2 * h ? 1.0f : 0.0f;
        xi_[i] = j <= 2 * h ? static_cast<float>(j - h) : 0.0f;
        col_[i] = j - h;
      }
      xi[k] = cv::v_load(xi_);
      inside[k] = cv::v_load(in_);
      column[k] = cv::v_load(col_);
    }
  }
};

// The reference (left) side of one window, constant over the iterations (the point of the
// inverse-compositional form). With f' = f - mean(f) and the steepest-descent images sd = fx * (1, xi, eta):
struct Reference {
  double f_sum = 0.0;     // sum of (f - 128)
  double f_mean = 0.0;    // mean of (f - 128)
  double f2 = 0.0;        // sum f'^2
  double norm = 0.0;      // sqrt(f2)
  double sd_f[3] = {};    // sum sd * f'
  double sd_sum[3] = {};  // sum sd
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

// The window's reference sums from the grid row's column sums. Returns false for too little texture or
// a singular Hessian. Columns outside the strip have zero sums, so only the lanes past the window need
// masking.
template <int V>
bool prepare_reference(const float* sums, int stride, int x, int n, const Lanes<V>& lanes, const DicConfig& p,
                       Reference& ref) {
  const auto at = [&](ColumnSum s, int k) { return cv::v_load(sums + s * stride + x + 4 * k); };
  const v_float32x4 zero = cv::v_setzero_f32();
  v_float32x4 f = zero, ff = zero, w = zero, w_xi = zero, w_xi2 = zero, we = zero, we_xi = zero, wee = zero;
  v_float32x4 d = zero, d_xi = zero, de = zero, df = zero, df_xi = zero, dfe = zero;
  for (int k = 0; k < V; ++k) {
    const v_float32x4 in = lanes.inside[k], xi = lanes.xi[k];
    f = cv::v_muladd(at(kF, k), in, f);
    ff = cv::v_muladd(at(kFF, k), in, ff);
    const v_float32x4 wk = at(kW, k) * in;
    w += wk;
    w_xi = cv::v_muladd(wk, xi, w_xi);
    w_xi2 = cv::v_muladd(wk * xi, xi, w_xi2);
    const v_float32x4 wek = at(kWE, k);
    we = cv::v_muladd(wek, in, we);
    we_xi = cv::v_muladd(wek, xi, we_xi);
    wee = cv::v_muladd(at(kWEE, k), in, wee);
    const v_float32x4 dk = at(kD, k);
    d = cv::v_muladd(dk, in, d);
    d_xi = cv::v_muladd(dk, xi, d_xi);
    de = cv::v_muladd(at(kDE, k), in, de);
    const v_float32x4 dfk = at(kDF, k);
    df = cv::v_muladd(dfk, in, df);
    df_xi = cv::v_muladd(dfk, xi, df_xi);
    dfe = cv::v_muladd(at(kDFE, k), in, dfe);
  }
  float s[16];
  cv::v_store(s, cv::v_reduce_sum4(f, ff, w, w_xi));
  cv::v_store(s + 4, cv::v_reduce_sum4(w_xi2, we, we_xi, wee));
  cv::v_store(s + 8, cv::v_reduce_sum4(d, d_xi, de, df));
  cv::v_store(s + 12, cv::v_reduce_sum4(df_xi, dfe, zero, zero));
  double h[3][3];
  h[0][0] = s[2];
  h[0][1] = h[1][0] = s[3];
  h[1][1] = s[4];
  h[0][2] = h[2][0] = s[5];
  h[1][2] = h[2][1] = s[6];
  h[2][2] = s[7];
  ref.f_sum = s[0];
  ref.f_mean = ref.f_sum / n;
  ref.f2 = s[1] - ref.f_sum * ref.f_mean;
  if (h[0][0] < p.min_gradient * p.min_gradient * n || !(ref.f2 > 0.0)) return false;
  ref.norm = std::sqrt(ref.f2);
  ref.sd_sum[0] = s[8];
  ref.sd_sum[1] = s[9];
  ref.sd_sum[2] = s[10];
  ref.sd_f[0] = s[11] - ref.f_mean * s[8];
  ref.sd_f[1] = s[12] - ref.f_mean * s[9];
  ref.sd_f[2] = s[13] - ref.f_mean * s[10];
  if (!p.first_order) {
    ref.h_inv[0][0] = 1.0 / h[0][0];
    return true;
  }
  return invert_symmetric3(h, ref.h_inv);
}

// The warp x_right = x + c + a * xi + b * eta (a = 1 + ux, b = uy, c = u).
struct Warp {
  double a = 1.0, b = 0.0, c = 0.0;
};

// Per strip column, sums over the window's rows of what one Gauss-Newton iteration needs, with g the
// right strip under the current warp minus 128 (a constant, so that neighbouring windows can share
// columns):
enum TargetSum { kG, kGG, kFG, kDG, kDGE, kTargetSums };
//   g, g^2, (f - 128) g, fx g, fx g eta.
// The warp maps strip column X of row eta to a X + e + b eta (e = c - (a - 1) x): a pixel whose start
// is its left neighbour's last sampled warp, moved (the warm start), sees the same samples in the
// columns the two windows share, so its first iteration samples only the new columns.
struct ColumnCache {
  float* sums = nullptr;  // kTargetSums arrays of `stride` floats; column X at X + h
  int x0 = 0, x1 = -1;    // columns that hold the last sampled warp
};

struct SampleRows {
  const float* ref = nullptr;   // left strip minus 128, padded; row r at ref + r * stride
  const float* dx = nullptr;    // its derivative, same layout
  const float* poly = nullptr;  // right strip cubics; row r at poly + r * poly_stride
  std::size_t stride = 0, poly_stride = 0;
};

// The tables are continuous (Mat::create): rows `stride` and 4 cols floats apart.
SampleRows sample_rows(const DicWorkspace& ws, const Layout& l, int yy) {
  const auto r = static_cast<std::size_t>(yy - l.table_row0);
  const auto stride = static_cast<std::size_t>(l.stride), poly_stride = static_cast<std::size_t>(4 * l.cols);
  return {reinterpret_cast<const float*>(ws.left_ref.data) + r * stride,
          reinterpret_cast<const float*>(ws.left_dx.data) + r * stride,
          reinterpret_cast<const float*>(ws.right_poly.data) + r * poly_stride, stride, poly_stride};
}

// Position of lane 0 (xi = -h) in each row of the window; lane j samples at starts[yy - y0] + a j.
void lane0_positions(const Layout& l, int x, int y, const Window& w, const Warp& wp, float* starts) {
  const double centre = x + wp.c - wp.a * l.h;
  double eta = w.y0 - y;
  for (int r = 0; r <= w.y1 - w.y0; ++r, eta += 1.0) starts[r] = static_cast<float>(centre + wp.b * eta);
}

// False when the window's samples leave the right strip. a > 0, so the extreme samples are the first
// and last columns of the first and last rows.
bool inside_right_strip(const Layout& l, int x, const Window& w, const Warp& wp, const float* starts) {
  const float a = static_cast<float>(wp.a), last = static_cast<float>(l.cols - 1);
  const float first_lane = static_cast<float>(w.x0 - (x - l.h)), last_lane = static_cast<float>(w.x1 - (x - l.h));
  for (const float s : {starts[0], starts[w.y1 - w.y0]}) {
    if (!(s + a * first_lane >= 0.0f && s + a * last_lane <= last)) return false;
  }
  return true;
}

// True when lanes [0, lanes) of the window's first and last rows sample inside the right strip.
bool lanes_inside_right_strip(const Layout& l, int x, const Window& w, const Warp& wp, const float* starts, int lanes) {
  const float a = static_cast<float>(wp.a), last = static_cast<float>(l.cols - 1);
  const float last_lane = a * static_cast<float>(lanes - 1);
  for (const float s : {starts[0], starts[w.y1 - w.y0]}) {
    if (!(s >= 0.0f && s + last_lane <= last)) return false;
  }
  return x - l.h >= 0;
}

// After a pass over `lanes` lanes: the cache holds the window's columns and those of the lanes past it
// whose column is in the left strip and whose positions are in the right one (a > 0: the first and
// last rows bound them; computed as in the passes).
void set_cache_range(const Layout& l, int x, const Window& w, const Warp& wp, const float* starts, int lanes,
                     ColumnCache& cache) {
  const float a = static_cast<float>(wp.a), last = static_cast<float>(l.cols - 1);
  int x1 = std::min(l.cols - 1, x - l.h + lanes - 1);
  for (; x1 > w.x1; --x1) {
    const float aj = a * static_cast<float>(x1 - (x - l.h));
    if (starts[0] + aj <= last && starts[w.y1 - w.y0] + aj <= last) break;
  }
  cache.x0 = w.x0;
  cache.x1 = x1;
}

// Samples lanes [4 k, 4 k + 4) of the window (strip columns x - h + 4 k ...) in every row under the
// warp into the cache. Lane j samples at starts[row] + a j.
template <bool kClamp>
void sample_lanes4(const SampleRows& rows, const Layout& l, int x, int y, const Window& w, float a, const float* starts,
                   int k, ColumnCache& cache) {
  const v_float32x4 last = cv::v_setall_f32(static_cast<float>(l.cols - 1)), zero = cv::v_setzero_f32();
  const auto j0 = static_cast<float>(4 * k);
  const v_float32x4 aj = cv::v_setall_f32(a) * cv::v_float32x4(j0, j0 + 1, j0 + 2, j0 + 3);
  // fx g eta from the running sums of fx g (prefix): sum_r r d_r = rows * sum_r d_r - sum_r prefix_r.
  v_float32x4 sg = zero, sgg = zero, sfg = zero, sdg = zero, prefix = zero;
  const float* ref = rows.ref + x + 4 * k;
  const float* dx = rows.dx + x + 4 * k;
  const float* poly = rows.poly;
  for (int r = 0; r <= w.y1 - w.y0; ++r, ref += rows.stride, dx += rows.stride, poly += rows.poly_stride) {
    // Lanes outside the window may sample anywhere: clamp their position (the cache range excludes
    // them). Inside, positions are in [0, cols - 1], so truncation is the floor.
    v_float32x4 pos = cv::v_setall_f32(starts[r]) + aj;
    if (kClamp) pos = cv::v_min(cv::v_max(pos, zero), last);
    const v_int32x4 index = cv::v_trunc(pos);
    const v_float32x4 t = pos - cv::v_cvt_f32(index);
    std::int32_t i[4];  // float offsets of the intervals' cubics, >= 0
    cv::v_store(i, cv::v_shl<2>(index));
    v_float32x4 p0, p1, p2, p3;
    cv::v_transpose4x4(cv::v_load(poly + static_cast<std::uint32_t>(i[0])),
                       cv::v_load(poly + static_cast<std::uint32_t>(i[1])),
                       cv::v_load(poly + static_cast<std::uint32_t>(i[2])),
                       cv::v_load(poly + static_cast<std::uint32_t>(i[3])), p0, p1, p2, p3);
    const v_float32x4 g = cv::v_muladd(cv::v_muladd(cv::v_muladd(p3, t, p2), t, p1), t, p0);  // minus 128
    sg += g;
    sgg = cv::v_muladd(g, g, sgg);
    sfg = cv::v_muladd(cv::v_load(ref), g, sfg);
    const v_float32x4 dg = cv::v_load(dx) * g;
    sdg += dg;
    prefix += sdg;
  }
  const float rows_count = static_cast<float>(w.y1 - w.y0 + 1), eta0 = static_cast<float>(w.y0 - y);
  const v_float32x4 sdge = sdg * cv::v_setall_f32(rows_count + eta0) - prefix;
  float* out = cache.sums + x + 4 * k;
  const std::size_t stride = static_cast<std::size_t>(l.stride);
  cv::v_store(out + kG * stride, sg);
  cv::v_store(out + kGG * stride, sgg);
  cv::v_store(out + kFG * stride, sfg);
  cv::v_store(out + kDG * stride, sdg);
  cv::v_store(out + kDGE * stride, sdge);
}

// Samples the window's columns under the warp into the cache, and the columns of the lanes past the
// window as far as they are inside both strips: the next pixels' new columns, free here. The window
// must be inside the right strip (inside_right_strip).
template <int V, bool kClamp>
void sample_window(const DicWorkspace& ws, const Layout& l, int x, int y, const Window& w, const Warp& wp,
                   const float* starts, ColumnCache& cache) {
  const SampleRows rows = sample_rows(ws, l, w.y0);
  for (int k = 0; k < V; ++k) sample_lanes4<kClamp>(rows, l, x, y, w, static_cast<float>(wp.a), starts, k, cache);
  set_cache_range(l, x, w, wp, starts, 4 * V, cache);
}

#if RUTD_DIC_AVX2
// sample_window with 8-lane AVX2 vectors, for CPUs that have them (chosen at run time: the build
// targets baseline x86-64), and a 4-lane tail when V is odd. Per lane it performs the same
// single-precision operations in the same order (no fused multiply-add), so the cache receives bit for
// bit the sums of the 4-lane pass.
template <int V, bool kClamp>
__attribute__((target("avx2"))) void sample_window_avx2(const DicWorkspace& ws, const Layout& l, int x, int y,
                                                        const Window& w, const Warp& wp, const float* starts,
                                                        ColumnCache& cache) {
  const __m256 zero = _mm256_setzero_ps(), last = _mm256_set1_ps(static_cast<float>(l.cols - 1));
  const __m256 a = _mm256_set1_ps(static_cast<float>(wp.a));
  const SampleRows rows = sample_rows(ws, l, w.y0);
  const std::size_t stride = static_cast<std::size_t>(l.stride);
  for (int k = 0; k < V / 2; ++k) {
    const auto j0 = static_cast<float>(8 * k);
    const __m256 aj = _mm256_mul_ps(a, _mm256_setr_ps(j0, j0 + 1, j0 + 2, j0 + 3, j0 + 4, j0 + 5, j0 + 6, j0 + 7));
    __m256 sg = zero, sgg = zero, sfg = zero, sdg = zero, prefix = zero;
    const float* ref = rows.ref + x + 8 * k;
    const float* dx = rows.dx + x + 8 * k;
    const float* poly = rows.poly;
    for (int r = 0; r <= w.y1 - w.y0; ++r, ref += rows.stride, dx += rows.stride, poly += rows.poly_stride) {
      __m256 pos = _mm256_add_ps(_mm256_set1_ps(starts[r]), aj);
      if (kClamp) pos = _mm256_min_ps(_mm256_max_ps(pos, zero), last);
      const __m256i index = _mm256_cvttps_epi32(pos);
      const __m256 t = _mm256_sub_ps(pos, _mm256_cvtepi32_ps(index));
      alignas(32) std::int32_t i[8];
      _mm256_store_si256(reinterpret_cast<__m256i*>(i), _mm256_slli_epi32(index, 2));
      // Lanes 0-3 in the low halves, 4-7 in the high ones: one 4x4 transpose per half. (Spelled out: a
      // lambda would not inherit the target, and -O2 keeps a loop's array in memory.)
      const __m256 q0 =
          _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_loadu_ps(poly + static_cast<std::uint32_t>(i[0]))),
                               _mm_loadu_ps(poly + static_cast<std::uint32_t>(i[4])), 1);
      const __m256 q1 =
          _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_loadu_ps(poly + static_cast<std::uint32_t>(i[1]))),
                               _mm_loadu_ps(poly + static_cast<std::uint32_t>(i[5])), 1);
      const __m256 q2 =
          _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_loadu_ps(poly + static_cast<std::uint32_t>(i[2]))),
                               _mm_loadu_ps(poly + static_cast<std::uint32_t>(i[6])), 1);
      const __m256 q3 =
          _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_loadu_ps(poly + static_cast<std::uint32_t>(i[3]))),
                               _mm_loadu_ps(poly + static_cast<std::uint32_t>(i[7])), 1);
      const __m256 u0 = _mm256_unpacklo_ps(q0, q1), u1 = _mm256_unpackhi_ps(q0, q1);
      const __m256 u2 = _mm256_unpacklo_ps(q2, q3), u3 = _mm256_unpackhi_ps(q2, q3);
      const __m256 p0 = _mm256_shuffle_ps(u0, u2, 0x44), p1 = _mm256_shuffle_ps(u0, u2, 0xEE);
      const __m256 p2 = _mm256_shuffle_ps(u1, u3, 0x44), p3 = _mm256_shuffle_ps(u1, u3, 0xEE);
      const __m256 g = _mm256_add_ps(
          _mm256_mul_ps(_mm256_add_ps(_mm256_mul_ps(_mm256_add_ps(_mm256_mul_ps(p3, t), p2), t), p1), t), p0);
      sg = _mm256_add_ps(sg, g);
      sgg = _mm256_add_ps(_mm256_mul_ps(g, g), sgg);
      sfg = _mm256_add_ps(_mm256_mul_ps(_mm256_loadu_ps(ref), g), sfg);
      sdg = _mm256_add_ps(sdg, _mm256_mul_ps(_mm256_loadu_ps(dx), g));
      prefix = _mm256_add_ps(prefix, sdg);
    }
    const float rows_count = static_cast<float>(w.y1 - w.y0 + 1), eta0 = static_cast<float>(w.y0 - y);
    const __m256 sdge = _mm256_sub_ps(_mm256_mul_ps(sdg, _mm256_set1_ps(rows_count + eta0)), prefix);
    float* out = cache.sums + x + 8 * k;
    _mm256_storeu_ps(out + kG * stride, sg);
    _mm256_storeu_ps(out + kGG * stride, sgg);
    _mm256_storeu_ps(out + kFG * stride, sfg);
    _mm256_storeu_ps(out + kDG * stride, sdg);
    _mm256_storeu_ps(out + kDGE * stride, sdge);
  }
  // The rest of the code is SSE (legacy encoding): leave the upper halves clean, or every SSE
  // instruction after this pays for the mixed state. (The compiler does not add it under the attribute.)
  _mm256_zeroupper();
  if (V % 2 != 0) sample_lanes4<kClamp>(rows, l, x, y, w, static_cast<float>(wp.a), starts, V - 1, cache);
  // The same range as the 4-lane pass: a column sampled here rather than later by another pixel would
  // see that pixel's rounding of the same positions, and the two paths would part by a few ulps.
  set_cache_range(l, x, w, wp, starts, 4 * l.vectors, cache);
}

#endif

// Samples columns [c0, c1] of the window (inside the strips) under the warp into the cache, one at a time.
void sample_columns(const DicWorkspace& ws, const Layout& l, int x, int y, const Window& w, const Warp& wp,
                    const float* starts, int c0, int c1, ColumnCache& cache) {
  const float a = static_cast<float>(wp.a);
  const SampleRows rows = sample_rows(ws, l, w.y0);
  for (int column = c0; column <= c1; ++column) {
    const float aj = a * static_cast<float>(column - (x - l.h));
    const float* ref = rows.ref + column + l.h;
    const float* dx = rows.dx + column + l.h;
    const float* poly = rows.poly;
    // As the vector passes do, to the bit: fx g eta from the prefix sums of fx g.
    float sg = 0, sgg = 0, sfg = 0, sdg = 0, prefix = 0;
    for (int r = 0; r <= w.y1 - w.y0; ++r, ref += rows.stride, dx += rows.stride, poly += rows.poly_stride) {
      const float pos = starts[r] + aj;  // in [0, cols - 1]
      const auto index = static_cast<std::uint32_t>(pos);
      const float t = pos - static_cast<float>(index);
      const float* p = poly + 4 * index;
      const float g = ((p[3] * t + p[2]) * t + p[1]) * t + p[0];  // minus 128
      sg += g;
      sgg += g * g;
      sfg += *ref * g;
      const float dg = *dx * g;
      sdg += dg;
      prefix += sdg;
    }
    const float rows_count = static_cast<float>(w.y1 - w.y0 + 1), eta0 = static_cast<float>(w.y0 - y);
    const float sdge = sdg * (rows_count + eta0) - prefix;
    float* out = cache.sums + column + l.h;
    const std::size_t stride = static_cast<std::size_t>(l.stride);
    out[kG * stride] = sg;
    out[kGG * stride] = sgg;
    out[kFG * stride] = sfg;
    out[kDG * stride] = sdg;
    out[kDGE * stride] = sdge;
  }
  cache.x0 = w.x0;
  cache.x1 = std::max(cache.x1, c1);
}

// Sums over the window of one iteration, g the right strip under the warp minus 128.
struct TargetSums {
  double g = 0, gg = 0, fg = 0;  // g, g^2, (f - 128) g
  double sd[3] = {};             // sd * g
};

template <int V>
TargetSums window_sums(const ColumnCache& cache, int stride, int x, const Lanes<V>& lanes, const v_float32x4* valid) {
  const v_float32x4 zero = cv::v_setzero_f32();
  v_float32x4 g = zero, gg = zero, fg = zero, dg = zero, dg_xi = zero, dge = zero;
  const float* in = cache.sums + x;
  for (int k = 0; k < V; ++k, in += 4) {
    g += cv::v_load(in + kG * stride) & valid[k];
    gg += cv::v_load(in + kGG * stride) & valid[k];
    fg += cv::v_load(in + kFG * stride) & valid[k];
    const v_float32x4 dgk = cv::v_load(in + kDG * stride) & valid[k];
    dg += dgk;
    dg_xi = cv::v_muladd(dgk, lanes.xi[k], dg_xi);
    dge += cv::v_load(in + kDGE * stride) & valid[k];
  }
  float s[8];
  cv::v_store(s, cv::v_reduce_sum4(g, gg, fg, dg));
  cv::v_store(s + 4, cv::v_reduce_sum4(dg_xi, dge, zero, zero));
  TargetSums t;
  t.g = s[0];
  t.gg = s[1];
  t.fg = s[2];
  t.sd[0] = s[3];
  t.sd[1] = s[4];
  t.sd[2] = s[5];
  return t;
}

// One full sampling pass over the window, 8 lanes wide where the CPU allows, clamping the positions
// only where some lane leaves the right strip.
template <int V>
void sample(const DicWorkspace& ws, const Layout& l, int x, int y, const Window& w, const Warp& wp, const float* starts,
            ColumnCache& cache) {
#if RUTD_DIC_AVX2
  if (l.avx2 && V > 1) {
    if (lanes_inside_right_strip(l, x, w, wp, starts, 4 * V)) {
      sample_window_avx2<V, false>(ws, l, x, y, w, wp, starts, cache);
    } else {
      sample_window_avx2<V, true>(ws, l, x, y, w, wp, starts, cache);
    }
    return;
  }
#endif
  if (lanes_inside_right_strip(l, x, w, wp, starts, 4 * V)) {
    sample_window<V, false>(ws, l, x, y, w, wp, starts, cache);
  } else {
    sample_window<V, true>(ws, l, x, y, w, wp, starts, cache);
  }
}

struct PixelResult {
  float disparity = kNaN;
  int iterations = 0;
  Warp sampled;  // the warp of the last iteration's samples, a warm start for the next pixel of the row
  Warp final;    // the converged warp
};

// Inverse-compositional Gauss-Newton on the ZNSSD criterion (Pan et al., 2013) from disparity d0.
// `start` is the warp to begin from (the previous pixel's, moved here, or the engine's shift); with
// `reuse`, it is the warp the cache holds (the previous pixel's last samples).
template <int V>
bool refine_pixel(const DicWorkspace& ws, const Layout& l, const float* sums, const Lanes<V>& lanes, int x, int y,
                  const Window& w, float d0, const Warp& start, bool reuse, const DicConfig& p, ColumnCache& cache,
                  float* starts, PixelResult& out) {
  const int n = w.size();
  Reference ref;
  if (!prepare_reference(sums, l.stride, x, n, lanes, p, ref)) return false;
  v_float32x4 valid[V];
  const v_int32x4 ncols = cv::v_setall_s32(l.cols), minus_one = cv::v_setall_s32(-1);
  for (int k = 0; k < V; ++k) {
    const v_int32x4 column = lanes.column[k] + cv::v_setall_s32(x);
    valid[k] =
        cv::v_reinterpret_as_f32((column > minus_one) & (ncols > column)) & (lanes.inside[k] > cv::v_setzero_f32());
  }
  const double inv_n = 1.0 / n, inv_f_norm = 1.0 / ref.norm;
  // The warp update moves the window's corners by about sqrt(corner2) px.
  const double tolerance2 = p.tolerance_px * p.tolerance_px;
  const auto converged = [&](double corner2) { return p.tolerance_px > 0.0 && corner2 < tolerance2; };
  Warp wp = start;
  for (int it = 1; it <= p.max_iterations; ++it) {
    lane0_positions(l, x, y, w, wp, starts);
    if (!inside_right_strip(l, x, w, wp, starts)) return false;
    if (it == 1 && reuse && cache.x0 <= w.x0 && cache.x1 >= w.x0) {
      if (cache.x1 < w.x1) sample_columns(ws, l, x, y, w, wp, starts, cache.x1 + 1, w.x1, cache);
    } else {
      sample<V>(ws, l, x, y, w, wp, starts, cache);
    }
    out.sampled = wp;
    const TargetSums t = window_sums(cache, l.stride, x, lanes, valid);
    const double g_mean = t.g * inv_n;
    const double g2 = t.gg - t.g * g_mean;  // sum g'^2, g' = g - mean(g)
    if (!(g2 > 1e-6)) return false;
    const double fg = t.fg - ref.f_sum * g_mean;  // sum f' g'
    const double inv_g_norm = 1.0 / std::sqrt(g2);
    const double k = ref.norm * inv_g_norm;
    // b = sum sd (f' - k g'), the residual's projection on the steepest-descent images.
    double b[3];
    for (int i = 0; i < 3; ++i) b[i] = ref.sd_f[i] - k * (t.sd[i] - g_mean * ref.sd_sum[i]);
    const double zncc = fg * inv_g_norm * inv_f_norm;
    double du = 0.0, dux = 0.0, duy = 0.0;
    if (p.first_order) {
      du = -(ref.h_inv[0][0] * b[0] + ref.h_inv[0][1] * b[1] + ref.h_inv[0][2] * b[2]);
      dux = -(ref.h_inv[1][0] * b[0] + ref.h_inv[1][1] * b[1] + ref.h_inv[1][2] * b[2]);
      duy = -(ref.h_inv[2][0] * b[0] + ref.h_inv[2][1] * b[1] + ref.h_inv[2][2] * b[2]);
    } else {
      du = -ref.h_inv[0][0] * b[0];
    }
    // W <- W o W(dp)^-1 ; W(dp)^-1: xi' = (xi - duy * eta - du) / (1 + dux).
    const double ai = 1.0 / (1.0 + dux);
    wp = Warp{wp.a * ai, wp.b - wp.a * duy * ai, wp.c - wp.a * du * ai};
    if (!std::isfinite(wp.c) || std::abs(wp.a - 1.0) > p.max_gradient || std::abs(wp.b) > p.max_gradient ||
        std::abs(-wp.c - d0) > p.max_shift_px) {
      return false;
    }
    if (converged(du * du + l.h * l.h * dux * dux + l.hh * l.hh * duy * duy)) {
      out.disparity = static_cast<float>(-wp.c);
      out.iterations = it;
      out.final = wp;
      if (p.max_sigma_px > 0.0) {
        const int unknowns = p.first_order ? 3 : 1;
        if (n <= unknowns) return false;
        // The residual sum of squares of this iteration's warp, sum (f' - k g')^2 = 2 f2 (1 - zncc), which
        // the converged update no longer changes.
        const double r2 = std::max(0.0, 2.0 * ref.f2 * (1.0 - zncc));
        const double variance = r2 / (n - unknowns) * ref.h_inv[0][0];
        if (!(variance <= p.max_sigma_px * p.max_sigma_px)) return false;
      }
      if (zncc >= p.min_zncc) return true;
      return p.noise_grey > 0.0 && zncc >= p.min_noise_zncc &&
             (1.0 - zncc) * ref.f2 <= p.noise_tolerance * n * p.noise_grey * p.noise_grey;
    }
  }
  return false;
}

// Refines rows [row_begin, row_end) of the grid with one thread's scratch.
template <int V>
void refine_rows(const DicWorkspace& ws, const Layout& l, cv::Mat& disparity, const DicConfig& params, int row_begin,
                 int row_end, DicScratch& scratch) {
  const int row_step = params.row_step > 0 ? params.row_step : params.step;
  const Lanes<V> lanes(l.h);
  const int rows = disparity.rows;
  for (int y = row_begin; y < row_end; ++y) {
    float* d = disparity.ptr<float>(y);
    if (y % row_step != 0) {
      std::fill(d, d + disparity.cols, kNaN);
      continue;
    }
    const int y0 = std::max(0, y - l.hh), y1 = std::min(rows - 1, y + l.hh);
    bool sums_ready = false;  // a row without an initial disparity needs none
    bool have_previous = false;
    Warp previous;  // last sampled warp of pixel x - step, moved to x
    ColumnCache cache{scratch.target_sums.data()};
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
      if (!sums_ready) {
        column_sums(ws, l, y0, y1, y, scratch.column_sums.data());
        sums_ready = true;
      }
      // Warm start from the neighbour when it agrees with the engine: fewer iterations, same optimum.
      Warp start{1.0, 0.0, -static_cast<double>(d0)};
      const bool warm = have_previous && std::abs(-previous.c - d0) < kWarmStartAgreementPx;
      if (warm) start = previous;
      const Window w{std::max(0, x - l.h), std::min(l.cols - 1, x + l.h), y0, y1};
      PixelResult result;
      have_previous = refine_pixel(ws, l, scratch.column_sums.data(), lanes, x, y, w, d0, start, warm, params, cache,
                                   scratch.starts.data(), result);
      if (have_previous) {
        d[x] = result.disparity;
        ++scratch.stats.refined;
        scratch.iterations += result.iterations;
        previous = result.sampled;
        previous.c += (previous.a - 1.0) * params.step;
      } else {
        d[x] = kNaN;
        ++scratch.stats.rejected;
      }
    }
  }
}

// Column windows: the initial disparity of each column, the median of its valid values in rows
// [row_begin, row_end); NaN when fewer than a quarter of them are valid.
void column_starts(const cv::Mat& disparity, int row_begin, int row_end, DicWorkspace& ws, float* start) {
  const int rows = row_end - row_begin;
  std::fill(start, start + disparity.cols, kNaN);
  ws.column_values.resize(static_cast<std::size_t>(rows));
  for (int x = 0; x < disparity.cols; ++x) {
    std::size_t n = 0;
    for (int y = row_begin; y < row_end; ++y) {
      const float d = disparity.ptr<float>(y)[x];
      if (std::isfinite(d)) ws.column_values[n++] = d;
    }
    if (4 * static_cast<int>(n) < rows || n == 0) continue;
    const auto mid = ws.column_values.begin() + static_cast<std::ptrdiff_t>(n / 2);
    std::nth_element(ws.column_values.begin(), mid, ws.column_values.begin() + static_cast<std::ptrdiff_t>(n));
    start[x] = *mid;
  }
}

// Column windows over rows [y0, y1] for columns [x_begin, x_end), with the column sums of the grid row
// yc (shared by all stripes, read-only here). Writes the fitted disparity into every row of the column,
// or NaN.
template <int V>
void refine_columns(const DicWorkspace& ws, const Layout& l, const float* sums, const float* starts, cv::Mat& disparity,
                    const DicConfig& params, int y0, int y1, int x_begin, int x_end, DicScratch& scratch) {
  const Lanes<V> lanes(l.h);
  const int yc = column_centre(y0, y1 + 1);
  bool have_previous = false;
  Warp previous;
  ColumnCache cache{scratch.target_sums.data()};
  for (int x = x_begin; x < x_end; ++x) {
    const float d0 = starts[x];
    bool ok = false;
    PixelResult result;
    if (std::isfinite(d0)) {
      Warp start{1.0, 0.0, -static_cast<double>(d0)};
      const bool warm = have_previous && std::abs(-previous.c - d0) < kWarmStartAgreementPx;
      if (warm) start = previous;
      const Window w{std::max(0, x - l.h), std::min(l.cols - 1, x + l.h), y0, y1};
      ok = refine_pixel(ws, l, sums, lanes, x, yc, w, d0, start, warm, params, cache, scratch.starts.data(), result);
    }
    have_previous = ok;
    if (ok) {
      previous = result.sampled;
      previous.c += previous.a - 1.0;
      ++scratch.stats.refined;
      scratch.iterations += result.iterations;
      for (int y = y0; y <= y1; ++y)
        disparity.ptr<float>(y)[x] = static_cast<float>(-(result.final.c + result.final.b * (y - yc)));
    } else {
      if (std::isfinite(d0)) ++scratch.stats.rejected;
      for (int y = y0; y <= y1; ++y) disparity.ptr<float>(y)[x] = kNaN;
    }
  }
}

using ColumnsFunction = void (*)(const DicWorkspace&, const Layout&, const float*, const float*, cv::Mat&,
                                 const DicConfig&, int, int, int, int, DicScratch&);

template <int... V>
ColumnsFunction columns_function(int vectors, std::integer_sequence<int, V...>) {
  ColumnsFunction f = nullptr;
  ((vectors == V + 1 ? (f = &refine_columns<V + 1>, 0) : 0), ...);
  return f;
}

using RowsFunction = void (*)(const DicWorkspace&, const Layout&, cv::Mat&, const DicConfig&, int, int, DicScratch&);

template <int... V>
RowsFunction rows_function(int vectors, std::integer_sequence<int, V...>) {
  RowsFunction f = nullptr;
  ((vectors == V + 1 ? (f = &refine_rows<V + 1>, 0) : 0), ...);
  return f;
}

// Runs body(stripe, begin, end) over `count` items split into contiguous stripes.
template <typename Body>
void for_stripes(int stripes, int count, const Body& body) {
  const auto run = [&](const cv::Range& range) {
    for (int s = range.start; s < range.end; ++s) body(s, count * s / stripes, count * (s + 1) / stripes);
  };
  if (stripes > 1) {
    cv::parallel_for_(cv::Range(0, stripes), run, stripes);
  } else {
    run(cv::Range(0, 1));
  }
}

}  // namespace

DicStats refine_disparity_dic(const cv::Mat& left_strip, const cv::Mat& right_strip, cv::Mat& disparity,
                              const DicConfig& params, DicWorkspace& ws) {
  CV_Assert(left_strip.type() == CV_8UC1 && right_strip.type() == CV_8UC1 && disparity.type() == CV_32FC1);
  CV_Assert(left_strip.size() == right_strip.size() && disparity.size() == left_strip.size());
  CV_Assert(left_strip.cols >= 4 && params.half_window >= 1 && 2 * params.half_window + 1 <= 4 * kMaxVectors &&
            params.step >= 1 && params.row_step >= 0);
  const int row_begin = std::clamp(params.row_begin, 0, disparity.rows);
  const int row_end = params.row_end < 0 ? disparity.rows : std::clamp(params.row_end, row_begin, disparity.rows);
  disparity.rowRange(0, row_begin).setTo(kNaN);
  disparity.rowRange(row_end, disparity.rows).setTo(kNaN);

  const Layout layout = make_layout(left_strip, params, row_begin, row_end);
  ws.left_ref.create(std::max(1, layout.table_rows), layout.stride, CV_32FC1);
  ws.left_dx.create(std::max(1, layout.table_rows), layout.stride, CV_32FC1);
  ws.right_poly.create(std::max(1, layout.table_rows), 4 * layout.cols, CV_32FC1);

  // Row stripes; with column windows, stripes of row blocks, or of columns when the rows are one block.
  const ColumnBlocks blocks(params, row_begin, row_end);
  int items = row_end - row_begin;
  if (params.column_windows) items = blocks.count > 1 ? blocks.count : disparity.cols;
  const int stripes = params.parallel ? std::max(1, std::min(cv::getNumThreads(), items)) : 1;
  if (ws.scratch.size() < static_cast<std::size_t>(stripes)) ws.scratch.resize(static_cast<std::size_t>(stripes));
  for (int s = 0; s < stripes; ++s) {
    DicScratch& sc = ws.scratch[static_cast<std::size_t>(s)];
    const auto coefficients = static_cast<std::size_t>(4 * (layout.cols + 2 * kPad));
    if (sc.row_buffer.size() < coefficients) sc.row_buffer.resize(coefficients);
    const auto sums = static_cast<std::size_t>(kColumnSums * layout.stride);
    if (sc.column_sums.size() < sums) sc.column_sums.resize(sums);
    if (sc.starts.size() < static_cast<std::size_t>(2 * layout.hh + 1)) sc.starts.resize(2 * layout.hh + 1);
    const auto target = static_cast<std::size_t>(kTargetSums * layout.stride);
    if (sc.target_sums.size() < target) sc.target_sums.resize(target);
    sc.stats = DicStats{};
    sc.iterations = 0;
  }
  for_stripes(stripes, (layout.table_rows + 3) / 4, [&](int s, int a, int b) {
    float* buffer = ws.scratch[static_cast<std::size_t>(s)].row_buffer.data();
    for (int q = a; q < b; ++q)
      build_table_rows(left_strip, right_strip, 4 * q, std::min(4, layout.table_rows - 4 * q), layout, ws, buffer);
  });
  if (params.column_windows && row_end > row_begin) {
    const auto cols = static_cast<std::size_t>(disparity.cols);
    ws.column_start.resize(cols * blocks.count);
    for (int b = 0; b < blocks.count; ++b)
      column_starts(disparity, blocks.begin(b), blocks.begin(b + 1), ws, ws.column_start.data() + b * cols);
    const ColumnsFunction refine_cols =
        columns_function(layout.vectors, std::make_integer_sequence<int, kMaxVectors>{});
    if (blocks.count == 1) {
      // One block (a strip): the sums once, shared by column stripes.
      float* sums = ws.scratch[0].column_sums.data();
      column_sums(ws, layout, row_begin, row_end - 1, column_centre(row_begin, row_end), sums);
      for_stripes(stripes, disparity.cols, [&](int s, int a, int b) {
        refine_cols(ws, layout, sums, ws.column_start.data(), disparity, params, row_begin, row_end - 1, a, b,
                    ws.scratch[static_cast<std::size_t>(s)]);
      });
    } else {
      // Blocks of rows (full frame): a stripe of blocks per thread, each with its own sums.
      for_stripes(stripes, blocks.count, [&](int s, int a, int b) {
        DicScratch& scratch = ws.scratch[static_cast<std::size_t>(s)];
        for (int k = a; k < b; ++k) {
          const int y0 = blocks.begin(k), y1 = blocks.begin(k + 1) - 1;
          column_sums(ws, layout, y0, y1, column_centre(y0, y1 + 1), scratch.column_sums.data());
          refine_cols(ws, layout, scratch.column_sums.data(), ws.column_start.data() + k * cols, disparity, params, y0,
                      y1, 0, disparity.cols, scratch);
        }
      });
    }
  } else {
    // Interleaved rows per stripe would share cache lines of `disparity`; contiguous blocks do not.
    const RowsFunction refine = rows_function(layout.vectors, std::make_integer_sequence<int, kMaxVectors>{});
    for_stripes(stripes, row_end - row_begin, [&](int s, int a, int b) {
      refine(ws, layout, disparity, params, row_begin + a, row_begin + b, ws.scratch[static_cast<std::size_t>(s)]);
    });
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
