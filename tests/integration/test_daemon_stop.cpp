// `rutd run` as systemd runs it: SIGTERM must drain and exit 0 within one second (the unit's stop
// contract), with everything published so far complete in its outputs, and every pair it recorded
// accounted for: measured and published, or counted as dropped, stale or refused (none abandoned in the
// pipeline, which a replay of the recording would measure and the vehicle never saw).
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>

#include <chrono>
#include <fstream>
#include <regex>
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
  const std::string rec = (tmp.path() / "rec").string(), err = (tmp.path() / "run.err").string();
  std::vector<std::string> args{RUTD_BINARY, "run", "--candump", log, "--csv", csv, "--record", rec};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  ASSERT_EQ(posix_spawn_file_actions_init(&actions), 0);
  ASSERT_EQ(posix_spawn_file_actions_addopen(&actions, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644), 0);
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, RUTD_BINARY, &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  ASSERT_EQ(spawned, 0);
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

  // Every pair recorded is accounted for by the pipeline, and every one published has its CSV row.
  const std::string text = test::read_text(err);
  std::smatch m;
  ASSERT_TRUE(std::regex_search(text, m, std::regex(R"(recording [^\n]*: (\d+) pairs written, 0 dropped)"))) << text;
  const long long written = std::stoll(m[1]);
  ASSERT_TRUE(std::regex_search(
      text, m,
      std::regex(
          R"(stopped: acquired (\d+) .* published (\d+) .* dropped (\d+) stale (\d+) rejected (\d+) errors \d+/(\d+)/)")))
      << text;
  const long long acquired = std::stoll(m[1]), published = std::stoll(m[2]);
  const long long handled = published + std::stoll(m[3]) + std::stoll(m[4]) + std::stoll(m[5]) + std::stoll(m[6]);
  std::printf("recorded %lld, acquired %lld, published %lld, handled %lld\n", written, acquired, published, handled);
  EXPECT_EQ(written, acquired) << text;
  // Under a sanitizer's slowdown the 400 ms the stop gives the pairs in flight may not do: those left
  // must be said, with their number. At full speed none is left.
  std::smatch left;
  const long long said =
      std::regex_search(text, left, std::regex(R"(stop: (\d+) pairs acquired were still in the pipeline)"))
          ? std::stoll(left[1])
          : 0;
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  EXPECT_EQ(handled + said, acquired) << "pairs acquired but abandoned at the stop unsaid\n" << text;
#else
  EXPECT_EQ(said, 0) << text;
  EXPECT_EQ(handled, acquired) << "pairs acquired but abandoned at the stop\n" << text;
#endif
  EXPECT_EQ(static_cast<long long>(rows.rows.size()), published);
}

}  // namespace
}  // namespace rutd
