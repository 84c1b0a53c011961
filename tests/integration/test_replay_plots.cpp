// rutd replay --plots on a rendered recording whose rut appears after three frames: the frames
// chosen (every N-th, and the first of each status change) get their three PNGs, the run its series plot,
// all readable at their sizes; a --plots path that is a file is one clear error; and no progress line
// reaches a stderr that is not a terminal.
#include <filesystem>
#include <fstream>
#include <set>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "recording/measurement_csv.hpp"
#include "test_support.hpp"

namespace rutd {
namespace {

namespace fs = std::filesystem;

TEST(ReplayPlots, ChosenFramesAndTheSeriesArePlotted) {
  test::TempDir tmp;
  const std::string rec = (tmp.path() / "rec").string(), plots = (tmp.path() / "plots").string();
  const std::string csv = (tmp.path() / "m.csv").string(), err = (tmp.path() / "err.txt").string();
  ASSERT_EQ(test::run_rutd("synth " + rec + " --frames 7 --size 320x240 --depth-profile 0:1,2:1,3:40,6:40"), 0);
  ASSERT_EQ(test::run_rutd("replay " + rec + " --out " + csv + " --plots " + plots + " --plot-every 4", err), 0)
      << test::read_text(err);
  const std::string log = test::read_text(err);
  EXPECT_EQ(log.find('\r'), std::string::npos) << "a progress line on a stderr that is not a terminal";
  // Which frames must have been chosen, from the measured statuses.
  const auto rows = read_measurement_csv(csv).rows;
  ASSERT_EQ(rows.size(), 7u);
  std::set<std::uint64_t> chosen;
  for (std::size_t i = 0; i < rows.size(); ++i)
    if (i == 0 || rows[i].seq % 4 == 0 || rows[i].measurement.status != rows[i - 1].measurement.status)
      chosen.insert(rows[i].seq);
  // A 1 mm dent is no rut: the status changes from NO_RUT to OK at a frame that is not a multiple of 4.
  EXPECT_EQ(rows[0].measurement.status, RutStatus::NoRut);
  EXPECT_EQ(rows[6].measurement.status, RutStatus::Ok);
  EXPECT_GT(chosen.size(), 2u);
  std::set<std::string> expected{"series.png"};
  for (std::uint64_t s : chosen)
    for (const char* kind : {"section", "disparity", "left"}) {
      char name[64];
      std::snprintf(name, sizeof name, "frame_%06llu_%s.png", static_cast<unsigned long long>(s), kind);
      expected.insert(name);
    }
  std::set<std::string> found;
  for (const auto& e : fs::directory_iterator(plots)) found.insert(e.path().filename().string());
  EXPECT_EQ(found, expected);
  for (const std::string& name : found) {
    const cv::Mat img = cv::imread(plots + "/" + name, cv::IMREAD_COLOR);
    ASSERT_FALSE(img.empty()) << name;
    const cv::Size want = name == "series.png"                      ? cv::Size(1000, 800)
                          : name.find("_left") != std::string::npos ? cv::Size(640, 480)
                                                                    : cv::Size(1000, 600);
    EXPECT_EQ(img.size(), want) << name;
    cv::Scalar mean, sd;
    cv::meanStdDev(img, mean, sd);
    EXPECT_GT(sd[0], 10.0) << name << " looks blank";
  }
}

TEST(ReplayPlots, PlotsPathThatIsAFileIsNamed) {
  test::TempDir tmp;
  const std::string rec = (tmp.path() / "rec").string(), file = (tmp.path() / "afile").string();
  const std::string err = (tmp.path() / "err.txt").string();
  ASSERT_EQ(test::run_rutd("synth " + rec + " --frames 1 --size 320x240"), 0);
  std::ofstream(file) << "x";
  EXPECT_EQ(test::run_rutd("replay " + rec + " --out /dev/null --plots " + file, err), 2);
  EXPECT_NE(test::read_text(err).find("afile: --plots:"), std::string::npos) << test::read_text(err);
}

// `rutd run` with the configuration's plots section on: the plot sink beside the CAN sink, the first frame
// plotted, the series written at exit and the sink's figures logged.
TEST(RunPlots, ConfigurationSectionPlotsALiveRun) {
  test::TempDir tmp;
  const std::string cfg = (tmp.path() / "rutd.yaml").string(), plots = (tmp.path() / "plots").string();
  const std::string err = (tmp.path() / "err.txt").string();
  std::ofstream(cfg) << "source:\n  type: synthetic\n  synthetic:\n    size: 320x240\n    cycle_frames: 2\n"
                        "sinks:\n  candump: \"\"\n"
                        "  plots:\n    enabled: true\n    dir: "
                     << plots << "\n    every: 10\n    min_interval_s: 0\n";
  ASSERT_EQ(test::run_rutd("run --config " + cfg + " --frames 30", err), 0) << test::read_text(err);
  const std::string log = test::read_text(err);
  EXPECT_NE(log.find("plots " + plots + ": "), std::string::npos) << log;
  EXPECT_NE(log.find(", 0 errors"), std::string::npos) << log;
  for (const char* name : {"frame_000000_section.png", "frame_000000_disparity.png", "frame_000000_left.png"})
    EXPECT_FALSE(cv::imread(plots + "/" + name).empty()) << name;
  EXPECT_EQ(cv::imread(plots + "/series.png").size(), cv::Size(1000, 800));
}

}  // namespace
}  // namespace rutd
