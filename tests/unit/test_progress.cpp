// The progress line: drawn in place on a terminal, never on a file or pipe, never under systemd.
#include <pty.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>

#include <gtest/gtest.h>

#include "daemon/progress.hpp"

namespace rutd {
namespace {

std::string contents(std::FILE* f) {
  std::fflush(f);
  std::rewind(f);
  std::string s;
  for (int c; (c = std::fgetc(f)) != EOF;) s += static_cast<char>(c);
  return s;
}

TEST(Progress, TextGivesDoneTotalRateAndTimeLeft) {
  const ProgressLine p("replay", 400, stderr, false, std::chrono::milliseconds(0));
  EXPECT_EQ(p.text(100, 4.0), "replay 100/400 pairs  25.0 /s  0:12 left");
  EXPECT_EQ(p.text(0, 1.0), "replay 0/400 pairs  0.0 /s");
  const ProgressLine unknown("record", 0, stderr, false, std::chrono::milliseconds(0));
  EXPECT_EQ(unknown.text(30, 2.0), "record 30 pairs  15.0 /s");
}

TEST(Progress, DrawsInPlaceOnlyWhenEnabledAndClears) {
  std::FILE* f = std::tmpfile();
  ASSERT_NE(f, nullptr);
  {
    ProgressLine p("bench", 10, f, true, std::chrono::milliseconds(0));
    p.update(3);
    p.update(4);  // within 250 ms of the last draw: not redrawn
  }
  const std::string s = contents(f);
  EXPECT_EQ(s.rfind("\rbench 3/10 pairs", 0), 0u) << s;
  EXPECT_EQ(s.find("4/10"), std::string::npos) << s;
  EXPECT_EQ(s.substr(s.size() - 4), "\r\x1b[K") << "cleared at the end";
  std::fclose(f);

  std::FILE* g = std::tmpfile();
  {
    ProgressLine p("bench", 10, g, false, std::chrono::milliseconds(0));
    p.update(3);
  }
  EXPECT_EQ(contents(g), "");
  std::fclose(g);
}

TEST(Progress, WantedOnATerminalOnlyAndNeverUnderSystemd) {
  int master = -1, slave = -1;
  ASSERT_EQ(openpty(&master, &slave, nullptr, nullptr, nullptr), 0);
  int pipe_fds[2];
  ASSERT_EQ(pipe(pipe_fds), 0);
  unsetenv("INVOCATION_ID");
  unsetenv("JOURNAL_STREAM");
  EXPECT_TRUE(progress_wanted(slave));
  EXPECT_FALSE(progress_wanted(pipe_fds[1]));
  setenv("INVOCATION_ID", "0123456789abcdef", 1);
  EXPECT_FALSE(progress_wanted(slave));
  unsetenv("INVOCATION_ID");
  setenv("JOURNAL_STREAM", "8:12345", 1);
  EXPECT_FALSE(progress_wanted(slave));
  unsetenv("JOURNAL_STREAM");
  close(master);
  close(slave);
  close(pipe_fds[0]);
  close(pipe_fds[1]);
}

}  // namespace
}  // namespace rutd
