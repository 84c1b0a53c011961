// `rutd run` on a looping replay source (source.replay.loop): the recording plays over and over, and
// sequence numbers and timestamps are rebased so that they keep increasing across loops (a recording of
// the replay, which refuses time going backwards, depends on it). The replay is recorded again with
// --record; the truth is the source recording's own frames.csv and images, read with ReplaySource.
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "recording/recording.hpp"
#include "test_support.hpp"

namespace rutd {
namespace {

namespace fs = std::filesystem;

std::vector<StereoFrame> read_all(const fs::path& dir) {
  ReplaySource replay(dir.string());
  std::vector<StereoFrame> out;
  for (;;) {
    StereoFrame f;
    const SourceStatus s = replay.next(f);
    if (s == SourceStatus::EndOfStream) break;
    EXPECT_EQ(s, SourceStatus::Ok) << replay.error_message();
    if (s != SourceStatus::Ok) break;
    out.push_back(f);
  }
  return out;
}

bool same(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
}

TEST(ReplayLoop, RunLoopsTheRecordingWithIncreasingSequenceAndTime) {
  test::TempDir tmp;
  const fs::path src = tmp.path() / "src", out = tmp.path() / "out", cfg = tmp.path() / "loop.yaml",
                 err = tmp.path() / "run.err";
  constexpr std::size_t kPairs = 5;
  ASSERT_EQ(test::run_rutd("synth " + test::quoted(src) + " --frames 5 --size 320x240 >/dev/null"), 0);
  std::ofstream(cfg) << "source:\n  type: replay\n  replay:\n    dir: " << src.string()
                     << "\n    paced: true\n    loop: true\nsinks:\n  candump: \"\"\n";
  ASSERT_EQ(
      test::run_rutd("run --config " + test::quoted(cfg) + " --frames 24 --record " + test::quoted(out), err.string()),
      0)
      << test::read_text(err);

  const std::vector<StereoFrame> source = read_all(src);
  ASSERT_EQ(source.size(), kPairs);
  // Loop L, pair i: the source's time line shifted by L loop lengths, a loop being the recording's span
  // plus one frame step (its last step), so that the time line goes on evenly.
  const std::int64_t t0 = source.front().t_ns, step = source[kPairs - 1].t_ns - source[kPairs - 2].t_ns;
  const std::int64_t loop_ns = source[kPairs - 1].t_ns - t0 + step;
  ASSERT_GT(step, 0);
  for (std::size_t i = 0; i < kPairs; ++i) ASSERT_EQ(source[i].seq, i) << "synth numbers pairs from 0";

  const std::vector<StereoFrame> replayed = read_all(out);  // refuses seq or time going backwards
  ASSERT_GE(replayed.size(), 3 * kPairs) << test::read_text(err);
  std::uint64_t checked = 0, later_loops = 0;
  for (const StereoFrame& f : replayed) {
    const std::uint64_t loop = f.seq / kPairs, i = f.seq % kPairs;
    SCOPED_TRACE("seq " + std::to_string(f.seq));
    EXPECT_EQ(f.seq, source[i].seq + loop * kPairs);
    EXPECT_EQ(f.t_ns, source[i].t_ns + static_cast<std::int64_t>(loop) * loop_ns);
    EXPECT_TRUE(same(f.left, source[i].left) && same(f.right, source[i].right)) << "not the source's pair " << i;
    ++checked;
    later_loops += loop > 0;
  }
  EXPECT_EQ(checked, replayed.size());
  EXPECT_GE(later_loops, 2 * kPairs) << "fewer than two later loops were checked";
}

}  // namespace
}  // namespace rutd
