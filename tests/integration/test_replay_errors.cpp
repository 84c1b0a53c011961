// Bad input through the rutd program, as a user meets it: one clear error naming the file and the
// field or line, and nothing already measured lost.
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "recording/measurement_csv.hpp"
#include "test_support.hpp"

namespace rutd {
namespace {

namespace fs = std::filesystem;

class ReplayErrors : public ::testing::Test {
 protected:
  void SetUp() override {
    rec_ = (tmp_.path() / "rec").string();
    ASSERT_EQ(test::run_rutd("synth " + rec_ + " --frames 4 --seed 3"), 0);
  }
  int replay(std::string& stderr_text) {
    const std::string err = (tmp_.path() / "err.txt").string();
    const int status = test::run_rutd("replay " + rec_ + " --out " + csv(), err);
    stderr_text = test::read_text(err);
    return status;
  }
  std::string csv() const { return (tmp_.path() / "m.csv").string(); }

  test::TempDir tmp_;
  std::string rec_;
};

TEST_F(ReplayErrors, MissingImageIsNamedAndTheOtherPairsAreMeasured) {
  fs::remove(fs::path(rec_) / "right" / "00000002.png");
  std::string err;
  EXPECT_EQ(replay(err), 1);
  EXPECT_NE(err.find("frames.csv: line 4"), std::string::npos) << err;
  EXPECT_NE(err.find("00000002.png"), std::string::npos) << err;
  const auto rows = read_measurement_csv(csv()).rows;
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[0].seq, 0u);
  EXPECT_EQ(rows[1].seq, 1u);
  EXPECT_EQ(rows[2].seq, 3u);
}

TEST_F(ReplayErrors, BadCalibrationKeyIsNamed) {
  const fs::path cal = fs::path(rec_) / "calibration.yaml";
  std::string text = test::read_text(cal);
  const auto at = text.find("M2:");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 3, "MX:");
  std::ofstream(cal) << text;
  std::string err;
  EXPECT_EQ(replay(err), 2);
  EXPECT_NE(err.find("calibration.yaml"), std::string::npos) << err;
  EXPECT_NE(err.find("M2"), std::string::npos) << err;
}

TEST_F(ReplayErrors, CutOffLastLineReplaysUpToTheLastCompletePair) {
  const fs::path frames = fs::path(rec_) / "frames.csv";
  std::string text = test::read_text(frames);
  text.resize(text.size() - 12);  // a power cut in the middle of the last line
  std::ofstream(frames, std::ios::trunc) << text;
  std::string err;
  EXPECT_EQ(replay(err), 0) << err;
  EXPECT_NE(err.find("cut off"), std::string::npos) << err;
  EXPECT_EQ(read_measurement_csv(csv()).rows.size(), 3u);
}

// A disk that fills up under `replay --out` (a 2 KiB file-size limit: writes fail with EFBIG): the replay
// stops at the first row it cannot write, with exit 1 and one error naming the file, and the CSV holds
// every row before it, whole (the partial row is cut off again).
TEST_F(ReplayErrors, FullDiskStopsTheReplayKeepingTheRowsWritten) {
  const std::string rec = (tmp_.path() / "long").string();
  ASSERT_EQ(test::run_rutd("synth " + rec + " --frames 30 --size 320x240 --seed 4"), 0);
  const std::string err = (tmp_.path() / "err.txt").string();
  const int status = test::run_shell("bash -c 'ulimit -f 2 && exec " + test::quoted(RUTD_BINARY) + " replay " + rec +
                                     " --out " + csv() + "' 2>" + test::quoted(err));
  const std::string text = test::read_text(err);
  EXPECT_EQ(status, 1) << text;
  EXPECT_NE(text.find(csv() + ": cannot write the row of seq"), std::string::npos) << text;
  EXPECT_NE(text.find("File too large"), std::string::npos) << text;
  const MeasurementCsv read = read_measurement_csv(csv());
  EXPECT_FALSE(read.truncated_tail) << "a partial row was left";
  ASSERT_GT(read.rows.size(), 5u);
  ASSERT_LT(read.rows.size(), 30u);
  for (std::size_t i = 0; i < read.rows.size(); ++i) EXPECT_EQ(read.rows[i].seq, i);
  EXPECT_LE(fs::file_size(csv()), 2048u);
  std::printf("replay stopped at the 2 KiB limit with %zu whole rows (%ju bytes)\n", read.rows.size(),
              static_cast<std::uintmax_t>(fs::file_size(csv())));
}

// The strip's placement on the command line: `--strip-first-row centred` or a row. The option of older
// releases (--strip-row0, where -1 meant centred) and the old value are refused, naming the new form.
TEST_F(ReplayErrors, OldStripOptionIsRefusedNamingItsReplacement) {
  const std::string err = (tmp_.path() / "err.txt").string();
  EXPECT_NE(test::run_rutd("replay " + rec_ + " --out " + csv() + " --strip-row0 -1", err), 0);
  EXPECT_NE(test::read_text(err).find("--strip-row0: replaced by --strip-first-row"), std::string::npos)
      << test::read_text(err);
  EXPECT_NE(test::run_rutd("replay " + rec_ + " --out " + csv() + " --strip-first-row -1", err), 0);
  EXPECT_NE(test::read_text(err).find("now written centred"), std::string::npos) << test::read_text(err);
  EXPECT_EQ(test::run_rutd("replay " + rec_ + " --out " + csv() + " --strip-rows 40 --strip-first-row 200", err), 0)
      << test::read_text(err);
  EXPECT_EQ(read_measurement_csv(csv()).rows.size(), 4u);
}

// A strip below the images (480 rows) is refused naming the option and the setting it stands for.
TEST_F(ReplayErrors, StripBeyondTheImagesIsRefusedNamingItsSetting) {
  const std::string err = (tmp_.path() / "err.txt").string();
  EXPECT_NE(test::run_rutd("replay " + rec_ + " --out " + csv() + " --strip-first-row 900", err), 0);
  EXPECT_NE(test::read_text(err).find("(--strip-first-row, --strip-rows): rows 900..948 lie outside the "
                                      "calibration's image height 480"),
            std::string::npos)
      << test::read_text(err);
}

}  // namespace
}  // namespace rutd
