// `rutd bench --json` through the program: every run is one JSON object (decoded by Python's json module,
// not by us) with the documented keys, and the strip runs' depths match the renderer's truth.
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

}  // namespace
}  // namespace rutd
