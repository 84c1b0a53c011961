// Recording folder: bit-exact round trips of 8-bit and 16-bit pairs, one clear error per bad input
// (naming file and line, and the image where one is involved), and crash safety: a recording cut at
// any byte of frames.csv, or a writer process killed at a random moment, replays every listed pair.
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/input_error.hpp"
#include "recording/recording.hpp"

extern char** environ;

#include "test_support.hpp"

namespace rutd {
namespace {

using test::read_text;

namespace fs = std::filesystem;

constexpr const char* kKillChildEnv = "RUTD_TEST_RECORDING_CHILD_DIR";
const cv::Size kSize(64, 48);

StereoCalibration test_calibration(cv::Size size = kSize) {
  StereoCalibration c;
  c.image_size = size;
  const double f = 1.2 * size.width;
  c.M1 = {f, 0, size.width / 2.0, 0, f, size.height / 2.0, 0, 0, 1};
  c.M2 = c.M1;
  c.D1 = cv::Mat::zeros(1, 5, CV_64F);
  c.D2 = cv::Mat::zeros(1, 5, CV_64F);
  cv::Rodrigues(cv::Vec3d(0.001, -0.002, 0.0005), c.R);
  c.T = {-120.0, 0.0, 0.0};
  return c;
}

// A pair whose pixels are a function of (seq, type), so any process can regenerate it for comparison.
StereoFrame make_pair(std::uint64_t seq, int type, cv::Size size = kSize) {
  StereoFrame frame;
  frame.seq = seq;
  frame.t_ns = 1'700'000'000'000'000'000LL + static_cast<std::int64_t>(seq) * 33'333'333;
  frame.skew_ns = seq % 2 == 0 ? 0 : -2'500'000 * static_cast<std::int64_t>(seq);  // free-running, right first
  cv::RNG rng(seq * 2654435761u + static_cast<std::uint64_t>(type));
  frame.left.create(size, type);
  frame.right.create(size, type);
  const double high = type == CV_16UC1 ? 65536.0 : 256.0;
  rng.fill(frame.left, cv::RNG::UNIFORM, 0.0, high);
  rng.fill(frame.right, cv::RNG::UNIFORM, 0.0, high);
  return frame;
}

bool same_image(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0.0;
}

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << text;
}

class RecordingTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("rutd_recording_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Writes pairs 0..count-1 of `type` into a new recording at `dir`.
  void record(const fs::path& dir, int count, int type = CV_8UC1) {
    RecordingWriter writer(dir.string(), test_calibration(), {.sync_to_disk = false});
    for (int i = 0; i < count; ++i) ASSERT_TRUE(writer.append(make_pair(i, type))) << writer.error();
  }

  std::string frames() const { return (dir_ / "frames.csv").string(); }

  fs::path dir_;
};

// ---------------------------------------------------------------------------------------------------
// Round trips and the writer

TEST_F(RecordingTest, RoundTripIsBitExactFor8And16Bit) {
  for (int type : {CV_8UC1, CV_16UC1}) {
    SCOPED_TRACE(type);
    fs::remove_all(dir_);
    {
      RecordingWriter writer(dir_.string(), test_calibration());
      for (std::uint64_t seq : {3, 4, 7, 8, 20}) ASSERT_TRUE(writer.append(make_pair(seq, type))) << writer.error();
      EXPECT_EQ(writer.pairs_written(), 5u);
      EXPECT_TRUE(writer.error().empty());
    }
    ReplaySource reader(dir_.string());
    EXPECT_EQ(reader.directory(), dir_.string());
    EXPECT_EQ(reader.calibration().image_size, kSize);
    EXPECT_EQ(cv::norm(reader.calibration().T - test_calibration().T), 0.0);
    StereoFrame frame;
    const uchar* left_buffer = nullptr;
    for (std::uint64_t seq : {3, 4, 7, 8, 20}) {
      ASSERT_EQ(reader.next(frame), SourceStatus::Ok) << reader.error_message();
      const StereoFrame expected = make_pair(seq, type);
      EXPECT_EQ(frame.seq, seq);
      EXPECT_EQ(frame.t_ns, expected.t_ns);
      EXPECT_EQ(frame.skew_ns, expected.skew_ns);
      EXPECT_EQ(frame.clock, ClockKind::Monotonic);
      EXPECT_TRUE(same_image(frame.left, expected.left));
      EXPECT_TRUE(same_image(frame.right, expected.right));
      if (left_buffer != nullptr) {
        EXPECT_EQ(frame.left.data, left_buffer) << "buffer not reused";
      }
      left_buffer = frame.left.data;
    }
    EXPECT_EQ(reader.next(frame), SourceStatus::EndOfStream);
    EXPECT_EQ(reader.next(frame), SourceStatus::EndOfStream);
    EXPECT_FALSE(reader.truncated_tail());
    EXPECT_EQ(reader.pairs_read(), 5u);
    EXPECT_TRUE(reader.error_message().empty());
  }
}

TEST_F(RecordingTest, FolderLayoutIsTheDocumentedOne) {
  record(dir_, 2);
  EXPECT_EQ(read_text(frames()),
            "seq,t_ns,skew_ns,left,right\n"
            "0,1700000000000000000,0,left/00000000.png,right/00000000.png\n"
            "1,1700000000033333333,-2500000,left/00000001.png,right/00000001.png\n");
  EXPECT_TRUE(fs::is_regular_file(dir_ / "calibration.yaml"));
  // Only the listed images remain: no temporaries.
  for (const char* side : {"left", "right"}) {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(dir_ / side)) names.push_back(entry.path().filename());
    std::sort(names.begin(), names.end());
    EXPECT_EQ(names, (std::vector<std::string>{"00000000.png", "00000001.png"}));
  }
  // The images are ordinary PNGs any tool reads.
  EXPECT_TRUE(same_image(cv::imread((dir_ / "right/00000001.png").string(), cv::IMREAD_UNCHANGED),
                         make_pair(1, CV_8UC1).right));
}

TEST_F(RecordingTest, WriterRefusesAFolderThatHoldsARecording) {
  record(dir_, 1);
  const std::string before = read_text(frames());
  try {
    RecordingWriter writer(dir_.string(), test_calibration());
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), dir_.string());
    EXPECT_EQ(e.field(), "folder");
    EXPECT_NE(std::string(e.what()).find("already holds a recording (frames.csv exists)"), std::string::npos)
        << e.what();
  }
  EXPECT_EQ(read_text(frames()), before);
}

TEST_F(RecordingTest, WriterRefusesAnUncreatableFolder) {
  fs::create_directories(dir_);
  write_text(dir_ / "a_file", "x");
  const std::string dir = (dir_ / "a_file" / "recording").string();
  try {
    RecordingWriter writer(dir, test_calibration());
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), dir);
    EXPECT_EQ(e.field(), "folder");
    EXPECT_NE(std::string(e.what()).find("cannot create"), std::string::npos) << e.what();
  }
}

TEST_F(RecordingTest, WriterRejectsPairsTheReaderWouldRefuse) {
  RecordingWriter writer(dir_.string(), test_calibration(), {.sync_to_disk = false});
  ASSERT_TRUE(writer.append(make_pair(5, CV_8UC1)));
  const std::string before = read_text(frames());

  StereoFrame mixed = make_pair(6, CV_8UC1);
  mixed.right = make_pair(6, CV_16UC1).right;
  StereoFrame small = make_pair(6, CV_8UC1, {32, 24});
  StereoFrame colour = make_pair(6, CV_8UC1);
  cv::cvtColor(colour.left, colour.left, cv::COLOR_GRAY2BGR);
  cv::cvtColor(colour.right, colour.right, cv::COLOR_GRAY2BGR);
  StereoFrame repeated = make_pair(5, CV_8UC1);
  StereoFrame earlier = make_pair(6, CV_8UC1);
  earlier.t_ns -= 100'000'000;
  const std::vector<std::pair<StereoFrame, std::string>> cases = {
      {mixed, "pair seq 6: left is 64x48 8-bit 1-channel but right is 64x48 16-bit 1-channel"},
      {small, "pair seq 6: images are 32x24 8-bit 1-channel but the calibration says 64x48"},
      {colour, "pair seq 6: images must be 8-bit or 16-bit grey"},
      {repeated, "pair seq 5: seq does not increase (previous pair was seq 5)"},
      {earlier, "pair seq 6: t_ns 1700000000099999998 is before the previous pair's 1700000000166666665"},
  };
  for (const auto& [frame, message] : cases) {
    EXPECT_FALSE(writer.append(frame));
    EXPECT_EQ(writer.error().substr(0, message.size()), message);
  }
  EXPECT_EQ(writer.pairs_written(), 1u);
  EXPECT_EQ(read_text(frames()), before);
  EXPECT_TRUE(writer.append(make_pair(6, CV_8UC1)));
  EXPECT_TRUE(writer.error().empty());
}

TEST_F(RecordingTest, WriteFailureIsReportedAndRecordingGoesOn) {
  RecordingWriter writer(dir_.string(), test_calibration(), {.sync_to_disk = false});
  ASSERT_TRUE(writer.append(make_pair(0, CV_8UC1)));
  // Make right/ unwritable in a way that holds even for root: replace the folder by a file.
  fs::rename(dir_ / "right", dir_ / "right.away");
  write_text(dir_ / "right", "not a folder");
  EXPECT_FALSE(writer.append(make_pair(1, CV_8UC1)));
  EXPECT_NE(writer.error().find("right/.00000001.png.tmp"), std::string::npos) << writer.error();
  EXPECT_FALSE(fs::exists(dir_ / "left/00000001.png")) << "half-written pair left behind";
  fs::remove(dir_ / "right");
  fs::rename(dir_ / "right.away", dir_ / "right");
  ASSERT_TRUE(writer.append(make_pair(2, CV_8UC1))) << writer.error();
  EXPECT_EQ(writer.pairs_written(), 2u);

  ReplaySource reader(dir_.string());
  StereoFrame frame;
  ASSERT_EQ(reader.next(frame), SourceStatus::Ok);
  EXPECT_EQ(frame.seq, 0u);
  ASSERT_EQ(reader.next(frame), SourceStatus::Ok) << reader.error_message();
  EXPECT_EQ(frame.seq, 2u);
  EXPECT_EQ(reader.next(frame), SourceStatus::EndOfStream);
}

// ---------------------------------------------------------------------------------------------------
// Opening a recording

void expect_open_error(const std::string& dir, const std::string& file, const std::string& field,
                       const std::string& message) {
  try {
    ReplaySource reader(dir);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), file);
    EXPECT_EQ(e.field(), field);
    EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
  }
}

TEST_F(RecordingTest, OpenErrorsNameFileAndField) {
  const std::string dir = dir_.string();
  expect_open_error(dir, dir, "folder", "does not exist");
  record(dir_, 1);
  fs::remove(dir_ / "calibration.yaml");
  expect_open_error(dir, dir + "/calibration.yaml", "file", "cannot open");

  fs::remove_all(dir_);
  record(dir_, 1);
  write_text(dir_ / "calibration.yaml", "%YAML:1.0\n---\nimage_width: 64\n");
  expect_open_error(dir, dir + "/calibration.yaml", "image_height", "missing");

  fs::remove_all(dir_);
  record(dir_, 1);
  fs::remove(frames());
  expect_open_error(dir, frames(), "file", "cannot open");
  write_text(frames(), "");
  expect_open_error(dir, frames(), "line 1", "missing header (file is empty)");
  write_text(frames(), "seq,t,left,right\n0,0,left/00000000.png,right/00000000.png\n");
  expect_open_error(dir, frames(), "line 1",
                    "header is 'seq,t,left,right' but must be 'seq,t_ns,skew_ns,left,right' (or, recorded before "
                    "skew_ns, 'seq,t_ns,left,right')");
}

// ---------------------------------------------------------------------------------------------------
// Per-frame errors

class ReplayErrorTest : public RecordingTest {
 protected:
  void SetUp() override {
    RecordingTest::SetUp();
    record(dir_, 4);
  }
  // Replaces the lines after the header and opens the recording.
  ReplaySource& replay(const std::string& lines) {
    write_text(frames(), "seq,t_ns,left,right\n" + lines);
    reader_.emplace(dir_.string());
    return *reader_;
  }
  // Expects the next pair to be an Error with exactly `message` after "FRAMES: line N: ".
  void expect_error(int line, const std::string& message) {
    StereoFrame frame;
    ASSERT_EQ(reader_->next(frame), SourceStatus::Error);
    EXPECT_EQ(reader_->error_message(), frames() + ": line " + std::to_string(line) + ": " + message);
  }
  void expect_pair(std::uint64_t seq) {
    StereoFrame frame;
    ASSERT_EQ(reader_->next(frame), SourceStatus::Ok) << reader_->error_message();
    EXPECT_EQ(frame.seq, seq);
    EXPECT_TRUE(reader_->error_message().empty());
    const StereoFrame expected = make_pair(seq, CV_8UC1);
    EXPECT_TRUE(same_image(frame.left, expected.left));
    EXPECT_TRUE(same_image(frame.right, expected.right));
  }
  void expect_end(bool truncated) {
    StereoFrame frame;
    EXPECT_EQ(reader_->next(frame), SourceStatus::EndOfStream) << reader_->error_message();
    EXPECT_EQ(reader_->truncated_tail(), truncated);
  }
  std::string line(std::uint64_t seq, std::int64_t t_ns) const {
    char text[128];
    std::snprintf(text, sizeof text, "%llu,%lld,left/%08llu.png,right/%08llu.png\n",
                  static_cast<unsigned long long>(seq), static_cast<long long>(t_ns),
                  static_cast<unsigned long long>(seq), static_cast<unsigned long long>(seq));
    return text;
  }
  std::string line(std::uint64_t seq) const { return line(seq, make_pair(seq, CV_8UC1).t_ns); }

  std::optional<ReplaySource> reader_;
};

TEST_F(ReplayErrorTest, MalformedLinesAreErrorsAndReplayGoesOn) {
  replay(line(0) + "1,2,left/00000001.png\n" + "x1," + line(1).substr(2) + "2,soon" + line(2).substr(21) +
         "3,1700000000100000000,,right/00000003.png\n" +
         "3,1700000000100000000,/abs/00000003.png,right/00000003.png\n" +
         "3,1700000000100000000,left/a.png,right/b.png,extra\n" + line(3));
  expect_pair(0);
  expect_error(3, "expected 4 fields (seq,t_ns,left,right), found 3");
  expect_error(4, "seq 'x1' is not a non-negative integer");
  expect_error(5, "t_ns 'soon' is not an integer");
  expect_error(6, "empty left image path");
  expect_error(7, "left image path '/abs/00000003.png' must be relative to the recording folder");
  expect_error(8, "expected 4 fields (seq,t_ns,left,right), found 5");
  expect_pair(3);
  expect_end(false);
}

// The skew column (recordings since skew_ns): read back as written, malformed values and field counts named;
// the recording of MalformedLinesAreErrorsAndReplayGoesOn, without it, reads as skew 0.
TEST_F(ReplayErrorTest, SkewColumnIsReadAndCheckedWhereTheHeaderHasIt) {
  const auto with_skew = [&](std::uint64_t seq, const std::string& skew) {
    const std::string l = line(seq);  // seq,t_ns,left,right
    const std::size_t paths = l.find(',', l.find(',') + 1) + 1;
    return l.substr(0, paths) + skew + "," + l.substr(paths);
  };
  write_text(frames(), "seq,t_ns,skew_ns,left,right\n" + with_skew(0, "-7000000") + line(1) + with_skew(2, "1.5e6") +
                           with_skew(3, "2500"));
  reader_.emplace(dir_.string());
  StereoFrame frame;
  ASSERT_EQ(reader_->next(frame), SourceStatus::Ok) << reader_->error_message();
  EXPECT_EQ(frame.skew_ns, -7'000'000);
  expect_error(3, "expected 5 fields (seq,t_ns,skew_ns,left,right), found 4");
  expect_error(4, "skew_ns '1.5e6' is not an integer");
  ASSERT_EQ(reader_->next(frame), SourceStatus::Ok) << reader_->error_message();
  EXPECT_EQ(frame.seq, 3u);
  EXPECT_EQ(frame.skew_ns, 2500);
  replay(line(0));  // the header without skew_ns
  ASSERT_EQ(reader_->next(frame), SourceStatus::Ok) << reader_->error_message();
  EXPECT_EQ(frame.skew_ns, 0);
}

TEST_F(ReplayErrorTest, MissingImageNamesImageAndLine) {
  fs::remove(dir_ / "right/00000001.png");
  replay(line(0) + line(1) + line(2));
  expect_pair(0);
  expect_error(3, "cannot read right image " + dir_.string() + "/right/00000001.png: No such file or directory");
  expect_pair(2);
  expect_end(false);
}

TEST_F(ReplayErrorTest, MissingImageOnCompleteLastLineIsAnError) {
  fs::remove(dir_ / "left/00000003.png");
  replay(line(0) + line(3));
  expect_pair(0);
  expect_error(3, "cannot read left image " + dir_.string() + "/left/00000003.png: No such file or directory");
  expect_end(false);
}

TEST_F(ReplayErrorTest, CorruptImageIsNamed) {
  write_text(dir_ / "left/00000001.png", "\x89PNG\r\n\x1a\n but then garbage");
  replay(line(1));
  expect_error(2, "left image " + dir_.string() + "/left/00000001.png is not a readable image");
}

// Found by fuzzing: replay handed any bytes to OpenCV's imdecode, whose other decoders took them (a
// JPEG 2000 signature here, whose decoder writes its complaints to stderr). Recordings hold PNG only.
// And a PNG header claiming 20000x20000 is refused before decoding, instead of allocating 400 MB first.
TEST_F(ReplayErrorTest, OnlyPngImagesNoLargerThanTheCalibrationAreDecoded) {
  write_text(dir_ / "left/00000001.png", std::string("\0\0\0\x0cjP  \r\n\x87\n", 12) + "then garbage");
  const char huge[] =
      "\x89\x50\x4e\x47\x0d\x0a\x1a\x0a\x00\x00\x00\x0d\x49\x48\x44\x52\x00\x00\x4e\x20\x00\x00\x4e\x20\x08\x00\x00"
      "\x00\x00\xc6\x1b\x19\xe5\x00\x00\x00\x00\x49\x45\x4e\x44\xae\x42\x60\x82";
  write_text(dir_ / "right/00000002.png", std::string(huge, sizeof huge - 1));
  replay(line(1) + line(2) + line(3));
  expect_error(2, "left image " + dir_.string() + "/left/00000001.png is not a PNG image");
  expect_error(
      3, "right image " + dir_.string() + "/right/00000002.png is 20000x20000 (PNG header) but calibration says 64x48");
  expect_pair(3);
  expect_end(false);
}

// A line may list any file; one of 1 GiB (sparse here) is refused by its size, not read into memory.
TEST_F(ReplayErrorTest, HugeImageFileIsRefusedUnread) {
  const fs::path huge = dir_ / "left/00000001.png";
  fs::resize_file(huge, 1ull << 30);
  replay(line(1) + line(2));
  expect_error(2, "cannot read left image " + huge.string() + ": File too large");
  expect_pair(2);
}

// The same after a good pair: the decoder must not hand back the previous pair's image for bytes it could
// not decode (OpenCV leaves its destination as it was), and the pair after must be itself again.
TEST_F(ReplayErrorTest, CorruptImageAfterAGoodPairIsAnErrorNotThePreviousImage) {
  write_text(dir_ / "left/00000001.png", "\x89PNG\r\n\x1a\n but then garbage");
  replay(line(0) + line(1) + line(2));
  expect_pair(0);
  expect_error(3, "left image " + dir_.string() + "/left/00000001.png is not a readable image");
  expect_pair(2);
  expect_end(false);
}

TEST_F(ReplayErrorTest, SizeAndTypeMismatches) {
  cv::imwrite((dir_ / "left/small.png").string(), make_pair(9, CV_8UC1, {32, 24}).left);
  cv::imwrite((dir_ / "right/small.png").string(), make_pair(9, CV_8UC1, {32, 24}).right);
  cv::imwrite((dir_ / "right/deep.png").string(), make_pair(9, CV_16UC1).right);
  replay(
      "1,10,left/small.png,right/00000001.png\n"
      "2,20,left/00000002.png,right/deep.png\n"
      "3,30,left/small.png,right/small.png\n");
  expect_error(2, "left image is 32x24 8-bit 1-channel but right image is 64x48 8-bit 1-channel");
  expect_error(3, "left image is 64x48 8-bit 1-channel but right image is 64x48 16-bit 1-channel");
  expect_error(4, dir_.string() + "/right/small.png: image_width: frame is 32x24 but calibration says 64x48");
  expect_end(false);
}

TEST_F(ReplayErrorTest, SeqOrTimeGoingBackwardsIsAnErrorAtThatLine) {
  replay(line(1) + line(2) + line(0) + line(2) + line(3, make_pair(1, CV_8UC1).t_ns) + line(3));
  expect_pair(1);
  expect_pair(2);
  expect_error(4, "seq 0 does not increase (previous pair was seq 2)");
  expect_error(5, "seq 2 does not increase (previous pair was seq 2)");
  expect_error(6, "t_ns 1700000000033333333 goes backwards (previous pair was at 1700000000066666666)");
  expect_pair(3);
  expect_end(false);
}

TEST_F(ReplayErrorTest, ColourImagesAreConvertedToGrey) {
  const StereoFrame pair = make_pair(1, CV_8UC1);
  cv::Mat colour(kSize, CV_8UC3);
  cv::RNG(5).fill(colour, cv::RNG::UNIFORM, 0, 256);
  cv::imwrite((dir_ / "left/colour.png").string(), colour);
  replay("1,10,left/colour.png,right/00000001.png\n");
  StereoFrame frame;
  ASSERT_EQ(reader_->next(frame), SourceStatus::Ok) << reader_->error_message();
  cv::Mat grey;
  cv::cvtColor(colour, grey, cv::COLOR_BGR2GRAY);
  EXPECT_TRUE(same_image(frame.left, grey));
  EXPECT_TRUE(same_image(frame.right, pair.right));
}

TEST_F(ReplayErrorTest, BlankLinesAndWindowsLineEndingsAreTolerated) {
  std::string l0 = line(0), l1 = line(1);
  l0.insert(l0.size() - 1, "\r");
  replay(l0 + "\n" + l1);
  expect_pair(0);
  expect_pair(1);
  expect_end(false);
}

// ---------------------------------------------------------------------------------------------------
// Cut-off recordings

TEST_F(ReplayErrorTest, CutOffLastLineEndsTheStreamWithANote) {
  const std::vector<std::string> tails = {
      "3,17000",                                             // cut in t_ns
      "3,1700000000100000000,left/000",                      // cut in the left path
      "3,1700000000100000000,left/00000003.png,right/0000",  // cut in the right path: 4 fields
      "3,1700000000100000000\n",                             // fewer fields, newline, end of file
  };
  for (const std::string& tail : tails) {
    SCOPED_TRACE(tail);
    replay(line(0) + line(1) + line(2) + tail);
    expect_pair(0);
    expect_pair(1);
    expect_pair(2);
    expect_end(true);
    EXPECT_NE(reader_->truncation_note().find(frames() + ": line 5: "), std::string::npos)
        << reader_->truncation_note();
    EXPECT_NE(reader_->truncation_note().find("replay stopped at the last complete pair"), std::string::npos);
    expect_end(true);
  }
}

TEST_F(ReplayErrorTest, FewerFieldsBeforeTheEndIsAnError) {
  replay(line(0) + "1,1700000000033333333\n" + line(2));
  expect_pair(0);
  expect_error(3, "expected 4 fields (seq,t_ns,left,right), found 2");
  expect_pair(2);
  expect_end(false);
}

TEST_F(ReplayErrorTest, LastLineMissingOnlyItsNewlineStillReplays) {
  std::string last = line(3);
  last.pop_back();
  replay(line(0) + last);
  expect_pair(0);
  expect_pair(3);
  expect_end(false);
}

// Every prefix of frames.csv is a state a killed writer can leave: each must replay exactly the pairs
// whose line is complete (the newline aside), and never report an error.
TEST_F(RecordingTest, EveryCutOfFramesCsvReplaysTheCompletePairs) {
  record(dir_, 3);
  const std::string full = read_text(frames());
  std::vector<std::size_t> line_ends;  // offset of each data line's '\n'
  for (std::size_t i = full.find('\n') + 1; i < full.size(); i = full.find('\n', i) + 1) {
    line_ends.push_back(full.find('\n', i));
  }
  const std::size_t header_size = full.find('\n') + 1;
  for (std::size_t cut = header_size; cut <= full.size(); ++cut) {
    SCOPED_TRACE(cut);
    write_text(frames(), full.substr(0, cut));
    ReplaySource reader(dir_.string());
    std::size_t expected = 0;
    while (expected < line_ends.size() && line_ends[expected] <= cut) ++expected;
    StereoFrame frame;
    std::size_t replayed = 0;
    SourceStatus status;
    while ((status = reader.next(frame)) == SourceStatus::Ok) {
      const StereoFrame truth = make_pair(replayed, CV_8UC1);
      ASSERT_TRUE(same_image(frame.left, truth.left) && same_image(frame.right, truth.right));
      ++replayed;
    }
    ASSERT_EQ(status, SourceStatus::EndOfStream) << reader.error_message();
    EXPECT_EQ(replayed, expected);
    const bool complete_without_newline = expected > 0 && line_ends[expected - 1] == cut;
    const bool mid_line = full[cut - 1] != '\n' && !complete_without_newline;
    EXPECT_EQ(reader.truncated_tail(), mid_line);
  }
}

// ---------------------------------------------------------------------------------------------------
// A writer process killed with SIGKILL at a random moment

// When this program is started with kKillChildEnv set, it only records into that folder until killed.
[[maybe_unused]] const bool kIsKillChild = [] {
  const char* dir = std::getenv(kKillChildEnv);
  if (dir == nullptr) return false;
  RecordingWriter writer(dir, test_calibration(), {.sync_to_disk = false});
  for (std::uint64_t seq = 0;; ++seq) {
    if (!writer.append(make_pair(seq, seq % 2 == 0 ? CV_8UC1 : CV_16UC1))) {
      std::fprintf(stderr, "%s\n", writer.error().c_str());
      std::_Exit(2);
    }
  }
}();

TEST_F(RecordingTest, KilledWriterLeavesAReplayableRecording) {
  std::mt19937 rng(42);
  // An attempt killed before the recording existed checks nothing: try until five were checked.
  int checked = 0;
  std::uint64_t replayed_total = 0;
  for (int attempt = 0; checked < 5 && attempt < 8; ++attempt) {
    fs::remove_all(dir_);
    const std::string env = std::string(kKillChildEnv) + "=" + dir_.string();
    std::vector<char*> envp;
    for (char** e = environ; *e != nullptr; ++e) envp.push_back(*e);
    envp.push_back(const_cast<char*>(env.c_str()));
    envp.push_back(nullptr);
    char arg0[] = "recording_writer_child";
    char* argv[] = {arg0, nullptr};
    pid_t child = 0;
    ASSERT_EQ(::posix_spawn(&child, "/proc/self/exe", nullptr, nullptr, argv, envp.data()), 0);
    // Kill once the child has recorded for a random while, counted from when its recording exists (a
    // loaded machine can take seconds to start it).
    for (auto t0 = std::chrono::steady_clock::now();
         !fs::exists(dir_ / "frames.csv") && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(10);)
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(50 + rng() % 300);
    while (std::chrono::steady_clock::now() < until) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    ::kill(child, SIGKILL);
    int wstatus = 0;
    ::waitpid(child, &wstatus, 0);
    ASSERT_TRUE(WIFSIGNALED(wstatus)) << "child exited by itself with " << WEXITSTATUS(wstatus);

    if (!fs::exists(dir_ / "frames.csv")) continue;  // killed before the recording existed
    ReplaySource reader(dir_.string());
    StereoFrame frame;
    std::uint64_t replayed = 0;
    SourceStatus status;
    while ((status = reader.next(frame)) == SourceStatus::Ok) {
      const StereoFrame truth = make_pair(replayed, replayed % 2 == 0 ? CV_8UC1 : CV_16UC1);
      ASSERT_EQ(frame.seq, replayed);
      ASSERT_TRUE(same_image(frame.left, truth.left) && same_image(frame.right, truth.right));
      ++replayed;
    }
    ASSERT_EQ(status, SourceStatus::EndOfStream) << reader.error_message();
    std::cout << "killed writer " << attempt << ": " << replayed << " pairs replayed"
              << (reader.truncated_tail() ? " (cut-off last line)" : "") << "\n";
    ++checked;
    replayed_total += replayed;
  }
  ASSERT_EQ(checked, 5) << "the writer was killed before its recording existed too often";
  // 50..350 ms of unsynced writes of small pairs each: together they must have listed some.
  EXPECT_GT(replayed_total, 0u);
}

// ---------------------------------------------------------------------------------------------------
// Throughput at a camera's resolution: printed, never asserted (shared machine).

TEST_F(RecordingTest, PrintsThroughputAtCameraResolution) {
  const cv::Size size(1936, 1216);
  // A textured scene rather than noise: PNG cost depends on content. Tile a real stereo image.
  const cv::Mat scene = cv::imread(std::string(RUTD_TEST_DATA_DIR) + "/middlebury/cone/im2.png", cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(scene.empty());
  cv::Mat tiled;
  cv::repeat(scene, size.height / scene.rows + 1, size.width / scene.cols + 1, tiled);
  StereoFrame frame;
  frame.left = tiled(cv::Rect({0, 0}, size)).clone();
  frame.right = tiled(cv::Rect({3, 0}, size)).clone();
  constexpr int kPairs = 8;
  for (bool sync : {false, true}) {
    fs::remove_all(dir_);
    RecordingWriter writer(dir_.string(), test_calibration(size), {.sync_to_disk = sync});
    const auto start = std::chrono::steady_clock::now();
    for (int i = 0; i < kPairs; ++i) {
      frame.seq = i;
      frame.t_ns = i;
      ASSERT_TRUE(writer.append(frame)) << writer.error();
    }
    const double write_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count() / kPairs;
    ReplaySource reader(dir_.string());
    StereoFrame read;
    const auto read_start = std::chrono::steady_clock::now();
    for (int i = 0; i < kPairs; ++i) ASSERT_EQ(reader.next(read), SourceStatus::Ok);
    const double read_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - read_start).count() / kPairs;
    const auto png_bytes = fs::file_size(dir_ / "left/00000000.png");
    std::cout << size.width << "x" << size.height << " 8-bit, sync_to_disk=" << sync << ": write " << write_ms
              << " ms/pair, read " << read_ms << " ms/pair, PNG " << png_bytes / 1024 << " KiB/image\n";
  }
}

}  // namespace
}  // namespace rutd
