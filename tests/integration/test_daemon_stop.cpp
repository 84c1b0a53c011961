// `rutd run` as systemd runs it: SIGTERM must drain and exit 0 within one second (the unit's stop
// contract), with everything published so far complete in its outputs.
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>

#include <chrono>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "can/candump_log.hpp"
#include "recording/measurement_csv.hpp"
#include "test_support.hpp"

extern char** environ;

namespace rutd {
namespace {

using namespace std::chrono_literals;

TEST(DaemonStop, SigtermDrainsAndExitsZeroWithinOneSecond) {
  const test::TempDir tmp;
  const std::string log = (tmp.path() / "can.log").string(), csv = (tmp.path() / "m.csv").string();
  std::vector<std::string> args{RUTD_BINARY, "run", "--candump", log, "--csv", csv};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  ASSERT_EQ(posix_spawn(&pid, RUTD_BINARY, nullptr, nullptr, argv.data(), environ), 0);
  // A failed assertion below returns early: the daemon must not outlive the test (an orphan holding
  // CTest's output pipe makes CTest wait for it forever).
  struct Reaper {
    pid_t& pid;
    ~Reaper() {
      if (pid > 0 && kill(pid, SIGKILL) == 0) waitpid(pid, nullptr, 0);
    }
  } reaper{pid};

  // Wait for measurements to flow (the first frames render and prime the pipeline).
  const auto deadline = std::chrono::steady_clock::now() + 60s;
  while (test::count_lines(log, "18FF50A0#") < 5 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(50ms);
  ASSERT_GE(test::count_lines(log, "18FF50A0#"), 5) << "no measurements within 60 s";

  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_EQ(kill(pid, SIGTERM), 0);
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  pid = 0;  // reaped
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("exit %.3f s after SIGTERM\n", seconds);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
  EXPECT_LT(seconds, 1.0);

  // Every line of both outputs is complete and parses.
  std::ifstream in(log);
  int frames = 0;
  for (std::string line; std::getline(in, line); ++frames) EXPECT_TRUE(parse_candump_line(line)) << line;
  EXPECT_GT(frames, 10);
  const auto rows = read_measurement_csv(csv);
  EXPECT_FALSE(rows.truncated_tail);
  EXPECT_GE(rows.rows.size(), 5u);
}

}  // namespace
}  // namespace rutd
