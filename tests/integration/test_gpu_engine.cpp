// The GPU engine as a process runs it: one device per engine and per `rutd run`, the device named by
// `rutd run`, `rutd replay` and `rutd bench`, and faults at the lowest Vulkan calls (gpu/vulkan_faults.hpp:
// a device lost mid-run, a pipeline that fails to build) seen by the checks every GPU test makes
// (gpu_test_support.hpp), so that a GPU test fails, rather than passes on the CPU fallback, when the GPU
// path breaks. Skipped only where no Vulkan driver exists.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <regex>
#include <string>
#include <vector>

#include <gtest/gtest-spi.h>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "engines/engine_factory.hpp"
#include "gpu/vulkan_faults.hpp"
#include "gpu/vulkan_sgm.hpp"
#include "gpu_engine.hpp"
#include "gpu_test_support.hpp"
#include "known_disparity.hpp"

namespace rutd {
namespace {

// The device line the engine wrote to `stderr_text`: what follows "rutd: GPU engine on ".
std::string device_line(const std::string& stderr_text) {
  const std::size_t at = stderr_text.find(test::kGpuDeviceLine);
  if (at == std::string::npos) return {};
  const std::size_t from = at + std::string(test::kGpuDeviceLine).size();
  return stderr_text.substr(from, stderr_text.find('\n', from) - from);
}

// Disparities equal where both are valid, and valid at the same pixels.
bool same_disparities(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size()) return false;
  for (int y = 0; y < a.rows; ++y)
    for (int x = 0; x < a.cols; ++x) {
      const float u = a.at<float>(y, x), v = b.at<float>(y, x);
      if (std::isnan(u) != std::isnan(v) || (!std::isnan(u) && u != v)) return false;
    }
  return true;
}

// The 16-bit download decoded a row at a time (vectorised, collect()) as each pixel on its own (at()):
// invalid pixels NaN, every other value offset + v * step, bit for bit, over a width that is not a multiple
// of the vector and with rows padded (stride > width). Needs no device.
TEST(GpuEngine, DecodedRowsEqualThePixelDecode) {
  constexpr int kWidth = 77, kHeight = 5;
  constexpr std::size_t kStride = 80;
  std::vector<std::uint16_t> data(kStride * kHeight);
  for (std::size_t i = 0; i < data.size(); ++i)
    data[i] = i % 7 == 3 ? gpu::DisparityView::kInvalid : static_cast<std::uint16_t>((i * 2654435761u) >> 16);
  gpu::DisparityView view;
  view.data = data.data();
  view.width = kWidth;
  view.height = kHeight;
  view.stride = kStride;
  view.offset_px = -13.0f;
  view.step_px = 1.0f / 512;
  std::vector<float> row(kWidth + 1, 42.0f);
  int invalid = 0, valid = 0;
  for (int y = 0; y < kHeight; ++y) {
    view.decode_row(y, row.data());
    for (int x = 0; x < kWidth; ++x) {
      const float want = view.at(x, y);
      if (std::isnan(want)) {
        EXPECT_TRUE(std::isnan(row[static_cast<std::size_t>(x)])) << x << "," << y;
        ++invalid;
      } else {
        EXPECT_EQ(row[static_cast<std::size_t>(x)], want) << x << "," << y;
        ++valid;
      }
    }
    EXPECT_EQ(row[kWidth], 42.0f) << "decode_row wrote past the row's width";
  }
  EXPECT_GT(invalid, 40);
  EXPECT_GT(valid, 300);
}

// The winner-takes-all walks rows in 128-px segments by default on a GPU and whole rows on a CPU device
// (where segments only add work); an explicit segment is kept, and one under 16 px refused.
TEST(GpuEngine, WinnerTakesAllSegmentByDeviceType) {
  RUTD_SKIP_WITHOUT_VULKAN_DRIVER();
  gpu::VulkanSgm automatic("", 64, 24, 16);
  EXPECT_EQ(automatic.wta_segment(), automatic.device().type == "cpu" ? 0 : gpu::VulkanSgmOptions::kWtaSegmentGpu)
      << automatic.device().type;
  gpu::VulkanSgmOptions options;
  options.wta_segment = 32;
  EXPECT_EQ(gpu::VulkanSgm("", 64, 24, 16, options).wta_segment(), 32);
  // A workgroup of several subgroups walks whole rows (segments there failed a check on an H100).
  options.wta_threads = 2 * static_cast<int>(automatic.device().subgroup_size);
  EXPECT_EQ(gpu::VulkanSgm("", 64, 24, 16, options).wta_segment(), 0);
  options.wta_threads = 0;
  options.wta_segment = 8;
  EXPECT_THROW(gpu::VulkanSgm("", 64, 24, 16, options), gpu::GpuError);
}

TEST(GpuEngine, AggregationLanesByDeviceType) {
  RUTD_SKIP_WITHOUT_VULKAN_DRIVER();
  gpu::VulkanSgm automatic("", 64, 24, 16);
  const auto subgroup = static_cast<int>(automatic.device().subgroup_size);
  // A CPU device walks a line with the whole workgroup (its subgroup); a GPU with kAggregateLanesGpu.
  EXPECT_EQ(automatic.aggregate_lanes(),
            automatic.device().type == "cpu" ? subgroup : std::min(gpu::VulkanSgmOptions::kAggregateLanesGpu, subgroup))
      << automatic.device().type;
  gpu::VulkanSgmOptions options;
  options.aggregate_lanes = 2;
  EXPECT_EQ(gpu::VulkanSgm("", 64, 24, 16, options).aggregate_lanes(), 2);
  options.aggregate_lanes = 256;  // more than the workgroup: the workgroup
  EXPECT_EQ(gpu::VulkanSgm("", 64, 24, 16, options).aggregate_lanes(), subgroup);
  options.aggregate_lanes = 3;  // not a power of two
  EXPECT_THROW(gpu::VulkanSgm("", 64, 24, 16, options), gpu::GpuError);
  options.aggregate_lanes = -1;
  EXPECT_THROW(gpu::VulkanSgm("", 64, 24, 16, options), gpu::GpuError);
}

TEST(GpuEngine, DicWindowSubgroupsByDeviceAndWindow) {
  RUTD_SKIP_WITHOUT_VULKAN_DRIVER();
  gpu::DicKernelConfig strip, frame, pixels;
  strip.column_windows = frame.column_windows = true;
  strip.column_block_rows = 0;   // one block of the whole 48 rows
  frame.column_block_rows = 16;  // blocks of 16 rows
  gpu::VulkanSgm automatic("", 64, 48, 16);
  const bool cpu = automatic.device().type == "cpu";
  const auto subgroup = static_cast<int>(automatic.device().subgroup_size);
  // Several subgroups only for tall windows on a GPU (a CPU device runs barriers slowly).
  EXPECT_EQ(automatic.dic_subgroups_per_window(strip), cpu || subgroup < 4 ? 1 : std::max(1, 128 / subgroup));
  EXPECT_EQ(automatic.dic_subgroups_per_window(frame), 1);
  EXPECT_EQ(automatic.dic_subgroups_per_window(pixels), 1);
  gpu::VulkanSgmOptions options;
  options.dic_window_subgroups = 3;
  gpu::VulkanSgm three("", 64, 48, 16, options);
  EXPECT_EQ(three.dic_subgroups_per_window(frame), subgroup < 4 ? 1 : 3);
  EXPECT_EQ(three.dic_subgroups_per_window(pixels), 1);  // the per-pixel mode keeps one
  options.dic_window_subgroups = 17;
  EXPECT_THROW(gpu::VulkanSgm("", 64, 48, 16, options), gpu::GpuError);
}

TEST(GpuEngine, RunOpensOneDeviceAndNamesIt) {
  RUTD_SKIP_WITHOUT_VULKAN_DRIVER();
  const test::TempDir tmp;
  const std::string config = (tmp.path() / "gpu.yaml").string(), err = (tmp.path() / "err.txt").string();
  std::ofstream(config) << "measurement:\n  engine: gpu\n";
  ASSERT_EQ(test::run_rutd("run --config " + config + " --frames 3 --size 320x240 --candump ''", err), 0)
      << test::read_text(err);
  // One engine, one device, for the whole daemon (the measurer makes no engine of its own).
  test::expect_ran_on_gpu(test::read_text(err));
}

TEST(GpuEngine, ReplayAndBenchNameTheDeviceThatRan) {
  RUTD_SKIP_WITHOUT_VULKAN_DRIVER();
  const test::TempDir tmp;
  const std::string rec = (tmp.path() / "rec").string(), err = (tmp.path() / "err.txt").string();
  ASSERT_EQ(test::run_rutd("synth " + rec + " --frames 2 --size 320x240 >/dev/null"), 0);
  ASSERT_EQ(test::run_rutd("replay " + rec + " --engine gpu --out " + (tmp.path() / "m.csv").string(), err), 0)
      << test::read_text(err);
  const std::string replay_err = test::read_text(err);
  test::expect_ran_on_gpu(replay_err);
  const std::string device = device_line(replay_err);
  ASSERT_FALSE(device.empty()) << replay_err;
  EXPECT_NE(replay_err.find("with engine gpu + DIC on " + device), std::string::npos) << replay_err;

  int status = -1;
  const std::string out =
      test::run_rutd_output("bench --engine gpu --size 128x96 --seconds 0.5 --frames 1 --json", status);
  ASSERT_EQ(status, 0) << out;
  int runs = 0;
  std::istringstream lines(out);
  for (std::string line; std::getline(lines, line);) {
    ++runs;
    EXPECT_NE(line.find("\"device\":\"" + device + "\""), std::string::npos) << line;
  }
  EXPECT_EQ(runs, 4) << out;
}

// Buffers follow the frame size and the widest band on the device the engine opened first.
TEST(GpuEngine, NewSizesAndBandsKeepTheOneDevice) {
  RUTD_SKIP_WITHOUT_VULKAN_DRIVER();
  const std::uint64_t opened = gpu::gpu_devices_opened();
  const auto engine = make_engine(EngineKind::Gpu);
  test::expect_on_gpu(*engine);
  const auto reference = make_cpu_engine(EngineKind::SgmRef);
  int checked = 0;
  for (const auto& [size, band] :
       {std::pair{cv::Size(160, 24), DisparityBand{8, 32}}, std::pair{cv::Size(200, 40), DisparityBand{8, 32}},
        std::pair{cv::Size(200, 40), DisparityBand{0, 160}}}) {
    const known_disparity::Pair pair = known_disparity::render_pair(20.4, 0.0, size, 31);
    cv::Mat gpu, cpu;
    engine->compute(pair.left, pair.right, band, gpu);
    reference->compute(pair.left, pair.right, band, cpu);
    EXPECT_TRUE(same_disparities(gpu, cpu)) << size << " band " << band.min_disparity << "+" << band.num_disparities;
    ++checked;
  }
  EXPECT_EQ(checked, 3);
  test::expect_on_gpu(*engine);
  EXPECT_EQ(gpu::gpu_devices_opened() - opened, 1u);
}

// A device lost mid-run: the engine measures on (on the CPU reference, the same disparities), and the
// GPU tests' check fails.
void expect_fault_fails_the_gpu_check(gpu::VulkanCall call, gpu::VulkanFault fault, const char* says) {
  gpu::VulkanFaults faults;
  faults.set(call, gpu::VulkanFaultRule{fault, /*after=*/2, /*count=*/1});
  const auto engine = make_gpu_engine(EngineConfig{}, &faults);
  const auto reference = make_cpu_engine(EngineKind::SgmRef);
  const known_disparity::Pair pair = known_disparity::render_pair(20.4, 0.0, cv::Size(160, 24), 32);
  for (int frame = 0; frame < 4; ++frame) {
    cv::Mat gpu, cpu;
    engine->compute(pair.left, pair.right, {8, 32}, gpu);
    reference->compute(pair.left, pair.right, {8, 32}, cpu);
    EXPECT_TRUE(same_disparities(gpu, cpu)) << "frame " << frame;
  }
  EXPECT_EQ(faults.injected(call), 1u);
  EXPECT_EQ(engine->kind(), EngineKind::SgmRef);
  EXPECT_NE(engine->device().find(says), std::string::npos) << engine->device();
  EXPECT_NONFATAL_FAILURE(test::expect_on_gpu(*engine), "the GPU engine fell back to the CPU");
}

TEST(GpuEngine, DeviceLostAtSubmitFailsTheGpuCheck) {
  RUTD_SKIP_WITHOUT_VULKAN_DRIVER();
  expect_fault_fails_the_gpu_check(gpu::VulkanCall::QueueSubmit, gpu::VulkanFault::DeviceLost, "device lost");
}

TEST(GpuEngine, DeviceLostWhileWaitingFailsTheGpuCheck) {
  RUTD_SKIP_WITHOUT_VULKAN_DRIVER();
  expect_fault_fails_the_gpu_check(gpu::VulkanCall::WaitForFrame, gpu::VulkanFault::DeviceLost, "device lost");
}

TEST(GpuEngine, PipelineThatFailsToBuildFailsTheGpuCheck) {
  RUTD_SKIP_WITHOUT_VULKAN_DRIVER();
  gpu::VulkanFaults faults;
  faults.set(gpu::VulkanCall::CreatePipeline, gpu::VulkanFaultRule{gpu::VulkanFault::InitializationFailed, 3, 1});
  const auto engine = make_gpu_engine(EngineConfig{}, &faults);
  EXPECT_EQ(faults.injected(gpu::VulkanCall::CreatePipeline), 1u);
  EXPECT_NE(engine->device().find("vkCreateComputePipelines: VK_ERROR_INITIALIZATION_FAILED"), std::string::npos)
      << engine->device();
  EXPECT_NONFATAL_FAILURE(test::expect_on_gpu(*engine), "the GPU engine fell back to the CPU");
  // A command whose engine opened its device and fell back later fails the check of `rutd` runs.
  EXPECT_NONFATAL_FAILURE(test::expect_ran_on_gpu(std::string(test::kGpuDeviceLine) +
                                                  "a device\nrutd: GPU engine unavailable (a device: device lost)\n"),
                          "the GPU engine fell back to the CPU");
}

}  // namespace
}  // namespace rutd
