// rutd_faults: `rutd run` with faults injected at its lowest I/O calls, for the fault tests
// (tests/integration/test_faults.cpp). The daemon code is rutd's own (add_run_command); this program
// only builds the IoFaults it is handed (core/io_faults.hpp), so the rutd executable has no way to
// switch a fault on. Not installed.
//
// Usage: rutd_faults [--fault SPEC]... [--can-socketpair] run [rutd run options]
//   SPEC = POINT:FAULT[:every=N][:from=S][:until=S]
//     POINT  camera-pop | can-write | record-write | image-decode | csv-write
//     FAULT  timeout | corrupt | short | an errno name: EAGAIN ENOBUFS ENETDOWN ENOSPC EIO
//     every=N  every Nth call in the window fails (default 1); from/until: the window, in seconds since
//              the first call at that point (default: the whole run).
//   --can-socketpair  sinks.socketcan (or --socketcan NAME) opens one end of a socketpair instead of a
//              CAN socket; a thread reads the other end. Runs the CAN path without CAN kernel support.
// At exit, one line on stderr per point: "injected POINT N"; with --can-socketpair "peer received N".
#include <fcntl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "core/input_error.hpp"
#include "daemon/commands.hpp"

namespace {

const std::map<std::string, rutd::IoPoint> kPoints{{"camera-pop", rutd::IoPoint::CameraPop},
                                                   {"can-write", rutd::IoPoint::CanWrite},
                                                   {"record-write", rutd::IoPoint::RecordWrite},
                                                   {"image-decode", rutd::IoPoint::ImageDecode},
                                                   {"csv-write", rutd::IoPoint::MeasurementWrite}};
const std::map<std::string, int> kFaults{{"timeout", rutd::io_fault::kTimeout},
                                         {"corrupt", rutd::io_fault::kCorrupt},
                                         {"short", rutd::io_fault::kShort},
                                         {"EAGAIN", EAGAIN},
                                         {"ENOBUFS", ENOBUFS},
                                         {"ENETDOWN", ENETDOWN},
                                         {"ENOSPC", ENOSPC},
                                         {"EIO", EIO}};

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out(1);
  for (char c : s) {
    if (c == sep) {
      out.emplace_back();
    } else {
      out.back().push_back(c);
    }
  }
  return out;
}

// Throws std::invalid_argument naming the part of SPEC at fault.
void add_fault(rutd::IoFaults& faults, const std::string& spec) {
  const std::vector<std::string> parts = split(spec, ':');
  if (parts.size() < 2) throw std::invalid_argument("--fault " + spec + ": expected POINT:FAULT[:key=value]...");
  const auto point = kPoints.find(parts[0]);
  if (point == kPoints.end()) throw std::invalid_argument("--fault " + spec + ": unknown point '" + parts[0] + "'");
  const auto fault = kFaults.find(parts[1]);
  if (fault == kFaults.end()) throw std::invalid_argument("--fault " + spec + ": unknown fault '" + parts[1] + "'");
  rutd::IoFaultRule rule;
  rule.fault = fault->second;
  for (std::size_t i = 2; i < parts.size(); ++i) {
    const auto eq = parts[i].find('=');
    const std::string key = parts[i].substr(0, eq), value = eq == std::string::npos ? "" : parts[i].substr(eq + 1);
    try {
      if (key == "every" && std::stoull(value) > 0) {
        rule.every = std::stoull(value);
      } else if (key == "from") {
        rule.from_s = std::stod(value);
      } else if (key == "until") {
        rule.until_s = std::stod(value);
      } else {
        throw std::invalid_argument(key);
      }
    } catch (const std::exception&) {
      throw std::invalid_argument("--fault " + spec + ": bad '" + parts[i] + "'");
    }
  }
  faults.set(point->second, rule);
}

}  // namespace

int main(int argc, char** argv) {
  spdlog::set_default_logger(spdlog::stderr_color_mt("rutd"));
  spdlog::set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ %v");
  rutd::IoFaults faults;
  bool socketpair_bus = false;
  std::vector<char*> rest{argv[0]};
  try {
    int i = 1;
    for (; i < argc && std::strcmp(argv[i], "run") != 0; ++i) {
      if (std::strcmp(argv[i], "--fault") == 0 && i + 1 < argc) {
        add_fault(faults, argv[++i]);
      } else if (std::strcmp(argv[i], "--can-socketpair") == 0) {
        socketpair_bus = true;
      } else {
        throw std::invalid_argument(std::string("unknown argument '") + argv[i] + "' before 'run'");
      }
    }
    for (; i < argc; ++i) rest.push_back(argv[i]);
  } catch (const std::exception& e) {
    std::cerr << "rutd_faults: " << e.what() << '\n';
    return 2;
  }

  rutd::RunInjection injection;
  injection.faults = &faults;
  std::atomic<std::uint64_t> peer_frames{0};
  std::thread peer;
  auto bus_adopted = std::make_shared<bool>(false);
  int bus_fd = -1;
  if (socketpair_bus) {
    int fds[2];
    if (socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, fds) != 0) {
      std::perror("rutd_faults: socketpair");
      return 2;
    }
    // The bus's end never blocks (as the CAN socket); the peer reads until the bus closes its end.
    bus_fd = fds[0];
    const int peer_fd = fds[1];
    if (fcntl(bus_fd, F_SETFL, O_NONBLOCK) != 0) return 2;
    peer = std::thread([peer_fd, &peer_frames] {
      char frame[64];
      while (::recv(peer_fd, frame, sizeof frame, 0) > 0) peer_frames.fetch_add(1, std::memory_order_relaxed);
      ::close(peer_fd);
    });
    injection.open_bus = [bus_fd, bus_adopted, &faults](const std::string& name) {
      *bus_adopted = true;
      return rutd::SocketCanBus::adopt(bus_fd, name, &faults);
    };
  }

  CLI::App app{"rutd run with injected I/O faults (tests only)"};
  app.require_subcommand(1);
  int exit_code = 0;
  rutd::add_run_command(app, exit_code, injection);
  try {
    app.parse(static_cast<int>(rest.size()), rest.data());
  } catch (const CLI::ParseError& e) {
    exit_code = app.exit(e);
  } catch (const std::exception& e) {
    std::cerr << "rutd_faults: error: " << e.what() << '\n';
    exit_code = 2;
  }
  for (const auto& [name, point] : kPoints)
    std::fprintf(stderr, "injected %s %llu\n", name.c_str(), static_cast<unsigned long long>(faults.injected(point)));
  if (peer.joinable()) {
    if (!*bus_adopted) ::close(bus_fd);  // the run never opened the bus
    peer.join();                         // the bus closed its end when the run ended
    std::fprintf(stderr, "peer received %llu\n", static_cast<unsigned long long>(peer_frames.load()));
  }
  return exit_code;
}
