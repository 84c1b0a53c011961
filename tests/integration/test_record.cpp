// Recording as a user runs it: `rutd record` killed with SIGKILL at random moments leaves a folder whose
// every listed pair replays (and `rutd replay` measures them all); `rutd run --record` on a disk that
// fills up (a 3 MB tmpfs) or under a file-size limit reports one clear error naming the file, keeps
// measuring, and raises RecordingError in the status frames (decoded by canmatrix, independently of rutd).
#include <fcntl.h>
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
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "recording/measurement_csv.hpp"
#include "recording/recording.hpp"
#include "test_support.hpp"

extern char** environ;

namespace rutd {
namespace {

namespace fs = std::filesystem;

const cv::Size kSize(320, 240);

std::vector<std::string> lines_of(const fs::path& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

// Checks a recording folder the way replay reads it: every complete line of frames.csv must replay
// (both images load, sizes match the calibration and kSize). Returns the listed seqs in order.
std::vector<std::uint64_t> check_every_listed_pair_replays(const fs::path& dir) {
  const std::string csv = test::read_text(dir / "frames.csv");
  const auto complete_lines = static_cast<std::size_t>(std::count(csv.begin(), csv.end(), '\n'));
  EXPECT_GE(complete_lines, 1u) << "no header line in " << dir;
  ReplaySource reader(dir.string());
  EXPECT_EQ(reader.calibration().image_size, kSize);
  std::vector<std::uint64_t> seqs;
  StereoFrame frame;
  for (SourceStatus s; (s = reader.next(frame)) != SourceStatus::EndOfStream;) {
    EXPECT_EQ(s, SourceStatus::Ok) << reader.error_message();
    if (s != SourceStatus::Ok) continue;
    EXPECT_EQ(frame.left.size(), reader.calibration().image_size) << frame.seq;
    EXPECT_EQ(frame.right.size(), reader.calibration().image_size) << frame.seq;
    seqs.push_back(frame.seq);
  }
  EXPECT_FALSE(reader.truncated_tail()) << reader.truncation_note();
  EXPECT_EQ(seqs.size() + 1, complete_lines) << "listed pairs that do not replay in " << dir;
  return seqs;
}

std::size_t count_entries(const fs::path& dir) {
  std::error_code ec;
  std::size_t n = 0;
  for (const auto& e : fs::directory_iterator(dir, ec)) n += e.is_regular_file();
  return n;
}

pid_t spawn(const std::vector<std::string>& args, const std::string& stderr_path) {
  std::vector<std::string> copy = args;
  std::vector<char*> argv;
  for (auto& a : copy) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 2, stderr_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  return rc == 0 ? pid : -1;
}

TEST(Record, KilledAtRandomMomentsEveryListedPairReplays) {
  const test::TempDir tmp;
  const fs::path config = tmp.path() / "small.yaml";
  std::ofstream(config) << "source:\n  synthetic:\n    size: " << kSize.width << "x" << kSize.height << "\n";
  const char* seed_env = std::getenv("RUTD_TEST_SEED");
  const unsigned seed =
      seed_env != nullptr ? static_cast<unsigned>(std::strtoul(seed_env, nullptr, 10)) : std::random_device{}();
  std::printf("seed %u (set RUTD_TEST_SEED to repeat)\n", seed);
  std::mt19937 rng(seed);
  // The first half from launch: from during start-up (before the folder exists) to well into the recording.
  // The second half from the first listed pair on, so that some kills land inside a recording however
  // slowly a loaded machine starts rutd.
  std::uniform_int_distribution<int> delay_ms(50, 1300), after_first_ms(0, 400);

  constexpr int kRuns = 8;
  std::size_t total_listed = 0;
  int runs_with_pairs = 0;
  for (int run = 0; run < kRuns; ++run) {
    const bool after_first = run >= kRuns / 2;
    const int delay = after_first ? after_first_ms(rng) : delay_ms(rng);
    const bool sync = run % 2 == 0;
    SCOPED_TRACE("run " + std::to_string(run) + ", killed after " + std::to_string(delay) + " ms" +
                 (after_first ? " from the first listed pair" : ""));
    const fs::path dir = tmp.path() / ("rec" + std::to_string(run));
    std::vector<std::string> args{RUTD_BINARY, "record", dir.string(), "--config", config.string()};
    if (!sync) args.push_back("--no-sync");
    const pid_t pid = spawn(args, (tmp.path() / "record.err").string());
    ASSERT_GT(pid, 0);
    if (after_first) {  // a header and one pair's line
      const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(60);
      const auto listed = [&] {
        const std::string text = test::read_text(dir / "frames.csv");
        const std::size_t header_end = text.find('\n');
        return header_end != std::string::npos && text.find('\n', header_end + 1) != std::string::npos;
      };
      while (!listed() && std::chrono::steady_clock::now() < give_up)
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(delay));
    ASSERT_EQ(kill(pid, SIGKILL), 0);
    int status = 0;
    ASSERT_EQ(waitpid(pid, &status, 0), pid);
    ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL)
        << "rutd record ended by itself: " << test::read_text(tmp.path() / "record.err");

    if (!fs::exists(dir / "frames.csv")) {
      // Killed before the recording was created: nothing is listed, so nothing can be missing.
      std::printf("run %d: killed after %4d ms (%s): no frames.csv yet\n", run, delay, sync ? "sync" : "no sync");
      EXPECT_FALSE(after_first) << "no frames.csv, although a pair was listed before the kill";
      continue;
    }
    const std::vector<std::uint64_t> seqs = check_every_listed_pair_replays(dir);
    // Images written for a pair whose line the kill prevented are harmless leftovers, never listed.
    const std::size_t leftovers = count_entries(dir / "left") + count_entries(dir / "right") - 2 * seqs.size();
    std::printf("run %d: killed after %4d ms (%s): %3zu pairs listed, all replay; %zu unlisted image files\n", run,
                delay, sync ? "sync" : "no sync", seqs.size(), leftovers);
    total_listed += seqs.size();
    if (seqs.empty()) continue;
    ++runs_with_pairs;

    // `rutd replay` measures every listed pair, in order.
    const fs::path measured = tmp.path() / ("m" + std::to_string(run) + ".csv");
    ASSERT_EQ(test::run_rutd("replay " + test::quoted(dir) + " --no-dic --out " + test::quoted(measured),
                             (tmp.path() / "replay.err").string()),
              0)
        << test::read_text(tmp.path() / "replay.err");
    const MeasurementCsv m = read_measurement_csv(measured.string());
    ASSERT_EQ(m.rows.size(), seqs.size());
    for (std::size_t i = 0; i < seqs.size(); ++i) EXPECT_EQ(m.rows[i].seq, seqs[i]);
  }
  std::printf("%d runs, %d with pairs, %zu pairs checked\n", kRuns, runs_with_pairs, total_listed);
  EXPECT_GE(runs_with_pairs, kRuns / 2) << "kills after the first listed pair left no pairs to check";
}

TEST(Record, CommandLimitsSignalsExistingFolderAndFailureExitCodes) {
  const test::TempDir tmp;
  const fs::path config = tmp.path() / "small.yaml";
  std::ofstream(config) << "source:\n  synthetic:\n    size: " << kSize.width << "x" << kSize.height << "\n";
  const std::string cfg = " --config " + test::quoted(config);
  const fs::path err = tmp.path() / "err";

  // --frames N: exactly N pairs written.
  const fs::path five = tmp.path() / "five";
  ASSERT_EQ(test::run_rutd("record " + test::quoted(five) + cfg + " --frames 5 --no-sync", err.string()), 0)
      << test::read_text(err);
  EXPECT_EQ(check_every_listed_pair_replays(five).size(), 5u);

  // An existing recording is refused (bad input, exit 2) and left as it was.
  const std::string before = test::read_text(five / "frames.csv");
  EXPECT_EQ(test::run_rutd("record " + test::quoted(five) + cfg + " --frames 5", err.string()), 2);
  EXPECT_NE(test::read_text(err).find("already holds a recording"), std::string::npos) << test::read_text(err);
  EXPECT_EQ(test::read_text(five / "frames.csv"), before);

  // --duration: stops by itself.
  const fs::path timed = tmp.path() / "timed";
  ASSERT_EQ(test::run_rutd("record " + test::quoted(timed) + cfg + " --duration 0.5", err.string()), 0)
      << test::read_text(err);
  check_every_listed_pair_replays(timed);

  // A failed recording: exit 1 with the message naming the file.
  const fs::path limited = tmp.path() / "limited";
  EXPECT_EQ(test::run_shell("prlimit --fsize=32768 " + test::quoted(RUTD_BINARY) + " record " + test::quoted(limited) +
                            cfg + " --frames 5 2>" + test::quoted(err)),
            1);
  const std::string failed = test::read_text(err);
  EXPECT_NE(failed.find(limited.string() + "/left/"), std::string::npos) << failed;
  EXPECT_NE(failed.find("File too large"), std::string::npos) << failed;
  EXPECT_TRUE(check_every_listed_pair_replays(limited).empty());

  // SIGINT: stops cleanly, exit 0, what was queued is written and listed.
  const fs::path interrupted = tmp.path() / "interrupted";
  const pid_t pid = spawn({RUTD_BINARY, "record", interrupted.string(), "--config", config.string()}, err.string());
  ASSERT_GT(pid, 0);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (lines_of(interrupted / "frames.csv").size() < 4 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ASSERT_EQ(kill(pid, SIGINT), 0);
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status)) << test::read_text(err);
  EXPECT_EQ(WEXITSTATUS(status), 0) << test::read_text(err);
  EXPECT_GE(check_every_listed_pair_replays(interrupted).size(), 3u);
  EXPECT_NE(test::read_text(err).find("recorded "), std::string::npos) << test::read_text(err);
}

// The RecordingError signal of every RutSensorStatus frame of a candump log, decoded by canmatrix
// (tests/can/decode_candump.py, which also checks CRCs and counters).
std::vector<int> decoded_recording_error(const fs::path& log, const fs::path& work) {
  const fs::path decoded = work / "decoded.csv";
  const std::string cmd = std::string("/usr/bin/python3 ") + RUTD_SOURCE_DIR + "/tests/can/decode_candump.py " +
                          RUTD_SOURCE_DIR + "/config/rutd.dbc " + test::quoted(log) + " > " + test::quoted(decoded) +
                          " 2> " + test::quoted(work / "decode.err");
  EXPECT_EQ(test::run_shell(cmd), 0) << test::read_text(work / "decode.err");
  std::vector<int> values;
  for (const std::string& line : lines_of(decoded)) {
    // index,t_ns,message,signal,raw,phys,named,na
    std::vector<std::string> f;
    std::stringstream ss(line);
    for (std::string x; std::getline(ss, x, ',');) f.push_back(x);
    if (f.size() >= 5 && f[2] == "RutSensorStatus" && f[3] == "RecordingError") values.push_back(std::stoi(f[4]));
  }
  return values;
}

bool have_canmatrix() { return std::system("/usr/bin/python3 -c 'import canmatrix' >/dev/null 2>&1") == 0; }

// What both disk failures must show: one error line naming a file of the recording and the OS reason,
// all `frames` measurements published, every listed pair replayable, and the status frames raising
// RecordingError once the recording failed and keeping it raised.
void expect_recording_failed_measuring_went_on(const fs::path& work, const fs::path& err, const std::string& rec_dir,
                                               const std::string& reason, const fs::path& csv, std::size_t frames,
                                               const fs::path& log, const fs::path& recording) {
  const std::vector<std::string> stderr_lines = lines_of(err);
  std::vector<std::string> reason_lines;
  for (const auto& l : stderr_lines)
    if (l.find(reason) != std::string::npos) reason_lines.push_back(l);
  ASSERT_EQ(reason_lines.size(), 1u) << test::read_text(err);
  const std::string& error = reason_lines[0];
  std::printf("stderr: %s\n", error.c_str());
  EXPECT_NE(error.find(" error "), std::string::npos) << error;
  EXPECT_NE(error.find(rec_dir + "/"), std::string::npos) << "the error does not name the file: " << error;

  const MeasurementCsv m = read_measurement_csv(csv.string());
  // --frames N stops once N were published; a few more may follow before the pipeline stops.
  EXPECT_GE(m.rows.size(), frames) << "measuring stopped with the recording";
  std::printf("%zu measurements published\n", m.rows.size());

  const std::vector<std::uint64_t> seqs = check_every_listed_pair_replays(recording);
  std::printf("%zu pairs listed before the failure, all replay\n", seqs.size());

  if (!have_canmatrix())
    RUTD_SKIP_NEEDS_INSTALLED("status frames not decoded: needs canmatrix (Debian package python3-canmatrix)");
  const std::vector<int> flags = decoded_recording_error(log, work);
  ASSERT_FALSE(flags.empty()) << "no status frames";
  const auto first_raised = std::find(flags.begin(), flags.end(), 1);
  ASSERT_NE(first_raised, flags.end()) << "RecordingError never raised";
  EXPECT_TRUE(std::all_of(first_raised, flags.end(), [](int v) { return v == 1; })) << "RecordingError dropped again";
  std::printf("status frames: %zu with RecordingError 0, then %zu with 1\n",
              static_cast<std::size_t>(first_raised - flags.begin()),
              static_cast<std::size_t>(flags.end() - first_raised));
}

TEST(Record, FullDiskStopsRecordingWithOneErrorAndMeasuringGoesOn) {
  const test::TempDir tmp;
  const fs::path mnt = tmp.path() / "mnt";
  fs::create_directory(mnt);
  // Paths under TempDir hold no quotes or spaces, so they go into the inner command line unquoted.
  if (test::run_shell("unshare -m sh -c " + test::quoted("mount -t tmpfs -o size=64k tmpfs " + mnt.string()) +
                      " >/dev/null 2>&1") != 0) {
    RUTD_SKIP_NEEDS_INSTALLED(
        "needs permission to mount a tmpfs in a private mount namespace (unshare -m: root or CAP_SYS_ADMIN)");
  }
  const fs::path csv = tmp.path() / "m.csv", log = tmp.path() / "can.log", err = tmp.path() / "run.err",
                 copy = tmp.path() / "rec-copy";
  const std::string rec = (mnt / "rec").string();
  // The tmpfs lives only in the namespace, so the recording is copied out before it ends.
  const std::string inner = "mount -t tmpfs -o size=3m tmpfs " + mnt.string() + " && " + std::string(RUTD_BINARY) +
                            " run --size 320x240 --frames 60 --record " + rec + " --csv " + csv.string() +
                            " --candump " + log.string() + " 2>" + err.string() + "; rc=$?; cp -a " + rec + " " +
                            copy.string() + "; exit $rc";
  const int rc = test::run_shell("unshare -m sh -c " + test::quoted(inner));
  ASSERT_EQ(rc, 0) << test::read_text(err);
  expect_recording_failed_measuring_went_on(tmp.path(), err, rec, "No space left on device", csv, 60, log, copy);
}

TEST(Record, FileSizeLimitStopsRecordingWithOneErrorAndMeasuringGoesOn) {
  const test::TempDir tmp;
  const fs::path csv = tmp.path() / "m.csv", log = tmp.path() / "can.log", err = tmp.path() / "run.err",
                 rec = tmp.path() / "rec";
  // 32 KiB: more than the CSV, the candump log, the log on stderr and calibration.yaml of this short
  // run need, less than one 320x240 PNG of the synthetic ground. Without ignoring SIGXFSZ the daemon
  // would be killed by the first oversized write.
  const int rc = test::run_shell("prlimit --fsize=32768 " + test::quoted(RUTD_BINARY) +
                                 " run --size 320x240 --frames 30" + " --record " + test::quoted(rec) + " --csv " +
                                 test::quoted(csv) + " --candump " + test::quoted(log) + " 2>" + test::quoted(err));
  ASSERT_EQ(rc, 0) << test::read_text(err);
  expect_recording_failed_measuring_went_on(tmp.path(), err, rec.string(), "File too large", csv, 30, log, rec);
}

}  // namespace
}  // namespace rutd
