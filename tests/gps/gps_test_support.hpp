#pragma once
// What the gpsd tests share: a free loopback port, processes started in their own process group (gpsfake
// and the gpsd it starts, the fake gpsd) and stopped with it, the drive logs nmea_drive.py writes and the
// truth it writes beside them.
#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "core/track.hpp"
#include "skip_policy.hpp"
#include "test_support.hpp"

extern char** environ;

namespace rutd::test {

namespace fs = std::filesystem;

inline const std::string kGpsTestDir = std::string(RUTD_SOURCE_DIR) + "/tests/gps";
// NMEA writes 1e-5 minute of arc (1.7e-7 degree); gpsd reports 9 decimals of a degree.
inline constexpr double kNmeaResolutionDeg = 1e-5 / 60.0;

inline bool gpsfake_installed() { return fs::exists("/usr/bin/gpsfake") && fs::exists("/usr/sbin/gpsd"); }

// Lines for fake_gpsd.py's sessions, one a line.
inline void write_lines(const fs::path& file, const std::vector<std::string>& lines) {
  std::ofstream out(file);
  for (const auto& l : lines) out << l << '\n';
}

// A gpsd TPV report (3D fix) as gpsd 3.22 writes it, at `time` (ISO 8601, UTC).
inline std::string tpv(const std::string& time, double lat, double lon) {
  return R"({"class":"TPV","device":"/dev/ttyACM0","mode":3,"time":")" + time + R"(","ept":0.005,"lat":)" +
         std::to_string(lat) + R"(,"lon":)" + std::to_string(lon) +
         R"(,"altHAE":1340.0,"altMSL":1340.0,"alt":1340.0,"track":90.0,"speed":2.0,"eph":1.5})";
}

// A port nobody listens on now (the kernel's choice for a socket bound to port 0).
inline int free_loopback_port() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
  socklen_t len = sizeof a;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
  ::close(fd);
  return ntohs(a.sin_port);
}

inline bool port_accepts(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  const bool ok = ::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  ::close(fd);
  return ok;
}

// A process and its children in a group of their own; killed (the whole group) when destroyed.
class ProcessGroup {
 public:
  ProcessGroup(const std::vector<std::string>& args, const fs::path& log) {
    std::vector<std::string> copy = args;
    std::vector<char*> argv;
    for (auto& s : copy) argv.push_back(s.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&actions, 1, 2);
    posix_spawnattr_t attr;
    posix_spawnattr_init(&attr);
    posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP);
    posix_spawnattr_setpgroup(&attr, 0);
    if (posix_spawnp(&pid_, argv[0], &actions, &attr, argv.data(), environ) != 0) pid_ = -1;
    posix_spawn_file_actions_destroy(&actions);
    posix_spawnattr_destroy(&attr);
  }
  ~ProcessGroup() { stop(); }
  ProcessGroup(const ProcessGroup&) = delete;
  ProcessGroup& operator=(const ProcessGroup&) = delete;
  bool started() const { return pid_ > 0; }
  // True once the process has ended by itself (reaped).
  bool ended() {
    if (pid_ <= 0) return true;
    int status = 0;
    if (::waitpid(pid_, &status, WNOHANG) == pid_) {
      ::kill(-pid_, SIGTERM);  // what it left behind in its group (gpsfake's gpsd)
      pid_ = -1;
      return true;
    }
    return false;
  }
  void stop() {
    if (pid_ <= 0) return;
    ::kill(-pid_, SIGTERM);
    int status = 0;
    for (int i = 0; i < 100 && ::waitpid(pid_, &status, WNOHANG) == 0; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    ::kill(-pid_, SIGKILL);
    ::waitpid(pid_, &status, 0);
    pid_ = -1;
  }

 private:
  pid_t pid_ = -1;
};

inline bool wait_for_port(int port, std::chrono::milliseconds limit) {
  const auto end = std::chrono::steady_clock::now() + limit;
  while (std::chrono::steady_clock::now() < end) {
    if (port_accepts(port)) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return false;
}

// One epoch as nmea_drive.py wrote it (the position as written in the log, read back).
struct TruthEpoch {
  int epoch = 0;
  bool fix = false;
  double lat = NAN, lon = NAN, alt = NAN, track = NAN;
};

inline std::vector<TruthEpoch> read_truth(const fs::path& csv) {
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);
  std::vector<TruthEpoch> out;
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::stringstream ss(line);
    for (std::string x; std::getline(ss, x, ',');) f.push_back(x);
    f.resize(8);
    TruthEpoch t;
    t.epoch = std::stoi(f[0]);
    t.fix = f[2] == "1";
    if (t.fix) {
      t.lat = std::stod(f[3]);
      t.lon = std::stod(f[4]);
      t.alt = std::stod(f[5]);
      t.track = std::stod(f[6]);
    }
    out.push_back(t);
  }
  return out;
}

// The epoch whose written position this is (within the log's resolution), or -1.
inline int matching_epoch(const std::vector<TruthEpoch>& truth, double lat, double lon) {
  for (const TruthEpoch& t : truth)
    if (t.fix && std::abs(t.lat - lat) <= kNmeaResolutionDeg && std::abs(t.lon - lon) <= kNmeaResolutionDeg)
      return t.epoch;
  return -1;
}

// Writes a drive log (nmea_drive.py) into dir: drive.nmea and drive_truth.csv.
inline void write_drive(const fs::path& dir, const std::string& extra_args) {
  const std::string cmd = "/usr/bin/python3 " + test::quoted(fs::path(kGpsTestDir) / "nmea_drive.py") + " --out " +
                          test::quoted(dir / "drive.nmea") + " --truth " + test::quoted(dir / "drive_truth.csv") + " " +
                          extra_args;
  ASSERT_EQ(run_shell(cmd), 0) << cmd;
}

}  // namespace rutd::test
