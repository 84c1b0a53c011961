// `rutd run` with the GPU engine where no device fits: the daemon measures on the CPU reference engine and
// says why exactly once. Until the measurer made its own engine lazily, two engines each opened (or
// failed to open) the device, and the reason was logged twice.
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "test_support.hpp"

namespace rutd {
namespace {

TEST(GpuFallback, NoMatchingDeviceIsLoggedOnceAndTheDaemonMeasures) {
  const test::TempDir tmp;
  const std::string config = (tmp.path() / "gpu.yaml").string(), err = (tmp.path() / "err.txt").string();
  const std::string csv = (tmp.path() / "m.csv").string();
  std::ofstream(config) << "measurement:\n  engine: gpu\n  gpu_device: no-such-device-name\n";
  ASSERT_EQ(test::run_rutd("run --config " + config + " --frames 3 --size 320x240 --candump '' --csv " + csv, err), 0)
      << test::read_text(err);
  EXPECT_EQ(test::count_lines(err, "GPU engine unavailable"), 1) << test::read_text(err);
  // The published measurements reached the CSV: a header and a line each.
  std::ifstream in(csv);
  int lines = 0;
  for (std::string line; std::getline(in, line);) ++lines;
  EXPECT_GE(lines, 4) << test::read_text(csv);  // --frames 3: at least three; more may be in flight
}

}  // namespace
}  // namespace rutd
