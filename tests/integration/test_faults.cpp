// Faults injected at the daemon's lowest I/O calls (core/io_faults.hpp), through the test program
// rutd_faults (tests/fault/rutd_faults.cpp), which runs rutd's own `run` command: camera buffer pops
// (timeouts, corrupt and short buffers), CAN writes (EAGAIN, ENOBUFS, ENETDOWN), recording writes
// (ENOSPC, EIO, short writes), measurement CSV writes and image decoding when replaying. Each fault is on for a window
// in the middle of the run. For each, the test checks against sources rutd does not control:
//   - the daemon keeps running: it is alive until SIGTERM and then exits 0;
//   - the status frame carries the fault: the candump log decoded by canmatrix with config/rutd.dbc
//     (tests/can/decode_candump.py) has RutSensorStatus frames with the fault's flag raised;
//   - counters rise: the daemon's own counters (its log) equal the number of faults injected;
//   - measuring resumes: after the last status frame with the flag, OK measurements are sent again and
//     the flag stays down (a failed recording stays failed by design: RecordingError then stays up while
//     measuring goes on).
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "recording/measurement_csv.hpp"
#include "recording/recording.hpp"
#include "test_support.hpp"

namespace rutd {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

// The fault window (seconds since the first call at the faulty point: about when measuring starts) and
// how long the daemon runs after its first good measurement: it measures before, during and after.
constexpr double kFrom = 1.5, kUntil = 3.5;
constexpr auto kRunAfterReady = std::chrono::seconds(7);

struct DecodeSummary {
  int frames = -1, crc_errors = -1, counter_errors = -1, unknown_frames = -1, bad_lines = -1;
};

// Decodes a candump log with canmatrix and the DBC; one entry per frame, in log order.
std::vector<test::DecodedFrame> decode(const fs::path& log, DecodeSummary& summary) {
  const fs::path out = log.string() + ".csv", err = log.string() + ".err";
  test::run_shell(std::string("/usr/bin/python3 ") + RUTD_SOURCE_DIR + "/tests/can/decode_candump.py " +
                  RUTD_SOURCE_DIR + "/config/rutd.dbc " + test::quoted(log) + " >" + test::quoted(out) + " 2>" +
                  test::quoted(err));
  std::smatch m;
  const std::string err_text = test::read_text(err);
  if (std::regex_search(err_text, m,
                        std::regex("frames=(\\d+) crc_errors=(\\d+) counter_errors=(\\d+) unknown_frames=(\\d+) "
                                   "bad_lines=(\\d+)"))) {
    summary = {std::stoi(m[1]), std::stoi(m[2]), std::stoi(m[3]), std::stoi(m[4]), std::stoi(m[5])};
  }
  return test::read_decoded_csv(out);
}

// The integer after `label` in the text (the last occurrence); -1 if absent.
long long number_after(const std::string& text, const std::string& label) {
  const std::size_t at = text.rfind(label);
  if (at == std::string::npos) return -1;
  return std::stoll(text.substr(at + label.size()));
}

// The RutMeasurement1 frames (any status) a candump log holds so far: its identifier in config/rutd.dbc
// (2566869152 = 0x80000000 | 0x18FF50A0). Used only to decide when a run has measured enough; what the
// tests assert is decoded by canmatrix.
int measurement_lines(const fs::path& log) { return test::count_lines(log, " 18FF50A0#"); }

// Runs `rutd_faults FAULT_ARGS run RUN_ARGS` for kRunAfterReady after its first good measurement, and on
// until `log` holds `min_after_window` measurement frames sent after the fault window, at most a minute in
// all, then SIGTERM. A busy machine renders and measures slowly (CI measured 0.9 Hz live rendering beside
// other tests), so a fixed run length would leave too few measurements after the window to tell that
// measuring resumed. The window starts at the first camera pop, before the first good measurement, so it
// has ended by kUntil after "ready" (plus a second for frames still in the pipeline). Returns the exit
// status (-1: did not exit normally, -2: exited before the signal, i.e. it did not keep running).
int run_for(const std::string& fault_args, const std::string& run_args, const fs::path& err, const fs::path& log,
            int min_after_window = 0) {
  const std::string cmd = "exec " + test::quoted(RUTD_FAULTS_BINARY) + " " + fault_args + " run " + run_args +
                          " >/dev/null 2>" + test::quoted(err);
  const pid_t pid = fork();
  if (pid == 0) {
    execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  using Clock = std::chrono::steady_clock;
  constexpr auto kPipelineLag = std::chrono::seconds(1);
  const auto window_s = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(kUntil));
  const auto give_up = Clock::now() + std::chrono::seconds(60);
  std::optional<Clock::time_point> ready;
  std::optional<int> at_window_end;  // measurement frames logged when the window had surely ended
  int status = 0;
  while (Clock::now() < give_up) {
    std::this_thread::sleep_for(50ms);
    if (waitpid(pid, &status, WNOHANG) == pid) return -2;
    const auto now = Clock::now();
    if (!ready) {
      if (test::read_text(err).find("ready: first good measurement") != std::string::npos) ready = now;
      continue;
    }
    if (!at_window_end && now >= *ready + window_s + kPipelineLag) at_window_end = measurement_lines(log);
    if (now < *ready + kRunAfterReady || !at_window_end) continue;
    if (min_after_window <= 0 || measurement_lines(log) - *at_window_end >= min_after_window) break;
    std::this_thread::sleep_for(200ms);  // the log is re-read at most 4 times a second
  }
  kill(pid, SIGTERM);
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string window(const std::string& point, const std::string& fault, int every) {
  return "--fault " + point + ":" + fault + ":every=" + std::to_string(every) + ":from=" + std::to_string(kFrom) +
         ":until=" + std::to_string(kUntil);
}

// What a run's CAN log says about one status flag and the measurements around it.
struct FlagTimeline {
  int status_frames = 0, raised = 0;
  int ok_before_first_raised = 0;
  int ok_after_last_raised = 0;       // RutMeasurement1 with status OK after the last raised status frame
  int cleared_after_last_raised = 0;  // status frames after it, flag down
};

FlagTimeline timeline(const std::vector<test::DecodedFrame>& frames, const std::string& flag) {
  FlagTimeline t;
  std::size_t first = frames.size(), last = frames.size();
  for (std::size_t i = 0; i < frames.size(); ++i) {
    if (frames[i].message != "RutSensorStatus") continue;
    ++t.status_frames;
    if (frames[i].raw.at(flag) != 0) {
      ++t.raised;
      if (first == frames.size()) first = i;
      last = i;
    }
  }
  if (last == frames.size()) return t;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const bool ok = frames[i].message == "RutMeasurement1" && frames[i].raw.at("RutM1_Status") == 0;
    if (i < first && ok) ++t.ok_before_first_raised;
    if (i > last && ok) ++t.ok_after_last_raised;
    if (i > last && frames[i].message == "RutSensorStatus") ++t.cleared_after_last_raised;
  }
  return t;
}

class Faults : public ::testing::Test {
 protected:
  fs::path log() const { return tmp_.path() / "can.log"; }
  fs::path err() const { return tmp_.path() / "run.err"; }
  std::string base_args() const { return "--size 320x240 --candump " + test::quoted(log()); }

  // Runs with the fault, checks that the daemon kept running and that `flag` was raised and then went
  // down with OK measurements after it (unless `flag_stays`). Returns the daemon's log.
  std::string run_and_check_flag(const std::string& fault_args, const std::string& run_args, const std::string& flag,
                                 bool flag_stays = false, bool counter_gaps_expected = false, int min_ok_after = 20) {
    // Five more than asked for: not every measurement after the window need be OK.
    const int rc = run_for(fault_args, base_args() + " " + run_args, err(), log(), min_ok_after + 5);
    const std::string text = test::read_text(err());
    EXPECT_EQ(rc, 0) << "the daemon did not run until SIGTERM and exit cleanly\n" << text;
    DecodeSummary s;
    const std::vector<test::DecodedFrame> frames = decode(log(), s);
    EXPECT_GT(s.frames, 0) << test::read_text(log().string() + ".err");
    EXPECT_EQ(s.crc_errors, 0);
    EXPECT_EQ(s.unknown_frames, 0);
    EXPECT_EQ(s.bad_lines, 0);
    if (counter_gaps_expected) {
      EXPECT_GT(s.counter_errors, 0) << "frames were not sent, so the receiver must see counter gaps";
    } else {
      EXPECT_EQ(s.counter_errors, 0);
    }
    const FlagTimeline t = timeline(frames, flag);
    std::printf("%s: %d status frames, %d with %s; OK measurements %d before, %d after; %d status frames after\n",
                fault_args.c_str(), t.status_frames, t.raised, flag.c_str(), t.ok_before_first_raised,
                t.ok_after_last_raised, t.cleared_after_last_raised);
    EXPECT_GT(t.raised, 0) << flag << " never raised\n" << text;
    EXPECT_GT(t.ok_before_first_raised, 0) << "nothing measured before the fault";
    if (flag_stays) {
      EXPECT_GE(t.ok_after_last_raised, 0);
      EXPECT_GE(t.cleared_after_last_raised, 0);
    } else {
      EXPECT_GE(t.ok_after_last_raised, min_ok_after) << "measuring did not resume after the fault\n" << text;
      EXPECT_GE(t.cleared_after_last_raised, 5) << flag << " did not go down after the fault";
    }
    return text;
  }

  test::TempDir tmp_;
};

TEST_F(Faults, CameraPopTimeoutsRaiseNoCameraAndCountAsTimeouts) {
  const std::string text = run_and_check_flag(window("camera-pop", "timeout", 1), "", "NoCamera");
  const long long injected = number_after(text, "injected camera-pop ");
  EXPECT_GT(injected, 20);
  EXPECT_EQ(number_after(text, "timeouts "), injected) << text;
  std::printf("  injected %lld, pipeline source timeouts %lld\n", injected, number_after(text, "timeouts "));
}

TEST_F(Faults, CorruptAndShortCameraBuffersRaiseNoCameraAndCountAsSourceErrors) {
  // The default cycles pre-rendered pairs; "live" renders every pair as it is popped (cycle_frames: 0).
  const fs::path live = tmp_.path() / "live.yaml";
  std::ofstream(live) << "source:\n  type: synthetic\n  synthetic:\n    size: 320x240\n    cycle_frames: 0\n";
  for (const std::string fault : {"corrupt", "short", "corrupt live"}) {
    SCOPED_TRACE(fault);
    const bool is_live = fault.find("live") != std::string::npos;
    // Live rendering runs at a few pairs per second in a sanitizer build: there every pop of the window
    // fails, and fewer measurements are asked for after it.
    const std::string text =
        run_and_check_flag(window("camera-pop", fault.substr(0, fault.find(' ')), is_live ? 1 : 3),
                           is_live ? "--config " + test::quoted(live) : "", "NoCamera", false, false, is_live ? 5 : 20);
    const long long injected = number_after(text, "injected camera-pop ");
    EXPECT_GT(injected, is_live ? 2 : 5);
    std::smatch m;  // "errors SOURCE/STAGE/SINK" of the final stats line
    ASSERT_TRUE(std::regex_search(text, m, std::regex("stopped: .* errors (\\d+)/(\\d+)/(\\d+)"))) << text;
    EXPECT_EQ(std::stoll(m[1]), injected) << text;
    EXPECT_EQ(std::stoll(m[2]), 0);
    std::printf("  injected %lld, pipeline source errors %s\n", injected, m[1].str().c_str());
  }
}

TEST_F(Faults, CanWriteErrorsRaiseCanTxDropsAndAreCounted) {
  for (const char* fault : {"EAGAIN", "ENOBUFS", "ENETDOWN"}) {
    SCOPED_TRACE(fault);
    const std::string text = run_and_check_flag("--can-socketpair " + window("can-write", fault, 3), "--socketcan can0",
                                                "CanTxDrops", false, true);
    const long long injected = number_after(text, "injected can-write ");
    EXPECT_GT(injected, 10);
    // "CAN can0: S frames sent, D dropped (queue full), W write errors, B bus-off events"
    std::smatch m;
    ASSERT_TRUE(std::regex_search(
        text, m, std::regex("CAN can0: (\\d+) frames sent, (\\d+) dropped \\(queue full\\), (\\d+) write errors")))
        << text;
    const bool queue_full = std::string(fault) != "ENETDOWN";
    EXPECT_EQ(std::stoll(m[queue_full ? 2 : 3]), injected) << text;
    EXPECT_EQ(std::stoll(m[queue_full ? 3 : 2]), 0) << text;
    // Every frame reported sent reached the other end of the socket, and is in the candump log.
    EXPECT_EQ(number_after(text, "peer received "), std::stoll(m[1])) << text;
    std::printf("  injected %lld; bus: %s sent, %s dropped, %s write errors; peer received %lld\n", injected,
                m[1].str().c_str(), m[2].str().c_str(), m[3].str().c_str(), number_after(text, "peer received "));
    DecodeSummary s;
    decode(log(), s);
    EXPECT_EQ(s.frames, std::stoll(m[1]));
  }
}

// frames.csv lists only pairs whose images were completely written, and each replays.
std::uint64_t replayable_pairs(const fs::path& rec) {
  ReplaySource replay(rec.string());
  StereoFrame frame;
  std::uint64_t n = 0;
  for (SourceStatus s; (s = replay.next(frame)) != SourceStatus::EndOfStream; ++n) {
    EXPECT_EQ(s, SourceStatus::Ok) << replay.error_message();
    if (s != SourceStatus::Ok) break;
  }
  return n;
}

TEST_F(Faults, RecordingWriteErrorsRaiseRecordingErrorWhileMeasuringGoesOn) {
  for (const char* fault : {"ENOSPC", "EIO"}) {
    SCOPED_TRACE(fault);
    const fs::path rec = tmp_.path() / (std::string("rec-") + fault);
    const std::string text =
        run_and_check_flag(window("record-write", fault, 1), "--record " + test::quoted(rec), "RecordingError", true);
    EXPECT_EQ(number_after(text, "injected record-write "), 1) << "the first failed write stops the recording";
    EXPECT_NE(text.find(std::string(": ") + std::strerror(fault == std::string("EIO") ? EIO : ENOSPC)),
              std::string::npos)
        << text;
    // "recording DIR: W pairs written, D dropped (writer behind), stopped by an error, N pairs not recorded"
    std::smatch m;
    ASSERT_TRUE(std::regex_search(text, m,
                                  std::regex("(\\d+) pairs written, \\d+ dropped \\(writer behind\\), stopped by an "
                                             "error, (\\d+) pairs not recorded")))
        << text;
    EXPECT_GT(std::stoll(m[1]), 0);
    EXPECT_GT(std::stoll(m[2]), 0);
    EXPECT_EQ(replayable_pairs(rec), std::stoull(m[1]));
    std::printf("  injected 1; recorder: %s pairs written (all replay), %s not recorded after the failure\n",
                m[1].str().c_str(), m[2].str().c_str());
    // Measuring went on after the recording failed.
    DecodeSummary s;
    const FlagTimeline t = timeline(decode(log(), s), "RecordingError");
    EXPECT_GE(t.ok_after_last_raised, 0);
    int ok_after_first = 0;
    bool raised = false;
    for (const test::DecodedFrame& f : decode(log(), s)) {
      if (f.message == "RutSensorStatus" && f.raw.at("RecordingError") != 0) raised = true;
      if (raised && f.message == "RutMeasurement1" && f.raw.at("RutM1_Status") == 0) ++ok_after_first;
    }
    EXPECT_GE(ok_after_first, 30) << "measuring did not go on after the recording failed";
    std::printf("  OK measurements after RecordingError was raised: %d\n", ok_after_first);
  }
}

TEST_F(Faults, ShortRecordingWritesLoseNothing) {
  const fs::path rec = tmp_.path() / "rec";
  // Every write of the run is cut short: write_all must carry on with the rest of each buffer.
  const int rc = run_for("--fault record-write:short", base_args() + " --record " + test::quoted(rec), err(), log());
  const std::string text = test::read_text(err());
  ASSERT_EQ(rc, 0) << text;
  EXPECT_GT(number_after(text, "injected record-write "), 100);
  std::smatch m;
  ASSERT_TRUE(std::regex_search(text, m, std::regex("(\\d+) pairs written, \\d+ dropped \\(writer behind\\)\n")))
      << text;
  EXPECT_GT(std::stoll(m[1]), 30);
  EXPECT_EQ(replayable_pairs(rec), std::stoull(m[1]));
  std::printf("short writes: injected %lld, %s pairs written, every one replays\n",
              number_after(text, "injected record-write "), m[1].str().c_str());
  DecodeSummary s;
  EXPECT_EQ(timeline(decode(log(), s), "RecordingError").raised, 0);
}

// The measurement CSV under failed writes: RecordingError in the status frames while rows are lost, the
// file stays a valid CSV (read back by read_measurement_csv), every published measurement is either a
// row or counted lost (the candump log has one RutMeasurement1 frame per measurement), and rows are
// written again after the fault.
TEST_F(Faults, MeasurementCsvWriteErrorsRaiseRecordingErrorAndTheCsvResumes) {
  for (const char* fault : {"ENOSPC", "EIO"}) {
    SCOPED_TRACE(fault);
    const fs::path csv = tmp_.path() / (std::string("m-") + fault + ".csv");
    const std::string text =
        run_and_check_flag(window("csv-write", fault, 2), "--csv " + test::quoted(csv), "RecordingError");
    const long long injected = number_after(text, "injected csv-write ");
    EXPECT_GT(injected, 5);
    // "measurement CSV PATH: W rows written, L lost (the last: PATH: cannot write the row of seq N: REASON)"
    std::smatch m;
    ASSERT_TRUE(std::regex_search(text, m,
                                  std::regex("measurement CSV .*: (\\d+) rows written, (\\d+) lost \\(the last: .*"
                                             "cannot write the row of seq (\\d+): ([^)]*)\\)")))
        << text;
    const std::uint64_t written = std::stoull(m[1]), lost = std::stoull(m[2]), last_lost_seq = std::stoull(m[3]);
    EXPECT_EQ(lost, static_cast<std::uint64_t>(injected));
    EXPECT_EQ(m[4].str(), std::strerror(fault == std::string("EIO") ? EIO : ENOSPC));
    const MeasurementCsv rows = read_measurement_csv(csv.string());
    EXPECT_FALSE(rows.truncated_tail);
    EXPECT_EQ(rows.rows.size(), written);
    std::uint64_t after_fault = 0;
    for (std::size_t i = 0; i < rows.rows.size(); ++i) {
      if (i > 0) {
        EXPECT_GT(rows.rows[i].seq, rows.rows[i - 1].seq);
      }
      EXPECT_NE(rows.rows[i].seq, last_lost_seq);
      if (rows.rows[i].seq > last_lost_seq) ++after_fault;
    }
    EXPECT_GE(after_fault, 20u) << "the CSV did not resume after the fault";
    DecodeSummary s;
    std::uint64_t measurements = 0;
    for (const test::DecodedFrame& f : decode(log(), s)) measurements += f.message == "RutMeasurement1";
    EXPECT_EQ(written + lost, measurements);
    std::printf(
        "  injected %lld; CSV: %llu rows written (valid, %llu after the last lost row), %llu lost; %llu "
        "measurements on CAN\n",
        injected, static_cast<unsigned long long>(written), static_cast<unsigned long long>(after_fault),
        static_cast<unsigned long long>(lost), static_cast<unsigned long long>(measurements));
  }
}

TEST_F(Faults, ShortMeasurementCsvWritesLoseNothing) {
  const fs::path csv = tmp_.path() / "m.csv";
  const int rc = run_for("--fault csv-write:short", base_args() + " --csv " + test::quoted(csv), err(), log());
  const std::string text = test::read_text(err());
  ASSERT_EQ(rc, 0) << text;
  EXPECT_GT(number_after(text, "injected csv-write "), 100);
  std::smatch m;
  ASSERT_TRUE(std::regex_search(text, m, std::regex("measurement CSV .*: (\\d+) rows written, 0 lost\n"))) << text;
  const MeasurementCsv rows = read_measurement_csv(csv.string());
  EXPECT_FALSE(rows.truncated_tail);
  EXPECT_EQ(rows.rows.size(), std::stoull(m[1]));
  EXPECT_GT(rows.rows.size(), 30u);
  DecodeSummary s;
  EXPECT_EQ(timeline(decode(log(), s), "RecordingError").raised, 0);
}

TEST_F(Faults, ImageDecodeFailuresRaiseNoCameraAndCountAsSourceErrors) {
  const fs::path rec = tmp_.path() / "synth", config = tmp_.path() / "replay.yaml";
  ASSERT_EQ(test::run_rutd("synth " + test::quoted(rec) + " --frames 30 --size 320x240 >/dev/null"), 0);
  std::ofstream(config) << "source:\n  type: replay\n  replay:\n    dir: " << rec.string()
                        << "\n    paced: true\n    loop: true\n";
  for (const char* fault : {"corrupt", "short", "EIO"}) {
    SCOPED_TRACE(fault);
    const std::string text =
        run_and_check_flag(window("image-decode", fault, 4), "--config " + test::quoted(config), "NoCamera");
    const long long injected = number_after(text, "injected image-decode ");
    EXPECT_GT(injected, 5);
    std::smatch m;
    ASSERT_TRUE(std::regex_search(text, m, std::regex("stopped: .* errors (\\d+)/(\\d+)/(\\d+)"))) << text;
    EXPECT_EQ(std::stoll(m[1]), injected) << text;
    std::printf("  injected %lld, pipeline source errors %s\n", injected, m[1].str().c_str());
  }
}

}  // namespace
}  // namespace rutd
