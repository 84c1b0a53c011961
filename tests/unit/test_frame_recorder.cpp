// FrameRecorder: pairs offered on the acquisition thread come back byte-identical through
// ReplaySource; a full queue drops and counts (offer never waits for the disk); a failing disk
// (file-size limit, folder gone) stops the recording with a message naming the file and the OS reason,
// and everything listed before the failure still replays.
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "core/input_error.hpp"
#include "recording/frame_recorder.hpp"
#include "recording/recording.hpp"
#include "test_support.hpp"

namespace rutd {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

const cv::Size kSize(64, 48);

StereoCalibration test_calibration(cv::Size size = kSize) {
  StereoCalibration c;
  c.image_size = size;
  const double f = 1.2 * size.width;
  c.M1 = {f, 0, size.width / 2.0, 0, f, size.height / 2.0, 0, 0, 1};
  c.M2 = c.M1;
  c.D1 = cv::Mat::zeros(1, 5, CV_64F);
  c.D2 = cv::Mat::zeros(1, 5, CV_64F);
  c.R = cv::Matx33d::eye();
  c.T = {-60.0, 0.0, 0.0};
  return c;
}

// Fills `frame` (reusing its buffers, as a camera source does) with pixels that are a function of seq
// and type alone, by plain loops (no OpenCV thread pool, so it is safe in a forked child). noisy: every
// pixel hashed (PNG cannot shrink it); otherwise a smooth ramp with a seq-dependent offset (PNG small).
void fill_pair(StereoFrame& frame, std::uint64_t seq, int type, bool noisy = true, cv::Size size = kSize) {
  frame.seq = seq;
  frame.t_ns = 1'700'000'000'000'000'000LL + static_cast<std::int64_t>(seq) * 33'333'333;
  frame.clock = ClockKind::Monotonic;
  frame.left.create(size, type);
  frame.right.create(size, type);
  for (int side = 0; side < 2; ++side) {
    cv::Mat& m = side == 0 ? frame.left : frame.right;
    for (int y = 0; y < size.height; ++y) {
      for (int x = 0; x < size.width; ++x) {
        std::uint64_t h = (seq * 1'000'003u + static_cast<std::uint64_t>(side) * 7919u +
                           static_cast<std::uint64_t>(y) * 131u + static_cast<std::uint64_t>(x)) *
                          0x9E3779B97F4A7C15ull;
        h ^= h >> 29;
        const std::uint64_t v =
            noisy ? h : static_cast<std::uint64_t>(x + y) + seq * 3 + static_cast<std::uint64_t>(side);
        if (type == CV_16UC1) m.at<std::uint16_t>(y, x) = static_cast<std::uint16_t>(noisy ? v : v * 257);
        else m.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(v);
      }
    }
  }
}

bool same_image(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  for (int y = 0; y < a.rows; ++y)
    if (std::memcmp(a.ptr(y), b.ptr(y), a.cols * a.elemSize()) != 0) return false;
  return true;
}

// Reads the whole recording; every pair must read Ok. Returns the pairs' seqs in order.
std::vector<std::uint64_t> replay_all(const std::string& dir, int type, bool noisy = true) {
  ReplaySource reader(dir);
  EXPECT_EQ(reader.calibration().image_size, kSize);
  std::vector<std::uint64_t> seqs;
  StereoFrame got, want;
  for (;;) {
    const SourceStatus s = reader.next(got);
    if (s == SourceStatus::EndOfStream) break;
    EXPECT_EQ(s, SourceStatus::Ok) << reader.error_message();
    if (s != SourceStatus::Ok) continue;
    fill_pair(want, got.seq, type, noisy);
    EXPECT_TRUE(same_image(got.left, want.left)) << "left of seq " << got.seq;
    EXPECT_TRUE(same_image(got.right, want.right)) << "right of seq " << got.seq;
    EXPECT_EQ(got.t_ns, want.t_ns) << got.seq;
    seqs.push_back(got.seq);
  }
  EXPECT_FALSE(reader.truncated_tail()) << reader.truncation_note();
  return seqs;
}

// Waits (bounded, generously) for a condition the writer thread brings about; not a timing assertion.
template <typename Pred>
bool wait_for(Pred pred) {
  const auto deadline = std::chrono::steady_clock::now() + 30s;
  while (!pred()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(1ms);
  }
  return true;
}

std::size_t count_files(const fs::path& dir) {
  std::size_t n = 0;
  for (const auto& e : fs::directory_iterator(dir)) n += e.is_regular_file();
  return n;
}

// First in the file: it forks, and the child should inherit as few threads and as little state as
// possible. The child records under RLIMIT_FSIZE with SIGXFSZ ignored, as the daemon runs; images fit
// under the limit but frames.csv outgrows it, so a line append fails with EFBIG part-way.
TEST(FrameRecorder, FileSizeLimitStopsRecordingWithFileTooLargeAndKeepsListedPairs) {
  const test::TempDir tmp;
  // Sizes of what the limit must let through: calibration.yaml and the largest image.
  {
    RecordingWriter probe((tmp.path() / "probe").string(), test_calibration(), {false, 1});
    StereoFrame f;
    fill_pair(f, 0, CV_8UC1, false);
    ASSERT_TRUE(probe.append(f)) << probe.error();
  }
  std::uintmax_t largest = fs::file_size(tmp.path() / "probe" / "calibration.yaml");
  for (const char* side : {"left", "right"})
    largest = std::max(largest, fs::file_size(tmp.path() / "probe" / side / "00000000.png"));
  const rlim_t limit = static_cast<rlim_t>(largest + 1500);  // about 20 more frames.csv lines
  constexpr std::uint64_t kOffers = 100;

  const std::string dir = (tmp.path() / "rec").string();
  int pipe_fds[2];
  ASSERT_EQ(pipe(pipe_fds), 0);
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    close(pipe_fds[0]);
    std::signal(SIGXFSZ, SIG_IGN);
    const rlimit rl{limit, limit};
    if (setrlimit(RLIMIT_FSIZE, &rl) != 0) _exit(3);
    std::string report;
    {
      FrameRecorderConfig options;
      options.capacity = 128;  // more than kOffers: nothing can be dropped
      options.writer.sync_to_disk = false;
      FrameRecorder recorder(dir, test_calibration(), options);
      StereoFrame frame;
      for (std::uint64_t seq = 0; seq < kOffers; ++seq) {
        fill_pair(frame, seq, CV_8UC1, false);
        recorder.offer(frame);
      }
      recorder.close();
      const FrameRecorderStats s = recorder.stats();
      report = std::to_string(s.offered) + " " + std::to_string(s.written) + " " + std::to_string(s.dropped) + " " +
               std::to_string(s.discarded) + " " + std::to_string(s.failed) + "\n" + s.error;
    }
    const bool sent = write(pipe_fds[1], report.data(), report.size()) == static_cast<ssize_t>(report.size());
    _exit(sent ? 0 : 4);
  }
  close(pipe_fds[1]);
  std::string report;
  char buf[512];
  for (ssize_t n; (n = read(pipe_fds[0], buf, sizeof buf)) > 0;) report.append(buf, static_cast<std::size_t>(n));
  close(pipe_fds[0]);
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status)) << "the child was killed (signal " << WTERMSIG(status) << ")";
  ASSERT_EQ(WEXITSTATUS(status), 0);

  std::istringstream in(report);
  std::uint64_t offered = 0, written = 0, dropped = 0, discarded = 0;
  int failed = 0;
  in >> offered >> written >> dropped >> discarded >> failed;
  std::string error;
  in.ignore(1);
  std::getline(in, error);
  std::printf("limit %llu bytes: %llu of %llu written, %llu discarded; error: %s\n",
              static_cast<unsigned long long>(limit), static_cast<unsigned long long>(written),
              static_cast<unsigned long long>(offered), static_cast<unsigned long long>(discarded), error.c_str());
  EXPECT_EQ(failed, 1);
  EXPECT_EQ(offered, kOffers);
  EXPECT_EQ(dropped, 0u);
  EXPECT_GT(written, 0u);
  EXPECT_LT(written, kOffers);
  EXPECT_EQ(offered, written + dropped + discarded);
  EXPECT_NE(error.find(dir + "/frames.csv"), std::string::npos) << error;
  EXPECT_NE(error.find("File too large"), std::string::npos) << error;

  // Exactly the written pairs are listed, in order, and replay byte-identical; the failed pair left no
  // partial line and no image behind.
  const std::vector<std::uint64_t> seqs = replay_all(dir, CV_8UC1, false);
  ASSERT_EQ(seqs.size(), written);
  for (std::size_t i = 0; i < seqs.size(); ++i) EXPECT_EQ(seqs[i], i);
  const std::string csv = test::read_text(fs::path(dir) / "frames.csv");
  ASSERT_FALSE(csv.empty());
  EXPECT_EQ(csv.back(), '\n');
  EXPECT_EQ(count_files(fs::path(dir) / "left"), written);
  EXPECT_EQ(count_files(fs::path(dir) / "right"), written);
}

TEST(FrameRecorder, OfferedPairsComeBackByteIdentical) {
  for (const int type : {CV_8UC1, CV_16UC1}) {
    SCOPED_TRACE(type == CV_8UC1 ? "8-bit" : "16-bit");
    const test::TempDir tmp;
    const std::string dir = (tmp.path() / "rec").string();
    constexpr std::uint64_t kPairs = 20;
    FrameRecorderConfig options;
    options.capacity = kPairs;  // a slot per pair: nothing can be dropped however slow the disk
    FrameRecorder recorder(dir, test_calibration(), options);
    EXPECT_EQ(recorder.directory(), dir);
    // One frame object refilled per pair, as a camera source does: the recorder must have copied it.
    StereoFrame frame;
    for (std::uint64_t i = 0; i < kPairs; ++i) {
      fill_pair(frame, 100 + 2 * i, type);
      EXPECT_TRUE(recorder.offer(frame)) << i;
    }
    recorder.close();
    const FrameRecorderStats s = recorder.stats();
    EXPECT_EQ(s.offered, kPairs);
    EXPECT_EQ(s.written, kPairs);
    EXPECT_EQ(s.dropped, 0u);
    EXPECT_EQ(s.discarded, 0u);
    EXPECT_FALSE(s.failed);
    EXPECT_TRUE(s.error.empty());

    const std::vector<std::uint64_t> seqs = replay_all(dir, type);
    ASSERT_EQ(seqs.size(), kPairs);
    for (std::uint64_t i = 0; i < kPairs; ++i) EXPECT_EQ(seqs[i], 100 + 2 * i);
    // The calibration was copied in.
    const StereoCalibration c = ReplaySource(dir).calibration();
    EXPECT_EQ(cv::norm(cv::Mat(c.M1), cv::Mat(test_calibration().M1), cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(cv::Mat(c.T), cv::Mat(test_calibration().T), cv::NORM_INF), 0.0);

    // After close, offers are refused and counted, and nothing more is written.
    EXPECT_FALSE(recorder.offer(frame));
    EXPECT_EQ(recorder.stats().discarded, 1u);
  }
}

TEST(FrameRecorder, FullQueueDropsAndCountsAndWhatIsWrittenReplays) {
  const test::TempDir tmp;
  const std::string dir = (tmp.path() / "rec").string();
  FrameRecorderConfig options;
  options.capacity = 1;  // the writer holds the only slot while it encodes and syncs
  FrameRecorder recorder(dir, test_calibration(), options);
  // 300 offers of a pair that is already in memory take microseconds each; the writer needs a PNG
  // encode and three fdatasync calls per pair, so it holds the single slot for most of the loop.
  constexpr std::uint64_t kOffers = 300;
  std::vector<StereoFrame> pairs(kOffers);
  for (std::uint64_t i = 0; i < kOffers; ++i) fill_pair(pairs[i], i, CV_8UC1);
  std::uint64_t accepted = 0;
  for (const StereoFrame& p : pairs) accepted += recorder.offer(p);
  recorder.close();
  const FrameRecorderStats s = recorder.stats();
  std::printf("%llu offered: %llu written, %llu dropped\n", static_cast<unsigned long long>(s.offered),
              static_cast<unsigned long long>(s.written), static_cast<unsigned long long>(s.dropped));
  EXPECT_FALSE(s.failed) << s.error;
  EXPECT_EQ(s.offered, kOffers);
  EXPECT_EQ(s.offered, s.written + s.dropped);
  EXPECT_EQ(s.written, accepted);
  EXPECT_GE(s.written, 1u);
  EXPECT_GT(s.dropped, 0u) << "the writer kept up with a tight loop of offers";

  // Everything written replays byte-identical, in increasing seq order, and nothing else is listed.
  const std::vector<std::uint64_t> seqs = replay_all(dir, CV_8UC1);
  EXPECT_EQ(seqs.size(), s.written);
  EXPECT_TRUE(std::is_sorted(seqs.begin(), seqs.end()));
  EXPECT_EQ(count_files(fs::path(dir) / "left"), s.written);
}

TEST(FrameRecorder, FolderGoneStopsRecordingOnceAndListedPairsStayComplete) {
  const test::TempDir tmp;
  const fs::path dir = tmp.path() / "rec";
  FrameRecorderConfig options;
  options.capacity = 16;
  options.writer.sync_to_disk = false;
  FrameRecorder recorder(dir.string(), test_calibration(), options);
  StereoFrame frame;
  for (std::uint64_t seq = 0; seq < 5; ++seq) {
    fill_pair(frame, seq, CV_8UC1);
    ASSERT_TRUE(recorder.offer(frame));
  }
  ASSERT_TRUE(wait_for([&] { return recorder.stats().written == 5; }));
  EXPECT_FALSE(recorder.failed());
  EXPECT_TRUE(recorder.error().empty());

  // left/ becomes a plain file (root ignores permissions, so unwritable means "not a folder" here).
  fs::rename(dir / "left", dir / "left.kept");
  std::ofstream(dir / "left") << "not a folder";
  fill_pair(frame, 5, CV_8UC1);
  EXPECT_TRUE(recorder.offer(frame));
  ASSERT_TRUE(wait_for([&] { return recorder.failed(); }));
  const std::string error = recorder.error();
  std::printf("error: %s\n", error.c_str());
  EXPECT_NE(error.find((dir / "left" / ".00000005.png.tmp").string()), std::string::npos) << error;
  EXPECT_NE(error.find("Not a directory"), std::string::npos) << error;

  // Stopped for good: later offers are refused at once, even once the folder is back.
  fs::remove(dir / "left");
  fs::rename(dir / "left.kept", dir / "left");
  for (std::uint64_t seq = 6; seq < 9; ++seq) {
    fill_pair(frame, seq, CV_8UC1);
    EXPECT_FALSE(recorder.offer(frame));
  }
  recorder.close();
  const FrameRecorderStats s = recorder.stats();
  EXPECT_TRUE(s.failed);
  EXPECT_EQ(s.error, error);
  EXPECT_EQ(s.offered, 9u);
  EXPECT_EQ(s.written, 5u);
  EXPECT_EQ(s.dropped, 0u);
  EXPECT_EQ(s.discarded, 4u);

  const std::vector<std::uint64_t> seqs = replay_all(dir.string(), CV_8UC1);
  EXPECT_EQ(seqs, (std::vector<std::uint64_t>{0, 1, 2, 3, 4}));
  EXPECT_EQ(count_files(dir / "left"), 5u);
  EXPECT_EQ(count_files(dir / "right"), 5u);
}

TEST(FrameRecorder, RecordingTeeForwardsAndRecordsEveryOkPair) {
  // A scripted source: Ok, Timeout, Error, Ok, Ok, EndOfStream.
  class Script final : public FrameSource {
   public:
    SourceStatus next(StereoFrame& frame) override {
      static const SourceStatus order[] = {SourceStatus::Ok, SourceStatus::Timeout, SourceStatus::Error,
                                           SourceStatus::Ok, SourceStatus::Ok,      SourceStatus::EndOfStream};
      const SourceStatus s = order[std::min<std::size_t>(calls_++, std::size(order) - 1)];
      error_ = s == SourceStatus::Error ? "camera lost" : "";
      if (s == SourceStatus::Ok) fill_pair(frame, seq_++, CV_8UC1);
      return s;
    }
    const StereoCalibration& calibration() const override { return calibration_; }
    const std::string& error_message() const override { return error_; }

   private:
    StereoCalibration calibration_ = test_calibration();
    std::string error_;
    std::size_t calls_ = 0;
    std::uint64_t seq_ = 0;
  };
  const test::TempDir tmp;
  const std::string dir = (tmp.path() / "rec").string();
  auto script = std::make_unique<Script>();
  FrameRecorderConfig options;
  options.capacity = 4;
  FrameRecorder recorder(dir, script->calibration(), options);
  RecordingTee source(std::move(script), recorder);
  EXPECT_EQ(source.calibration().image_size, kSize);
  StereoFrame frame;
  std::vector<SourceStatus> got;
  for (int i = 0; i < 6; ++i) {
    got.push_back(source.next(frame));
    if (got.back() == SourceStatus::Error) {
      EXPECT_EQ(source.error_message(), "camera lost");
    }
  }
  EXPECT_EQ(got, (std::vector<SourceStatus>{SourceStatus::Ok, SourceStatus::Timeout, SourceStatus::Error,
                                            SourceStatus::Ok, SourceStatus::Ok, SourceStatus::EndOfStream}));
  recorder.close();
  EXPECT_EQ(recorder.stats().offered, 3u);
  EXPECT_EQ(replay_all(dir, CV_8UC1), (std::vector<std::uint64_t>{0, 1, 2}));
}

TEST(FrameRecorder, ExistingRecordingIsRefusedNotOverwritten) {
  const test::TempDir tmp;
  const std::string dir = (tmp.path() / "rec").string();
  {
    FrameRecorder first(dir, test_calibration());
    StereoFrame frame;
    fill_pair(frame, 7, CV_8UC1);
    ASSERT_TRUE(first.offer(frame));
  }
  const std::string before = test::read_text(fs::path(dir) / "frames.csv");
  EXPECT_THROW((void)FrameRecorder(dir, test_calibration()), InputError);
  EXPECT_EQ(test::read_text(fs::path(dir) / "frames.csv"), before);
  EXPECT_EQ(replay_all(dir, CV_8UC1), (std::vector<std::uint64_t>{7}));
  FrameRecorderConfig bad;
  bad.capacity = 0;
  EXPECT_THROW((void)FrameRecorder((tmp.path() / "other").string(), test_calibration(), bad), std::invalid_argument);
  EXPECT_FALSE(fs::exists(tmp.path() / "other"));
}

}  // namespace
}  // namespace rutd
