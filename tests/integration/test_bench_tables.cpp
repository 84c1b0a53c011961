// rutd bench --tables on a tiny configuration (one engine, 320x240, 0.5 s per rate): every table's rows
// are there with figures that make sense against the renderer's truth, in JSON and as text.
#include <cmath>
#include <cstdio>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "test_support.hpp"

namespace rutd {
namespace {

bool has(const std::string& line, const std::string& fragment) { return line.find(fragment) != std::string::npos; }

TEST(BenchTables, JsonRowsOfAllThreeTables) {
  int status = -1;
  const std::string out =
      test::run_rutd_output("bench --tables 1,2,3 --json --seconds 0.5 --sizes 320x240 --engines sgbm3way", status);
  ASSERT_EQ(status, 0) << out;
  std::vector<std::string> t1, t2, t3;
  std::istringstream in(out);
  for (std::string line; std::getline(in, line);) {
    ASSERT_EQ(line.front(), '{') << "stdout carries only JSON lines: " << line;
    if (has(line, "\"table\":1,")) t1.push_back(line);
    if (has(line, "\"table\":2,")) t2.push_back(line);
    if (has(line, "\"table\":3,")) t3.push_back(line);
  }
  ASSERT_EQ(t1.size(), 4u) << out;  // strip, full x DIC off, on
  for (const auto& l : t1) {
    EXPECT_TRUE(has(l, "\"engine\":\"sgbm3way\"") && has(l, "\"width\":320") && has(l, "\"height\":240")) << l;
    EXPECT_GT(test::json_number(l, "hz"), 0.0) << l;
    EXPECT_NEAR(test::json_number(l, "hz") * test::json_number(l, "ms"), 1000.0, 1.0) << l;
    // Rows rectified and matched: every row in full mode; the 24-row strip and its matching margin otherwise.
    if (has(l, "\"mode\":\"full\"")) EXPECT_EQ(test::json_number(l, "rows"), 240) << l;
    else EXPECT_TRUE(test::json_number(l, "rows") >= 24 && test::json_number(l, "rows") <= 64) << l;
  }
  ASSERT_EQ(t2.size(), 2u) << out;
  for (const auto& l : t2) {
    // The measured strip against the exact surface: unbiased to well under a millimetre.
    EXPECT_LT(std::abs(test::json_number(l, "mean_mm")), 1.0) << l;
    EXPECT_LT(test::json_number(l, "std_mm"), 5.0) << l;
    EXPECT_GT(test::json_number(l, "points"), 1000) << l;
  }
  ASSERT_EQ(t3.size(), 8u) << out;  // 30, 40, 50, 60 mm x DIC off, on
  double truths[4] = {30, 40, 50, 60};
  for (std::size_t i = 0; i < t3.size(); ++i) {
    const std::string& l = t3[i];
    EXPECT_NEAR(test::json_number(l, "truth_mm"), truths[i / 2], 0.5) << l;
    EXPECT_NEAR(test::json_number(l, "error_mm"), test::json_number(l, "depth_mm") - test::json_number(l, "truth_mm"),
                2e-4)
        << l;
    if (has(l, "\"dic\":true")) {
      EXPECT_TRUE(has(l, "\"status\":\"OK\"")) << l;
      EXPECT_LT(std::abs(test::json_number(l, "error_mm")), 1.5) << l;
    }
  }
}

TEST(BenchTables, TextTablesAndBadTableNumber) {
  int status = -1;
  const std::string out = test::run_rutd_output("bench --tables 3 --sizes 200x160 --engines bm", status);
  ASSERT_EQ(status, 0) << out;
  EXPECT_TRUE(has(out, "Table 3: rut depth measured")) << out;
  EXPECT_FALSE(has(out, "Table 1")) << out;
  EXPECT_TRUE(has(out, "bm        200x160    on")) << out;
  test::TempDir tmp;
  const std::string err = (tmp.path() / "err.txt").string();
  EXPECT_NE(test::run_rutd("bench --tables 4", err), 0);
  EXPECT_TRUE(has(test::read_text(err), "--tables")) << test::read_text(err);
}

}  // namespace
}  // namespace rutd
