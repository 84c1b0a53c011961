// What the rutd program says about itself and about starting, as the package and the unit rely on it:
// `rutd --version` names the project version of CMakeLists.txt and the commit git reports for the source
// tree; `rutd run --check` passes the bench default and refuses the vehicle configuration as installed
// (no cameras), naming the key; and the exit status of a failed start tells systemd whether a restart can
// help (2: bad input, RestartPreventExitStatus=2; 1: a CAN interface that is not there, restarted).
#include <cstdio>
#include <fstream>
#include <regex>
#include <string>

#include <gtest/gtest.h>

#include "test_support.hpp"

namespace rutd {
namespace {

// The output of a shell command, and its exit status (-1 if it did not exit).
std::string shell_output(const std::string& cmd, int& status) {
  std::string out;
  status = -1;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return out;
  char buf[4096];
  while (std::fgets(buf, sizeof buf, p)) out += buf;
  const int s = pclose(p);
  status = WIFEXITED(s) ? WEXITSTATUS(s) : -1;
  return out;
}

TEST(Version, NamesTheProjectVersionAndTheCommitGitReports) {
  std::smatch m;
  const std::string cmake = test::read_text(std::string(RUTD_SOURCE_DIR) + "/CMakeLists.txt");
  ASSERT_TRUE(std::regex_search(cmake, m, std::regex(R"(project\(rutd VERSION ([0-9]+\.[0-9]+\.[0-9]+))")));
  const std::string project_version = m[1];

  int status = -1;
  const std::string line = test::run_rutd_output("--version", status);
  EXPECT_EQ(status, 0);
  EXPECT_TRUE(line.starts_with("rutd " + project_version + "-")) << line;

  int git_status = -1;
  std::string head =
      shell_output("git -C " + test::quoted(RUTD_SOURCE_DIR) + " rev-parse HEAD 2>/dev/null", git_status);
  if (git_status != 0) {
    EXPECT_NE(line.find("(commit unknown: not built from a git checkout)"), std::string::npos) << line;
    return;
  }
  head.erase(head.find_last_not_of('\n') + 1);
  EXPECT_NE(line.find("(git " + head), std::string::npos)
      << line << "git says HEAD is " << head << " (a program built before the last commit: rebuild)";
}

TEST(RunCheck, PassesTheBenchDefaultAndRefusesTheInstalledVehicleConfigurationNamingTheKey) {
  int status = -1;
  const std::string out = test::run_rutd_output("run --check", status);
  EXPECT_EQ(status, 0);
  EXPECT_NE(out.find("ready to run: source synthetic"), std::string::npos) << out;

  const test::TempDir tmp;
  const std::string err = (tmp.path() / "err.txt").string();
  EXPECT_EQ(test::run_rutd("run --check --config " + test::quoted(RUTD_INSTALLED_CONFIG), err), 2);
  EXPECT_NE(test::read_text(err).find("source.aravis.left"), std::string::npos) << test::read_text(err);
}

TEST(StartErrors, BadInputExitsTwoAndAMissingCanInterfaceOne) {
  const test::TempDir tmp;
  const std::string config = (tmp.path() / "typo.yaml").string();
  std::ofstream(config) << "measurement:\n  engnie: bm\n";
  const std::string err = (tmp.path() / "err.txt").string();
  EXPECT_EQ(test::run_rutd("run --config " + test::quoted(config) + " --frames 1", err), 2);
  EXPECT_NE(test::read_text(err).find("measurement.engnie"), std::string::npos) << test::read_text(err);

  // Without the interface, or without CAN in the kernel (CI): the system refuses the socket either way.
  EXPECT_EQ(test::run_rutd("run --socketcan rutdnocan0 --candump '' --size 160x120 --frames 1", err), 1);
  EXPECT_NE(test::read_text(err).find("SocketCAN interface 'rutdnocan0'"), std::string::npos) << test::read_text(err);
}

}  // namespace
}  // namespace rutd
