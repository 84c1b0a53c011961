// `rutd bench --json` through the program: every run is one JSON object (decoded by Python's json module,
// not by us) with the documented keys, and the strip runs' depths match the renderer's truth.
#include <regex>
#include <string>

#include <gtest/gtest.h>

#include "test_support.hpp"

namespace rutd {
namespace {

TEST(BenchJson, EveryRunIsOneJsonLineAndStripDepthsMatchTheTruth) {
  test::TempDir dir;
  const auto out = dir.path() / "bench.jsonl";
  const auto err = dir.path() / "bench.err";
  ASSERT_EQ(test::run_rutd("bench --seconds 1 --frames 2 --json >" + test::quoted(out), err.string()), 0)
      << test::read_text(err);
  // The people's header goes to stderr, so stdout is JSON only.
  EXPECT_NE(test::read_text(err).find("synthetic pairs"), std::string::npos);
  const std::string check = std::string("python3 ") + test::quoted(RUTD_SOURCE_DIR) +
                            "/tests/integration/check_bench_json.py " + test::quoted(out) + " 0.5";
  EXPECT_EQ(test::run_shell(check), 0) << test::read_text(out);
}

// The plain `rutd bench` (text rows) with its options: the image size, the engine and DIC setting, and
// the live regime paced at --fps (it cannot publish more pairs than the camera rate delivers), against
// the renderer's truth depth.
TEST(Bench, TextRowsFollowTheOptionsAndTheLiveRunKeepsTheCameraRate) {
  test::TempDir dir;
  const auto out = dir.path() / "bench.txt";
  constexpr double kSeconds = 1.0, kFps = 10.0;
  ASSERT_EQ(test::run_rutd("bench --seconds 1 --fps 10 --frames 2 --size 320x240 --engine sgbm >" + test::quoted(out)),
            0);
  const std::string text = test::read_text(out);
  EXPECT_NE(text.find("320x240 synthetic pairs"), std::string::npos) << text;
  EXPECT_NE(text.find("engine sgbm, DIC on"), std::string::npos) << text;
  // "MODE REGIME rows A..B  published N (K ok, depth D mm, worst error E mm)  H Hz ..."
  const std::regex row(
      "(strip|full) +(throughput|live) +rows +(\\d+)\\.\\. *(\\d+) +published +(\\d+) \\( *(\\d+) ok, depth "
      "([0-9.]+) mm, worst error ([0-9.]+) mm\\)");
  int rows = 0;
  for (std::sregex_iterator it(text.begin(), text.end(), row), end; it != end; ++it, ++rows) {
    const std::smatch& m = *it;
    SCOPED_TRACE(m.str());
    const int first = std::stoi(m[3]), last = std::stoi(m[4]);
    const long published = std::stol(m[5]), ok = std::stol(m[6]);
    if (m[1] == "full") {
      EXPECT_EQ(first, 0);
      EXPECT_EQ(last, 240);
    } else {
      EXPECT_GT(first, 0);
      EXPECT_LT(last - first, 240);
    }
    if (m[2] == "live") {
      EXPECT_LE(published, static_cast<long>(kFps * kSeconds) + 2) << "not paced at --fps";
    }
    if (m[1] == "strip") {
      EXPECT_GT(ok, 0);
      // With DIC: within a millimetre of the truth, as the end-to-end tests ask (this small size and SGBM
      // give about 0.7 mm).
      EXPECT_LT(std::stod(m[8]), 1.0);
    }
  }
  EXPECT_EQ(rows, 4) << text;
}

}  // namespace
}  // namespace rutd
