// Rectification on the GPU engine's device (MeasurerConfig::rectify_on_device). The device resamples
// through the same float maps as the CPU rectifier with the same cubic B-spline, in an arithmetic fixed
// so that the device equals its C++ reference (gpu/rectify.hpp) byte for byte (rutd-gpu-check compares
// the two on randomised maps). Here, on rendered frames of the default rig:
//   - the reference against the CPU rectifier of StereoGeometry (OpenCV's maps, SIMD taps): the same
//     strips up to 1 grey level at rounding ties;
//   - the engine end to end: the strips the measurer gets back from the device equal the reference; the
//     first frame's band is estimated on the device (rectified there, its coarse pass matched there) and
//     holds the disparities the CPU-rectified measurer finds; later frames keep it and are rectified,
//     matched and refined in one submission; the depth is that of the same engine fed CPU-rectified strips;
//   - a jump of the terrain (two rigs sharing one calibration, 350 and 270 mm high) outside the kept band:
//     the band is estimated again on the device and every frame is measured;
//   - 16-bit frames, which the device does not take, are rectified on the CPU and measured as well.
// The engine tests skip only where no Vulkan driver is installed (the engine then falls back to the CPU) and
// fail where one is and the engine fell back all the same (skip_policy.hpp).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <vector>

#include <gtest/gtest.h>

#include "gpu/rectify.hpp"
#include "jump_rigs.hpp"
#include "pipeline/measurer.hpp"
#include "skip_policy.hpp"
#include "synthetic/synthetic_renderer.hpp"

namespace rutd {
namespace {

gpu::ImageView view(const cv::Mat& m) { return gpu::ImageView{m.data, m.cols, m.rows, m.step[0]}; }

cv::Mat reference_strip(const cv::Mat& raw, const std::vector<float>& map, const StereoGeometry& g) {
  std::vector<std::uint8_t> out;
  const int width = g.rectified_size().width, height = g.roi().rows;
  gpu::rectify_reference(view(raw), map, width, height, out);
  return cv::Mat(height, width, CV_8UC1, out.data()).clone();
}

struct StripDifference {
  double largest = 0;    // grey levels
  double identical = 0;  // share of pixels
};

StripDifference difference(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat d;
  cv::absdiff(a, b, d);
  StripDifference s;
  cv::minMaxLoc(d, nullptr, &s.largest);
  s.identical = 1.0 - static_cast<double>(cv::countNonZero(d)) / static_cast<double>(d.total());
  return s;
}

// The 2nd and 98th percentiles of the valid disparities, px.
std::pair<float, float> spread(const cv::Mat& disparity) {
  std::vector<float> v;
  for (auto it = disparity.begin<float>(); it != disparity.end<float>(); ++it)
    if (std::isfinite(*it)) v.push_back(*it);
  if (v.empty()) return {NAN, NAN};
  std::sort(v.begin(), v.end());
  return {v[v.size() * 2 / 100], v[v.size() * 98 / 100]};
}

MeasurerConfig gpu_config(bool on_device) {
  MeasurerConfig c;
  c.engine = EngineKind::Gpu;
  c.rectify_on_device = on_device;
  return c;
}

TEST(GpuRectify, ReferenceResamplesAsTheCpuRectifier) {
  int checked = 0;
  for (const Texture texture : {Texture::Sand, Texture::Grass}) {
    SyntheticRendererConfig config;
    config.texture = texture;
    config.rig.image_size = cv::Size(631, 479);  // odd width: the packed words' padding
    const SyntheticRenderer renderer(config);
    const StereoMeasurer measurer(renderer.calibration(), MeasurerConfig{});
    const StereoGeometry& g = measurer.geometry();
    StereoFrame frame;
    renderer.render(3, frame);
    cv::Mat left, right;
    g.rectify(frame.left, frame.right, left, right);
    const StripDifference dl = difference(reference_strip(frame.left, g.left_map(), g), left);
    const StripDifference dr = difference(reference_strip(frame.right, g.right_map(), g), right);
    const std::array<int, 2> rows = gpu::rectify_rows(
        gpu::RectifyMaps{g.raw_size().width, g.raw_size().height, left.cols, left.rows, g.left_map(), g.right_map()});
    std::printf(
        "%s: largest difference %.0f / %.0f grey, identical %.4f / %.4f (left / right, %dx%d strip; raw rows %d..%d "
        "of %d read)\n",
        texture == Texture::Sand ? "sand" : "grass", dl.largest, dr.largest, dl.identical, dr.identical, left.cols,
        left.rows, rows[0], rows[1] - 1, g.raw_size().height);
    // The rows the device uploads hold every tap: a strip reads a band of rows, not the whole image.
    EXPECT_LT(rows[1] - rows[0], g.raw_size().height / 2);
    EXPECT_LE(dl.largest, 1.0);
    EXPECT_LE(dr.largest, 1.0);
    EXPECT_GE(dl.identical, 0.99);
    EXPECT_GE(dr.identical, 0.99);
    ++checked;
  }
  EXPECT_EQ(checked, 2);
}

TEST(GpuRectify, EngineRectifiesOnItsDeviceAsTheReferenceAndMeasuresAsFromCpuStrips) {
  SyntheticRendererConfig config;
  config.rut.depth_mm = 40;
  const SyntheticRenderer renderer(config);
  const StereoMeasurer device(renderer.calibration(), gpu_config(true));
  const StereoMeasurer host(renderer.calibration(), gpu_config(false));
  MatchContext device_context = device.make_match_context(), host_context = host.make_match_context();
  if (device_context.engine->kind() != EngineKind::Gpu) RUTD_SKIP_GPU_FELL_BACK("the GPU engine fell back to sgmref");
  const StereoGeometry& g = device.geometry();
  RutWorkspace ws;
  int checked = 0;
  for (std::uint64_t i = 0; i < 4; ++i) {
    FrameWork on, off;
    renderer.render(i, on.frame);
    off.frame = on.frame;
    ASSERT_TRUE(device.rectify(on));
    EXPECT_FALSE(on.strips_ready) << "the rectify stage left the strips to the engine";
    device.match(on, device_context);
    device.extract(on, ws);
    ASSERT_TRUE(host.rectify(off));
    host.match(off, host_context);
    host.extract(off, ws);

    ASSERT_TRUE(on.strips_ready);
    EXPECT_TRUE(on.diag.rectified_on_device) << "frame " << i;
    EXPECT_FALSE(off.diag.rectified_on_device) << "frame " << i;
    // Frame 0 estimates its band on the device; later frames keep the band and go to the device in one
    // submission. No frame is rectified on the CPU.
    EXPECT_EQ(on.diag.band_estimated, i == 0) << "frame " << i;
    EXPECT_EQ(on.diag.band_on_device, i == 0) << "frame " << i;
    EXPECT_FALSE(off.diag.band_on_device) << "frame " << i;
    EXPECT_EQ(on.diag.rectify_ms, 0.0) << "frame " << i;
    const auto [lo, hi] = spread(off.disparity);
    const int band_hi = on.diag.band.min_disparity + on.diag.band.num_disparities - 1;
    EXPECT_GE(lo, on.diag.band.min_disparity) << "frame " << i;
    EXPECT_LE(hi, band_hi) << "frame " << i;
    const StripDifference exact_l = difference(on.left_strip, reference_strip(on.frame.left, g.left_map(), g));
    const StripDifference exact_r = difference(on.right_strip, reference_strip(on.frame.right, g.right_map(), g));
    EXPECT_EQ(exact_l.largest, 0.0) << "frame " << i;
    EXPECT_EQ(exact_r.largest, 0.0) << "frame " << i;
    const StripDifference cpu = difference(on.left_strip, off.left_strip);
    std::printf(
        "frame %llu: band %d+%d %s (CPU-rectified: %d+%d; disparities %.1f..%.1f); device strips = reference; "
        "against the CPU's: largest %.0f grey, identical %.4f; depth %.3f mm (CPU strips %.3f, truth %.3f)\n",
        static_cast<unsigned long long>(i), on.diag.band.min_disparity, on.diag.band.num_disparities,
        on.diag.band_estimated ? "estimated on the device" : "kept", off.diag.band.min_disparity,
        off.diag.band.num_disparities, lo, hi, cpu.largest, cpu.identical, on.measurement.depth_mm,
        off.measurement.depth_mm, renderer.truth(i).depth_mm);
    EXPECT_LE(cpu.largest, 1.0);
    ASSERT_EQ(on.measurement.status, RutStatus::Ok) << "frame " << i;
    ASSERT_EQ(off.measurement.status, RutStatus::Ok) << "frame " << i;
    EXPECT_NEAR(on.measurement.depth_mm, off.measurement.depth_mm, 0.1) << "frame " << i;
    EXPECT_NEAR(on.measurement.depth_mm, renderer.truth(i).depth_mm, 1.0) << "frame " << i;
    ++checked;
  }
  EXPECT_EQ(checked, 4);
}

TEST(GpuRectify, BandFollowsAJumpOnTheDevice) {
  const test::JumpRigs rigs;
  const SyntheticRenderer &high_renderer = rigs.high, &low_renderer = rigs.low;
  StereoMeasurer measurer(high_renderer.calibration(), gpu_config(true));
  const std::vector<bool> is_low = {false, false, true, true, false};
  std::vector<bool> on_device;
  int checked = 0;
  for (std::size_t i = 0; i < is_low.size(); ++i) {
    const SyntheticRenderer& r = is_low[i] ? low_renderer : high_renderer;
    StereoFrame frame;
    r.render(i, frame);
    const RutMeasurement m = measurer.measure(frame.left, frame.right);
    const MeasurementDiagnostics& d = measurer.diagnostics();
    if (i == 0 && !d.rectified_on_device) RUTD_SKIP_GPU_FELL_BACK("the pair was not rectified on a device");
    on_device.push_back(d.band_on_device);
    std::printf("frame %zu (%s): band %d+%d %s, depth %.3f mm (truth %.3f)\n", i, is_low[i] ? "low" : "high",
                d.band.min_disparity, d.band.num_disparities,
                d.band_on_device   ? "estimated on the device"
                : d.band_estimated ? "estimated on the CPU"
                                   : "kept",
                m.depth_mm, r.truth(i).depth_mm);
    EXPECT_TRUE(d.rectified_on_device) << "frame " << i;
    ASSERT_EQ(m.status, RutStatus::Ok) << "frame " << i;
    EXPECT_NEAR(m.depth_mm, r.truth(i).depth_mm, 0.5) << "frame " << i;
    ++checked;
  }
  EXPECT_EQ(checked, 5);
  // Estimated on the first frame and at both jumps, kept between.
  EXPECT_EQ(on_device, (std::vector<bool>{true, false, true, false, true}));
}

TEST(GpuRectify, SixteenBitFramesAreRectifiedOnTheCpu) {
  SyntheticRendererConfig config;
  config.bit_depth = 16;
  config.rut.depth_mm = 50;
  const SyntheticRenderer renderer(config);
  StereoMeasurer measurer(renderer.calibration(), gpu_config(true));
  StereoFrame frame;
  renderer.render(0, frame);
  ASSERT_EQ(frame.left.type(), CV_16UC1);
  const RutMeasurement m = measurer.measure(frame.left, frame.right);
  std::printf("16-bit frame: depth %.3f mm (truth %.3f), rectified on the %s\n", m.depth_mm, renderer.truth(0).depth_mm,
              measurer.diagnostics().rectified_on_device ? "device" : "CPU");
  EXPECT_FALSE(measurer.diagnostics().rectified_on_device);
  ASSERT_EQ(m.status, RutStatus::Ok);
  EXPECT_NEAR(m.depth_mm, renderer.truth(0).depth_mm, 1.0);
}

}  // namespace
}  // namespace rutd
