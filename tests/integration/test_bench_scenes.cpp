// `rutd bench --scenes` through the program: the scene matrix's JSON lines decoded by Python's json module
// (not by us) with every scene's counts recomputed from its frames, the text table's rows, and a bad
// --only refused naming the option. The matrix's outcomes are reported, not judged, here.
#include <regex>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "test_support.hpp"

namespace rutd {
namespace {

// One scene of each group: clear water (published wrong today), a lens fault, a clean rut, a skewed pair.
const std::string kOnly = "'^(water-clear-sand-25|lens-mud-left-sand|clean-manual-sand-16|skew-sand-00)$'";

TEST(BenchScenes, JsonLinesCountEveryFrameAgainstTheTruth) {
  test::TempDir dir;
  const auto out = dir.path() / "scenes.jsonl";
  const auto err = dir.path() / "scenes.err";
  ASSERT_EQ(test::run_rutd("bench --scenes --only " + kOnly + " --frames 2 --json >" + test::quoted(out), err.string()),
            0)
      << test::read_text(err);
  // The summary goes to stderr, so stdout is JSON only.
  EXPECT_NE(test::read_text(err).find("false alarms"), std::string::npos) << test::read_text(err);
  const std::string check = std::string("python3 ") + test::quoted(RUTD_SOURCE_DIR) +
                            "/tests/integration/check_scene_matrix_json.py " + test::quoted(out) + " 4 2 " +
                            test::quoted(err);
  EXPECT_EQ(test::run_shell(check), 0) << test::read_text(out);
}

TEST(BenchScenes, TextTableHasARowPerSceneAndTheirSynthOptions) {
  test::TempDir dir;
  const auto out = dir.path() / "scenes.txt";
  ASSERT_EQ(test::run_rutd("bench --scenes --only " + kOnly + " --frames 1 >" + test::quoted(out)), 0);
  const std::string text = test::read_text(out);
  // The scene rows, then the kind table (check_scene_matrix_json.py recomputes its counts).
  const std::size_t kinds = text.find("\nkind ");
  ASSERT_NE(kinds, std::string::npos) << text;
  const std::string scenes = text.substr(0, kinds);
  // "NAME GROUP FRAMES OK<=1 OK>1 WORST T/N REF<=1 RIGHT-FLAG REFUSED"
  const std::regex row(
      "\\n([a-z0-9-]+) +(spoiled|clean|skew) +1 +([01]) +([01]) +([0-9.]+|-) +([0-9.]+) +([01]) +(\\d/\\d|-)  ");
  int rows = 0;
  for (std::sregex_iterator it(scenes.begin(), scenes.end(), row), end; it != end; ++it, ++rows) {
    const std::smatch& m = *it;
    EXPECT_LE(std::stoi(m[3]) + std::stoi(m[4]) + std::stoi(m[7]), 1) << m.str();
    // Each scene's options follow the table, ready for rutd synth.
    EXPECT_NE(text.find("\n" + m[1].str() + " "), text.rfind("\n" + m[1].str() + " ")) << m[1];
  }
  EXPECT_EQ(rows, 4) << text;
  EXPECT_NE(text.find("--lens mud:left:"), std::string::npos);
}

// Each frame flagged Water names the rule that flagged it, the one the renderer's water calls for: opaque
// turbid water hides the bottom below a waterline on both walls, the bottom under clear water is read
// through it and published, a foam lid is a level span unlike the soil, a dry rut has no rule.
TEST(BenchScenes, EachWaterFlagNamesTheRuleThatRaisedIt) {
  test::TempDir dir;
  const auto out = dir.path() / "water.jsonl";
  const std::vector<std::pair<std::string, std::string>> want = {{"water-turbid-sand-00", "\"waterline_hides\""},
                                                                 {"water-clear-sand-25", "\"read_through\""},
                                                                 {"lid-foam-snow-06", "\"lid\""},
                                                                 {"clean-manual-sand-16", "null"}};
  std::string only;
  for (const auto& [scene, rule] : want) only += (only.empty() ? "" : "|") + scene;
  ASSERT_EQ(test::run_rutd("bench --scenes --only '^(" + only + ")$' --frames 2 --json >" + test::quoted(out)), 0);
  const std::string text = test::read_text(out);
  const std::regex rule_of_frame("\"water_rule\":(null|\"[a-z_]+\")");
  int frames = 0;
  for (const auto& [scene, rule] : want) {
    const std::size_t at = text.find("{\"scene\":\"" + scene + "\"");
    ASSERT_NE(at, std::string::npos) << scene;
    const std::string line = text.substr(at, text.find('\n', at) - at);
    for (std::sregex_iterator it(line.begin(), line.end(), rule_of_frame), end; it != end; ++it, ++frames)
      EXPECT_EQ((*it)[1].str(), rule) << scene;
  }
  EXPECT_EQ(frames, 8);
}

TEST(BenchScenes, BadSelectionIsRefusedNamingTheOption) {
  test::TempDir dir;
  const auto err = dir.path() / "err";
  EXPECT_NE(test::run_rutd("bench --scenes --only '(' >/dev/null", err.string()), 0);
  EXPECT_NE(test::read_text(err).find("--only: not a regular expression"), std::string::npos) << test::read_text(err);
  EXPECT_NE(test::run_rutd("bench --scenes --only no-such-scene >/dev/null", err.string()), 0);
  EXPECT_NE(test::read_text(err).find("--only: selects no scene"), std::string::npos) << test::read_text(err);
  EXPECT_NE(test::run_rutd("bench --only water >/dev/null", err.string()), 0);  // --only belongs to --scenes
  EXPECT_NE(test::read_text(err).find("--scenes"), std::string::npos) << test::read_text(err);
}

}  // namespace
}  // namespace rutd
