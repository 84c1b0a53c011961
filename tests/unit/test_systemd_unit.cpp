// The service unit passes systemd's own checker (systemd-analyze verify), pointed at the built rutd.
#include <cstdio>
#include <fstream>
#include <regex>
#include <sstream>

#include <gtest/gtest.h>

#include "test_support.hpp"

namespace rutd {
namespace {

TEST(SystemdUnit, VerifiesWithSystemdAnalyze) {
  if (std::system("command -v systemd-analyze >/dev/null 2>&1") != 0)
    RUTD_SKIP_NEEDS_INSTALLED("needs systemd-analyze (Debian package systemd)");
  std::string unit = test::read_text(std::string(RUTD_SOURCE_DIR) + "/systemd/rutd.service.in");
  ASSERT_FALSE(unit.empty());
  unit = std::regex_replace(unit, std::regex("@RUTD_BINDIR@/rutd"), RUTD_BINARY);
  unit = std::regex_replace(unit, std::regex("@RUTD_CONFIG_DIR@"), "/etc/rutd");
  unit = std::regex_replace(unit, std::regex("@RUTD_DOC_DIR@"), "/usr/share/doc/rutd");
  ASSERT_FALSE(std::regex_search(unit, std::regex("@[A-Z_]+@"))) << "unsubstituted variable left in the unit";
  const test::TempDir tmp;
  const std::string path = (tmp.path() / "rutd.service").string();
  std::ofstream(path) << unit;
  const std::string err = (tmp.path() / "err.txt").string();
  const int status = std::system(("systemd-analyze verify '" + path + "' 2>'" + err + "'").c_str());
  const std::string messages = test::read_text(err);
  EXPECT_EQ(status, 0) << messages;
  EXPECT_EQ(messages.find("rutd.service"), std::string::npos) << messages;
  // The properties the product relies on.
  EXPECT_NE(unit.find("Type=notify"), std::string::npos);
  EXPECT_NE(unit.find("WatchdogSec="), std::string::npos);
  EXPECT_NE(unit.find("Restart=on-failure"), std::string::npos);
  EXPECT_NE(unit.find("ProtectSystem=strict"), std::string::npos);
  EXPECT_NE(unit.find("AF_CAN"), std::string::npos);
}

}  // namespace
}  // namespace rutd
