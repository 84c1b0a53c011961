// The DIC as the GPU engine runs it (pipeline/gpu/: its C++ reference, and the Vulkan engine end to end)
// against images with KNOWN fractional disparities (known_disparity.hpp, made independently of
// the code under test), and against the CPU DIC of dic_refine.hpp on the same initial disparities: per
// pixel, and with column windows (one window per column and row block, the measurer's default).
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "gpu/dic.hpp"
#include "known_disparity.hpp"
#include "pipeline/dic_refine.hpp"
#include "pipeline/disparity.hpp"
#include "skip_policy.hpp"

namespace rutd {
namespace {

using namespace known_disparity;

gpu::ImageView view(const cv::Mat& m) { return gpu::ImageView{m.data, m.cols, m.rows, m.step[0]}; }

// The reference DIC of the GPU on `initial` (CV_32F), as a cv::Mat.
cv::Mat reference_dic(const Pair& pair, const cv::Mat& initial, const gpu::DicKernelConfig& p) {
  std::vector<float> coef_l, coef_r, in(initial.begin<float>(), initial.end<float>()), out;
  gpu::bspline_reference(view(pair.left), coef_l);
  gpu::bspline_reference(view(pair.right), coef_r);
  gpu::dic_reference(view(pair.left), coef_l, coef_r, in, p, out);
  return cv::Mat(initial.size(), CV_32FC1, out.data()).clone();
}

// Largest |a - b| where both are valid, and how many are valid in only one.
std::pair<double, int> compare(const cv::Mat& a, const cv::Mat& b) {
  double worst = 0;
  int one_side = 0;
  for (int y = 0; y < a.rows; ++y) {
    for (int x = 0; x < a.cols; ++x) {
      const float u = a.at<float>(y, x), v = b.at<float>(y, x);
      if (std::isfinite(u) != std::isfinite(v)) ++one_side;
      if (std::isfinite(u) && std::isfinite(v)) worst = std::max(worst, static_cast<double>(std::abs(u - v)));
    }
  }
  return {worst, one_side};
}

const cv::Size kStrip(320, 48);

struct Truth {
  double d0, slope;
  unsigned seed;
};
const Truth kTruths[] = {{24.1, 0.0, 101}, {24.5, 0.0, 105}, {24.9, 0.0, 109}, {20.3, 0.12, 7}};

TEST(GpuDic, ReferenceRemovesPixelLockingLikeTheCpuDic) {
  auto sgm = make_cpu_engine(EngineKind::SgmRef);
  std::printf("   d_true  slope   sgm_bias  sgm_rms   gpu_bias  gpu_rms  refined | cpu_dic_rms  refined  |diff|\n");
  for (const Truth& t : kTruths) {
    const Pair pair = render_pair(t.d0, t.slope, kStrip, t.seed);
    cv::Mat initial;
    sgm->compute(pair.left, pair.right, {16, 48}, initial);
    const int x_min = 64;
    const Error before = error_of(initial, t.d0, t.slope, x_min);
    gpu::DicKernelConfig p;
    const cv::Mat gpu_dic = reference_dic(pair, initial, p);
    const Error after = error_of(gpu_dic, t.d0, t.slope, x_min);
    cv::Mat cpu_dic = initial.clone();
    DicWorkspace ws;
    refine_disparity_dic(pair.left, pair.right, cpu_dic, DicConfig{}, ws);
    const Error cpu = error_of(cpu_dic, t.d0, t.slope, x_min);
    const auto [diff, one_side] = compare(gpu_dic, cpu_dic);
    std::printf("  %7.2f  %5.2f  %+9.4f  %7.4f  %+9.4f  %7.4f  %7d | %11.4f  %7d  %.4f (%d on one side)\n", t.d0,
                t.slope, before.mean, before.rms, after.mean, after.rms, after.count, cpu.rms, cpu.count, diff,
                one_side);
    EXPECT_LT(std::abs(after.mean), 0.02) << t.d0;
    EXPECT_LT(after.rms, 0.05) << t.d0;
    EXPECT_GT(after.count, 0.9 * before.count) << t.d0;
    // Same optimum as the CPU DIC (double precision, warm-started): within 1/64 px, nearly the same pixels.
    EXPECT_LT(diff, 1.0 / 64) << t.d0;
    EXPECT_LT(one_side, 0.01 * after.count) << t.d0;
  }
}

TEST(GpuDic, EngineRefinesOnTheDeviceAsTheReference) {
  auto engine = make_engine(EngineKind::Gpu);
  for (const Truth& t : kTruths) {
    const Pair pair = render_pair(t.d0, t.slope, kStrip, t.seed);
    DicConfig config;
    config.row_step = 2;
    config.row_begin = 4;
    config.row_end = 44;
    cv::Mat refined;
    DicStats stats;
    if (!engine->compute_refined(pair.left, pair.right, {16, 48}, config, refined, stats))
      RUTD_SKIP_GPU_FELL_BACK("the GPU engine runs as sgmref, which does not refine");
    cv::Mat initial;
    make_cpu_engine(EngineKind::SgmRef)->compute(pair.left, pair.right, {16, 48}, initial);
    gpu::DicKernelConfig p;
    p.row_step = 2;
    p.row_begin = 4;
    p.row_end = 44;
    const cv::Mat expected = reference_dic(pair, initial, p);
    const auto [diff, one_side] = compare(refined, expected);
    const Error e = error_of(refined, t.d0, t.slope, 64);
    std::printf("d %.2f slope %.2f: %d refined, rms %.4f px; against the reference %.6f px, %d on one side\n", t.d0,
                t.slope, stats.refined, e.rms, diff, one_side);
    EXPECT_LT(diff, 1.0 / 64) << t.d0;
    EXPECT_LE(one_side, stats.refined / 200) << t.d0;
    EXPECT_GT(stats.refined, 0) << t.d0;
    EXPECT_LT(e.rms, 0.05) << t.d0;
  }
}

// Column windows on a strip whose disparity slopes across and down it: rows [row_begin, row_end) of
// `size`, in blocks of about block_rows rows (0: one block).
struct ColumnCase {
  cv::Size size;
  int row_begin, row_end, block_rows;
  double d0, slope, slope_y;
  unsigned seed;
};
const ColumnCase kColumnCases[] = {
    {{320, 62}, 7, 55, 0, 20.35, 0.0, 0.0, 23},  {{320, 62}, 7, 55, 0, 20.65, 0.08, -0.04, 24},
    {{320, 48}, 0, 48, 0, 24.5, 0.0, 0.06, 25},  {{321, 100}, 3, 97, 16, 22.2, 0.05, 0.03, 26},
    {{257, 71}, 5, 66, 7, 20.8, 0.04, 0.02, 27},
};

// Truth of a column case at (x, y).
double column_truth(const ColumnCase& c, int x, int y) { return c.d0 + c.slope * x + c.slope_y * y; }

gpu::DicKernelConfig column_params(const ColumnCase& c) {
  gpu::DicKernelConfig p;
  p.column_windows = true;
  p.column_block_rows = c.block_rows;
  p.row_begin = c.row_begin;
  p.row_end = c.row_end;
  return p;
}

// The same windows for the CPU DIC and the engine.
DicConfig column_config(const ColumnCase& c) {
  DicConfig config;
  config.column_windows = true;
  config.column_block_rows = c.block_rows;
  config.row_begin = c.row_begin;
  config.row_end = c.row_end;
  return config;
}

// Windows refined (a block's first row at each column), and pixels refined outside [row_begin, row_end).
std::pair<int, int> column_windows_refined(const cv::Mat& d, const gpu::DicKernelConfig& p) {
  const gpu::ColumnBlocks blocks(p, d.rows);
  int windows = 0, outside = 0;
  for (int b = 0; b < blocks.count; ++b)
    for (int x = 0; x < d.cols; ++x) windows += std::isfinite(d.at<float>(blocks.begin(b), x));
  for (int y = 0; y < d.rows; ++y)
    for (int x = 0; x < d.cols; ++x) outside += (y < p.row_begin || y >= p.row_end) && std::isfinite(d.at<float>(y, x));
  return {windows, outside};
}

// RMS error against the truth over x >= 64.
double column_rms(const cv::Mat& d, const ColumnCase& c) {
  double sum = 0;
  int n = 0;
  for (int y = 0; y < d.rows; ++y) {
    for (int x = 64; x < d.cols; ++x) {
      const float v = d.at<float>(y, x);
      if (!std::isfinite(v)) continue;
      sum += (v - column_truth(c, x, y)) * (v - column_truth(c, x, y));
      ++n;
    }
  }
  return n > 0 ? std::sqrt(sum / n) : 1e30;
}

// The reference's column windows are the CPU DIC's: the same rows, blocks, starts and write-back, so the
// two reach the same optimum (the CPU in double, warm-started from the neighbour) on every pixel.
TEST(GpuDic, ReferenceColumnWindowsAreTheCpuColumnWindows) {
  auto sgm = make_cpu_engine(EngineKind::SgmRef);
  for (const ColumnCase& c : kColumnCases) {
    const Pair pair = render_pair(c.d0, c.slope, c.size, c.seed, 0.7, c.slope_y);
    cv::Mat initial;
    sgm->compute(pair.left, pair.right, {16, 48}, initial);
    const gpu::DicKernelConfig p = column_params(c);
    const cv::Mat gpu_dic = reference_dic(pair, initial, p);
    cv::Mat cpu_dic = initial.clone();
    const DicConfig config = column_config(c);
    DicWorkspace ws;
    const DicStats cpu_stats = refine_disparity_dic(pair.left, pair.right, cpu_dic, config, ws);
    const auto [diff, one_side] = compare(gpu_dic, cpu_dic);
    const auto [windows, outside] = column_windows_refined(gpu_dic, p);
    const double rms = column_rms(gpu_dic, c);
    std::printf(
        "%dx%d rows %d..%d blocks of %d: %d windows (CPU %d), rms %.4f px (CPU %.4f); |diff| %.5f px, %d "
        "pixels on one side\n",
        c.size.width, c.size.height, c.row_begin, c.row_end, c.block_rows, windows, cpu_stats.refined, rms,
        column_rms(cpu_dic, c), diff, one_side);
    EXPECT_LT(diff, 1.0 / 64) << c.seed;
    EXPECT_LE(std::abs(windows - cpu_stats.refined), cpu_stats.refined / 100) << c.seed;
    EXPECT_LE(one_side, (c.row_end - c.row_begin) * (cpu_stats.refined / 100)) << c.seed;
    EXPECT_EQ(outside, 0) << c.seed;
    // Columns left of the band's widest disparity (63) have no start.
    EXPECT_GT(windows, 0.9 * (c.size.width - 64) * gpu::ColumnBlocks(p, c.size.height).count) << c.seed;
    EXPECT_LT(rms, 0.03) << c.seed;
  }
}

TEST(GpuDic, EngineRefinesColumnWindowsOnTheDeviceAsTheReference) {
  auto engine = make_engine(EngineKind::Gpu);
  for (const ColumnCase& c : kColumnCases) {
    const Pair pair = render_pair(c.d0, c.slope, c.size, c.seed, 0.7, c.slope_y);
    const DicConfig config = column_config(c);
    cv::Mat refined;
    DicStats stats;
    if (!engine->compute_refined(pair.left, pair.right, {16, 48}, config, refined, stats))
      RUTD_SKIP_GPU_FELL_BACK("the GPU engine runs as sgmref, which does not refine");
    cv::Mat initial;
    make_cpu_engine(EngineKind::SgmRef)->compute(pair.left, pair.right, {16, 48}, initial);
    const gpu::DicKernelConfig p = column_params(c);
    const cv::Mat expected = reference_dic(pair, initial, p);
    const auto [diff, one_side] = compare(refined, expected);
    const auto [windows, outside] = column_windows_refined(expected, p);
    const double rms = column_rms(refined, c);
    std::printf(
        "%dx%d blocks of %d: %d windows refined (reference %d), rms %.4f px; against the reference %.6f px, "
        "%d pixels on one side\n",
        c.size.width, c.size.height, c.block_rows, stats.refined, windows, rms, diff, one_side);
    EXPECT_LT(diff, 1.0 / 128) << c.seed;
    EXPECT_LE(one_side, (c.row_end - c.row_begin) * (windows / 200)) << c.seed;
    EXPECT_LE(std::abs(stats.refined - windows), windows / 200) << c.seed;
    EXPECT_EQ(column_windows_refined(refined, p).second, 0) << c.seed;
    EXPECT_LT(rms, 0.03) << c.seed;
  }
}

}  // namespace
}  // namespace rutd
