// Per-strip cost of the CPU disparity engines and of the DIC refinement, on textured strips of
// 640x48 and 1280x64 px with a 64 px band (the sizes and band of a narrow-band rut strip), and of the
// rectification of a rendered pair (strip and full frame), and of the light check's look at its raw images.
#include <benchmark/benchmark.h>
#include <opencv2/imgproc.hpp>

#include "engines/disparity_engine.hpp"
#include "engines/engine_factory.hpp"
#include "geometry/stereo_geometry.hpp"
#include "measurement/frame_checks.hpp"
#include "refinement/dic_refine.hpp"
#include "synthetic/synthetic_renderer.hpp"

namespace {

using rutd::EngineKind;

struct Strips {
  cv::Mat left, right;
};

// Smoothed random texture; the right view is the left shifted by 40.3 px (cubic interpolation).
Strips make_strips(cv::Size size) {
  cv::Mat canvas(size.height, size.width + 64, CV_32FC1);
  cv::RNG rng(7);
  rng.fill(canvas, cv::RNG::NORMAL, 0.0, 1.0);
  cv::GaussianBlur(canvas, canvas, cv::Size(0, 0), 1.2);
  cv::normalize(canvas, canvas, 20, 235, cv::NORM_MINMAX);
  Strips s;
  canvas.colRange(0, size.width).convertTo(s.left, CV_8U);
  const cv::Matx23d shift(1, 0, -40.3, 0, 1, 0);  // right(x) = left(x + 40.3)
  cv::Mat right;
  cv::warpAffine(canvas, right, shift, canvas.size(), cv::INTER_CUBIC, cv::BORDER_REFLECT);
  right.colRange(0, size.width).convertTo(s.right, CV_8U);
  return s;
}

constexpr rutd::DisparityBand kBand{16, 64};

cv::Size size_of(const benchmark::State& state) {
  return {static_cast<int>(state.range(1)), static_cast<int>(state.range(2))};
}

void BM_Engine(benchmark::State& state) {
  const auto kind = static_cast<EngineKind>(state.range(0));
  const Strips s = make_strips(size_of(state));
  auto engine = rutd::make_cpu_engine(kind);
  cv::Mat disparity;
  for (auto _ : state) {
    engine->compute(s.left, s.right, kBand, disparity);
    benchmark::DoNotOptimize(disparity.data);
  }
  state.SetLabel(std::string(rutd::to_string(kind)));
}

// DIC on the SGBM disparity of the strip; each iteration restores the engine's disparity first (a
// ~0.1 ms copy, included). `step` as given, row_step: 0 (= step) or as given; `margin` rows at the top
// and bottom are context only (refined rows [margin, rows - margin)), as the measurer does.
void BM_Dic(benchmark::State& state) {
  const Strips s = make_strips({static_cast<int>(state.range(2)), static_cast<int>(state.range(3))});
  auto engine = rutd::make_cpu_engine(EngineKind::Sgbm);
  cv::Mat initial, disparity;
  engine->compute(s.left, s.right, kBand, initial);
  rutd::DicConfig params;
  params.step = static_cast<int>(state.range(0));
  params.row_step = static_cast<int>(state.range(1));
  const int margin = static_cast<int>(state.range(4));
  params.row_begin = margin;
  params.row_end = static_cast<int>(state.range(3)) - margin;
  params.column_windows = state.range(5) != 0;
  rutd::DicWorkspace ws;
  rutd::DicStats stats;
  for (auto _ : state) {
    initial.copyTo(disparity);
    stats = rutd::refine_disparity_dic(s.left, s.right, disparity, params, ws);
  }
  state.counters["refined"] = stats.refined;
  state.counters["rejected"] = stats.rejected;
  state.counters["iterations"] = stats.mean_iterations;
}

void engine_args(benchmark::internal::Benchmark* b) {
  for (EngineKind kind : {EngineKind::Bm, EngineKind::Sgbm, EngineKind::Sgbm3Way, EngineKind::Hh4, EngineKind::Hh}) {
    b->Args({static_cast<long>(kind), 640, 48});
    b->Args({static_cast<long>(kind), 1280, 64});
  }
  b->ArgNames({"engine", "width", "rows"});
}

void dic_args(benchmark::internal::Benchmark* b) {
  for (long step : {1, 2}) {
    b->Args({step, 0, 640, 48, 0, 0});
    b->Args({step, 0, 1280, 64, 0, 0});
  }
  // Per-pixel windows on every column of every other row of a 48-row strip matched with 7 rows of
  // context on each side (full-frame mode's grid), and the measurer's strip default: one window per
  // column spanning the 48 measured rows.
  for (long columns : {0, 1}) {
    b->Args({1, 2, 640, 62, 7, columns});
    b->Args({1, 2, 1280, 78, 7, columns});
  }
  b->ArgNames({"step", "row_step", "width", "rows", "margin", "columns"});
}

// The default synthetic pair at the benchmark's size (its first two arguments), and its calibration.
struct RenderedPair {
  rutd::StereoFrame frame;
  rutd::StereoCalibration calibration;
  explicit RenderedPair(const benchmark::State& state) {
    rutd::SyntheticRendererConfig config;
    config.rig.image_size = cv::Size(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
    const rutd::SyntheticRenderer renderer(config);
    renderer.render(0, frame);
    calibration = renderer.calibration();
  }
};

// Both raw images of a rendered 8-bit pair to rectified strips: `rows` centred rows (the default strip
// with its matching margin is 62 rows of 480) or the full frame.
void BM_Rectify(benchmark::State& state) {
  const RenderedPair pair(state);
  const rutd::StereoFrame& frame = pair.frame;
  const int rows = static_cast<int>(state.range(2));
  const rutd::StereoGeometry geometry(pair.calibration, rutd::StripRoi{(frame.left.rows - rows) / 2, rows});
  cv::Mat left, right;
  for (auto _ : state) {
    geometry.rectify(frame.left, frame.right, left, right);
    benchmark::DoNotOptimize(left.data);
  }
}

// The light check's look at both raw images of a rendered pair (measurement/frame_checks.hpp,
// image_signal): 16 rows each about the strip, as the measurer reads them on every frame.
void BM_ImageSignal(benchmark::State& state) {
  const RenderedPair pair(state);
  const rutd::StereoFrame& frame = pair.frame;
  const int rows = static_cast<int>(state.range(2)), row0 = (frame.left.rows - rows) / 2;
  std::vector<std::uint32_t> histogram;
  for (auto _ : state) {
    const rutd::ImageSignal l = rutd::image_signal(frame.left, row0, row0 + rows, 16, histogram);
    const rutd::ImageSignal r = rutd::image_signal(frame.right, row0, row0 + rows, 16, histogram);
    benchmark::DoNotOptimize(l.texture_to_noise + r.texture_to_noise);
  }
}

BENCHMARK(BM_Rectify)
    ->Args({640, 480, 62})
    ->Args({640, 480, 480})
    ->Args({1280, 1024, 78})
    ->ArgNames({"width", "height", "rows"})
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ImageSignal)
    ->Args({640, 480, 48})
    ->Args({1280, 1024, 64})
    ->ArgNames({"width", "height", "rows"})
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Engine)->Apply(engine_args)->Unit(benchmark::kMillisecond);
// CPU time: of all threads (the refinement splits rows across OpenCV's workers).
BENCHMARK(BM_Dic)->Apply(dic_args)->MeasureProcessCPUTime()->UseRealTime()->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
