// rutd bench --pair: every engine, with and without DIC, on one rectified pair with a Middlebury-style
// ground-truth disparity image. Statistics over the pixels with known ground truth (value != 0):
//   bad-t     % of the pixels with a valid estimate whose |estimate - truth| > t px
//   mae_px    mean |estimate - truth| over the pixels with a valid estimate
//   coverage  pixels with a valid estimate / pixels with known truth (0..1)
//   ms        wall time of the engine (and of DIC when on) on this pair, median of three runs
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/input_error.hpp"
#include "daemon/bench_tables.hpp"
#include "daemon/progress.hpp"
#include "engines/disparity_engine.hpp"
#include "engines/engine_factory.hpp"
#include "refinement/dic_refine.hpp"

namespace rutd {
namespace {

cv::Mat read_grey(const std::string& path, const char* field) {
  cv::Mat image;
  try {
    image = cv::imread(path, cv::IMREAD_GRAYSCALE);  // colour is converted; 16-bit is scaled to 8
  } catch (const cv::Exception& e) {
    throw InputError(path, field, std::string("cannot read the image: ") + e.what());
  }
  if (image.empty()) throw InputError(path, field, "cannot read the image (missing, or not an image file)");
  return image;
}

struct PairStats {
  double bad05 = 0, bad1 = 0, bad2 = 0, mae = 0, coverage = 0;
};

PairStats score(const cv::Mat& d, const cv::Mat& truth) {
  long known = 0, valid = 0, b05 = 0, b1 = 0, b2 = 0;
  double abs_sum = 0;
  for (int y = 0; y < truth.rows; ++y) {
    const float* t = truth.ptr<float>(y);
    const float* e = d.ptr<float>(y);
    for (int x = 0; x < truth.cols; ++x) {
      if (!std::isfinite(t[x])) continue;
      ++known;
      if (!std::isfinite(e[x])) continue;
      ++valid;
      const double err = std::abs(double(e[x]) - t[x]);
      abs_sum += err;
      b05 += err > 0.5;
      b1 += err > 1.0;
      b2 += err > 2.0;
    }
  }
  PairStats s;
  const double v = static_cast<double>(std::max(1L, valid));
  s.bad05 = 100.0 * b05 / v;
  s.bad1 = 100.0 * b1 / v;
  s.bad2 = 100.0 * b2 / v;
  s.mae = valid > 0 ? abs_sum / v : std::numeric_limits<double>::quiet_NaN();
  s.coverage = known > 0 ? static_cast<double>(valid) / known : 0.0;
  return s;
}

}  // namespace

int run_bench_pair(const BenchPairOptions& o) {
  const cv::Mat left = read_grey(o.left, "--pair LEFT");
  const cv::Mat right = read_grey(o.right, "--pair RIGHT");
  if (right.size() != left.size())
    throw InputError(o.right, "--pair RIGHT",
                     fmt::format("image is {}x{}, the left image {} is {}x{}", right.cols, right.rows, o.left,
                                 left.cols, left.rows));
  cv::Mat stored;
  try {
    stored = cv::imread(o.gt, cv::IMREAD_ANYDEPTH | cv::IMREAD_GRAYSCALE);
  } catch (const cv::Exception& e) {
    throw InputError(o.gt, "--gt", std::string("cannot read the ground truth: ") + e.what());
  }
  if (stored.empty()) throw InputError(o.gt, "--gt", "cannot read the ground truth (missing, or not an image file)");
  if (stored.size() != left.size())
    throw InputError(o.gt, "--gt",
                     fmt::format("ground truth is {}x{}, the left image {} is {}x{}", stored.cols, stored.rows, o.left,
                                 left.cols, left.rows));
  if (!(o.gt_scale > 0)) throw CLI::ValidationError("--gt-scale", "must be > 0");
  cv::Mat truth;
  stored.convertTo(truth, CV_32F, 1.0 / o.gt_scale);
  truth.setTo(std::numeric_limits<float>::quiet_NaN(), stored == 0);
  const long known = cv::countNonZero(stored);
  if (known == 0) throw InputError(o.gt, "--gt", "no pixel with a known disparity (every value is 0)");

  int dmin = 0, dmax = 0;
  if (o.dmin.has_value() != o.dmax.has_value()) throw CLI::ValidationError("--dmin/--dmax", "give both or neither");
  if (o.dmin) {
    dmin = *o.dmin;
    dmax = *o.dmax;
    if (dmax <= dmin) throw CLI::ValidationError("--dmax", fmt::format("must be above --dmin {}, got {}", dmin, dmax));
  } else {
    double lo = 0, hi = 0;
    cv::minMaxLoc(truth, &lo, &hi, nullptr, nullptr, stored != 0);
    dmin = static_cast<int>(std::floor(lo));
    dmax = static_cast<int>(std::ceil(hi));
  }
  const DisparityBand band{dmin, (dmax - dmin + 1 + 15) / 16 * 16};
  if (band.min_disparity + band.num_disparities >= left.cols)
    throw CLI::ValidationError(
        "--dmax", fmt::format("searched disparities {}..{} leave no column of the {} px wide "
                              "image to match",
                              band.min_disparity, band.min_disparity + band.num_disparities - 1, left.cols));
  std::fprintf(o.json ? stderr : stdout, "%s: %dx%d, %ld pixels with known disparity, disparities searched %d..%d px\n",
               o.left.c_str(), left.cols, left.rows, known, band.min_disparity,
               band.min_disparity + band.num_disparities - 1);
  if (!o.json)
    std::printf("%-9s %-4s %8s %8s %8s %8s %9s %9s\n", "engine", "dic", "bad-0.5", "bad-1.0", "bad-2.0", "MAE px",
                "coverage", "ms");
  ProgressLine progress("bench --pair", o.engines.size() * 2);
  std::uint64_t done = 0;
  for (const std::string& name : o.engines) {
    const auto kind = parse_engine(name);
    if (!kind) throw CLI::ValidationError("--engines", "unknown engine '" + name + "'");
    auto engine = make_cpu_engine(*kind);
    cv::Mat warm;
    engine->compute(left, right, band, warm);  // first call allocates the engine's buffers
    for (bool dic : {false, true}) {
      // The median of three runs: one slow run on a shared machine does not make the figure.
      cv::Mat d;
      std::array<double, 3> runs{};
      DicWorkspace ws;
      for (double& ms : runs) {
        const auto t0 = std::chrono::steady_clock::now();
        engine->compute(left, right, band, d);
        if (dic) refine_disparity_dic(left, right, d, DicConfig{}, ws);
        ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      }
      std::sort(runs.begin(), runs.end());
      const double ms = runs[1];
      const PairStats s = score(d, truth);
      progress.clear();
      if (o.json) {
        std::printf(
            "{\"engine\":\"%s\",\"dic\":%s,\"width\":%d,\"height\":%d,\"dmin\":%d,\"dmax\":%d,"
            "\"bad_0_5\":%.4f,\"bad_1_0\":%.4f,\"bad_2_0\":%.4f,\"mae_px\":%.5f,\"coverage\":%.5f,"
            "\"ms\":%.2f}\n",
            name.c_str(), dic ? "true" : "false", left.cols, left.rows, band.min_disparity,
            band.min_disparity + band.num_disparities - 1, s.bad05, s.bad1, s.bad2, s.mae, s.coverage, ms);
      } else {
        std::printf("%-9s %-4s %7.2f%% %7.2f%% %7.2f%% %8.3f %8.1f%% %9.1f\n", name.c_str(), dic ? "on" : "off",
                    s.bad05, s.bad1, s.bad2, s.mae, 100.0 * s.coverage, ms);
      }
      std::fflush(stdout);
      progress.update(++done);
    }
  }
  return 0;
}

}  // namespace rutd
